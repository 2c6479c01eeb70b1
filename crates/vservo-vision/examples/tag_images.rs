//! Writes the AprilTag benchmark's images (crates/vservo-vision/benches/apriltag.rs: one tag36h11 tag, id 3,
//! about 200 px wide at 640 × 480 and 400 px at 1280 × 1024, clean and with noise of σ = 5 gray levels) as
//! PGM files, with `truth.json` giving each image's true corners (the projection of the tag's corners, in
//! the C library's order), so that another detector can be measured on the same images.
//! `cargo run -p vservo-vision --example tag_images -- DIR`

use std::fmt::Write as _;

use image::ExtendedColorType;
use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
use nalgebra::{Point2, Rotation3, Translation3, Vector3};
use vservo_scene::{AprilTag, Board, CameraIntrinsics, IsometryMatrix3};
use vservo_vision::{RenderSettings, Renderer};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: tag_images DIR")?);
    std::fs::create_dir_all(&dir)?;
    let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135))?;
    let board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
    let pose = IsometryMatrix3::from_parts(
        Translation3::new(0.02, 0.15, 0.4),
        Rotation3::from_scaled_axis(Vector3::new(0.1, -0.15, 0.3)),
    );
    let mut truth = String::from("{");
    for (width, height) in [(640u32, 480u32), (1280, 1024)] {
        let focal = 500.0 * f64::from(width) / 640.0;
        let centre = Point2::new(f64::from(width) / 2.0, f64::from(height) / 2.0);
        let camera = CameraIntrinsics::new(focal, centre, width, height)?;
        let corners = camera.project_marks(&board, &pose)?;
        for (noise, sigma) in [("clean", 0.0), ("sigma5", 5.0)] {
            let settings = RenderSettings {
                noise_sigma_gray: sigma,
                lighting_gradient: [0.0, 0.0],
                ..Default::default()
            };
            let image = Renderer::new(camera, settings).render(&board, &pose, 1).clone();
            let name = format!("{width}x{height}_{noise}");
            // binary PGM (P5): the encoder's default for a .pgm name would be PAM (P7)
            let file = std::io::BufWriter::new(std::fs::File::create(dir.join(format!("{name}.pgm")))?);
            PnmEncoder::new(file).with_subtype(PnmSubtype::Graymap(SampleEncoding::Binary)).encode(
                image.as_raw().as_slice(),
                width,
                height,
                ExtendedColorType::L8,
            )?;
            let list: Vec<String> = corners.iter().map(|v| format!("{v:.6}")).collect();
            let _ =
                write!(truth, "{}\"{name}\": [{}]", if truth.len() > 1 { ", " } else { "" }, list.join(", "));
        }
    }
    truth.push_str("}\n");
    std::fs::write(dir.join("truth.json"), truth)?;
    println!("wrote 4 images and truth.json to {}", dir.display());
    Ok(())
}
