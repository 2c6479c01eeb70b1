//! Writes the degraded-render benchmark's images (scripts/bench-tags-degraded.py runs vservo and the AprilTag C
//! library on them): one tag36h11 tag (id 3, 0.16 m) on its white sheet, seen at 640 × 480 from twenty poses per
//! condition, degraded one way at a time — motion blur, defocus, noise, JPEG, a lighting gradient, a bent paper —
//! and at tag edges from 12 to 400 px (at 1280 × 1024, where a tag of 400 px fits with its margin). Each image is an 8-bit PGM (a JPEG is decoded once, here, so that both
//! detectors read the same pixels), and `truth.json` gives each one's condition, level, tag edge and true corners
//! (the projection of the tag's corners, in the C library's order, in vservo's pixels: pixel centres at + ½).
//! Apart from the condition itself every image has noise of σ = 1 gray level.
//! `cargo run --release -p vservo-vision --example degraded_tags -- DIR`

use std::fmt::Write as _;
use std::path::Path;

use image::codecs::jpeg::JpegEncoder;
use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
use image::{ExtendedColorType, GrayImage};
use nalgebra::{Point2, Point3, Rotation3, Translation3, Vector3};
use vservo_scene::{AprilTag, Board, CameraIntrinsics, IsometryMatrix3};
use vservo_vision::noise::{GaussianTable, Xorshift64};
use vservo_vision::{RenderSettings, Renderer};

const FOCAL_PX: f64 = 500.0;
const TAG_M: f64 = 0.16;
const POSES: usize = 20;
/// Every image's noise but the noise condition's (gray levels).
const BASE_NOISE: f64 = 1.0;

/// One way of degrading the image, and its levels.
#[derive(Clone, Copy)]
enum Condition {
    MotionBlurPx,
    DefocusSigmaPx,
    NoiseSigma,
    JpegQuality,
    LightingGradient,
    BentPaperMm,
    TagEdgePx,
}

impl Condition {
    fn name(self) -> &'static str {
        match self {
            Condition::MotionBlurPx => "motion_blur_px",
            Condition::DefocusSigmaPx => "defocus_sigma_px",
            Condition::NoiseSigma => "noise_sigma",
            Condition::JpegQuality => "jpeg_quality",
            Condition::LightingGradient => "lighting_gradient",
            Condition::BentPaperMm => "bent_paper_mm",
            Condition::TagEdgePx => "tag_edge_px",
        }
    }

    fn levels(self) -> &'static [f64] {
        match self {
            Condition::MotionBlurPx => &[0.0, 2.0, 4.0, 6.0, 8.0, 10.0],
            Condition::DefocusSigmaPx => &[0.0, 0.5, 1.0, 1.5, 2.0, 3.0],
            Condition::NoiseSigma => &[0.0, 2.0, 4.0, 6.0, 8.0, 10.0],
            Condition::JpegQuality => &[95.0, 85.0, 75.0, 65.0, 50.0],
            Condition::LightingGradient => &[0.0, 0.2, 0.4, 0.6, 0.8],
            Condition::BentPaperMm => &[0.0, 1.0, 2.0, 3.0],
            Condition::TagEdgePx => &[12.0, 16.0, 20.0, 30.0, 50.0, 100.0, 200.0, 400.0],
        }
    }
}

/// A small deterministic generator for the poses (the same images on every machine).
struct Poses(u64);

impl Poses {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// The board in the camera: the tag's centre near the image's middle, its edge about `edge_px`, tilted by
    /// up to `tilt_rad` about x and y and turned any way about the optical axis.
    fn pose(&mut self, tag: &AprilTag, edge_px: f64, tilt_rad: f64, height_px: f64) -> IsometryMatrix3<f64> {
        let depth_m = FOCAL_PX * TAG_M / edge_px;
        let rotation = Rotation3::from_euler_angles(
            self.uniform(-tilt_rad, tilt_rad),
            self.uniform(-tilt_rad, tilt_rad),
            self.uniform(-std::f64::consts::PI, std::f64::consts::PI),
        );
        // the tag's centre at (cx, cy, depth) in the camera
        let offset_px = (0.15 * (height_px - edge_px).max(0.0)).min(60.0);
        let centre_in_camera = Vector3::new(
            self.uniform(-offset_px, offset_px) * depth_m / FOCAL_PX,
            self.uniform(-offset_px, offset_px) * depth_m / FOCAL_PX,
            depth_m,
        );
        let centre = tag.centre_in_board();
        let translation = centre_in_camera - rotation * Vector3::new(centre.x, centre.y, 0.0);
        IsometryMatrix3::from_parts(Translation3::from(translation), rotation)
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: degraded_tags DIR")?);
    std::fs::create_dir_all(&dir)?;
    let tag = AprilTag::tag36h11(3, TAG_M, Point2::new(0.0, 0.0))?;
    let board = Board::with_apriltag(tag, tag.sheet_extent_in_board());
    let camera_of = |width: u32, height: u32| {
        let centre = Point2::new(f64::from(width) / 2.0, f64::from(height) / 2.0);
        CameraIntrinsics::new(FOCAL_PX, centre, width, height)
    };
    let (vga, large) = (camera_of(640, 480)?, camera_of(1280, 1024)?);
    let mut truth = String::from("{\n");
    let mut count = 0;
    let conditions = [
        Condition::MotionBlurPx,
        Condition::DefocusSigmaPx,
        Condition::NoiseSigma,
        Condition::JpegQuality,
        Condition::LightingGradient,
        Condition::BentPaperMm,
        Condition::TagEdgePx,
    ];
    for condition in conditions {
        for &level in condition.levels() {
            let mut poses = Poses(0x5EED + count as u64);
            for k in 0..POSES {
                let (edge_px, camera) =
                    if let Condition::TagEdgePx = condition { (level, &large) } else { (100.0, &vga) };
                let tilt = if edge_px > 150.0 { 0.25 } else { 0.5 };
                let pose = inside_pose(&mut poses, (&tag, camera, &board), edge_px, tilt)?;
                let corners = camera.project_marks(&board, &pose)?;
                let image = degraded(condition, level, camera, &board, &pose, k as u64)?;
                let name = format!("{}_{level}_{k}", condition.name());
                write_pgm(&dir.join(format!("{name}.pgm")), &image)?;
                let list: Vec<String> = corners.iter().map(|v| format!("{v:.6}")).collect();
                let _ = writeln!(
                    truth,
                    "{}\"{name}\": {{\"condition\": \"{}\", \"level\": {level}, \"edge_px\": {edge_px}, \"id\": 3, \
                     \"corners_px\": [{}]}}",
                    if count > 0 { "," } else { "" },
                    condition.name(),
                    list.join(", ")
                );
                count += 1;
            }
        }
    }
    truth.push_str("}\n");
    std::fs::write(dir.join("truth.json"), truth)?;
    println!("wrote {count} images and truth.json to {}", dir.display());
    Ok(())
}

/// A pose whose tag lies in the image with a margin of two cells of the tag.
fn inside_pose(
    poses: &mut Poses,
    (tag, camera, board): (&AprilTag, &CameraIntrinsics, &Board),
    edge_px: f64,
    tilt: f64,
) -> Result<IsometryMatrix3<f64>, Box<dyn std::error::Error>> {
    let margin = 2.0 * edge_px / 8.0 + 2.0;
    let (width, height) = (f64::from(camera.width_px()), f64::from(camera.height_px()));
    for _ in 0..1000 {
        let pose = poses.pose(tag, edge_px, tilt, height);
        let corners = camera.project_marks(board, &pose)?;
        let inside = (0..4).all(|m| {
            let (x, y) = (corners[2 * m], corners[2 * m + 1]);
            x > margin && y > margin && x < width - margin && y < height - margin
        });
        if inside {
            return Ok(pose);
        }
    }
    Err(format!("no pose keeps a tag of {edge_px} px inside the image").into())
}

/// The image of `condition` at `level`, the `k`-th pose.
fn degraded(
    condition: Condition,
    level: f64,
    camera: &CameraIntrinsics,
    board: &Board,
    pose: &IsometryMatrix3<f64>,
    k: u64,
) -> Result<GrayImage, Box<dyn std::error::Error>> {
    let noisy = |sigma: f64| RenderSettings {
        noise_sigma_gray: sigma,
        noise_seed: 17 + k,
        lighting_gradient: [0.0, 0.0],
        ..Default::default()
    };
    let clean = noisy(0.0);
    Ok(match condition {
        Condition::NoiseSigma => Renderer::new(*camera, noisy(level)).render(board, pose, k).clone(),
        Condition::TagEdgePx => Renderer::new(*camera, noisy(BASE_NOISE)).render(board, pose, k).clone(),
        Condition::LightingGradient => {
            let lit = RenderSettings { lighting_gradient: [level, -0.5 * level], ..noisy(BASE_NOISE) };
            Renderer::new(*camera, lit).render(board, pose, k).clone()
        }
        Condition::MotionBlurPx => {
            // the board slides along the image's x during the exposure, centred on the pose
            let instants = if level > 0.0 { 2 * level as usize + 1 } else { 1 };
            let depth = pose.translation.z;
            let sweep: Vec<IsometryMatrix3<f64>> = (0..instants)
                .map(|i| {
                    let s = if instants == 1 { 0.0 } else { i as f64 / (instants - 1) as f64 - 0.5 };
                    let shift = Translation3::new(s * level * depth / FOCAL_PX, 0.0, 0.0);
                    IsometryMatrix3::from_parts(shift * pose.translation, pose.rotation)
                })
                .collect();
            Renderer::new(*camera, noisy(BASE_NOISE)).render_exposure(board, &sweep, k).clone()
        }
        Condition::DefocusSigmaPx => {
            let sharp = Renderer::new(*camera, clean).render(board, pose, k).clone();
            let blurred = if level > 0.0 { image::imageops::blur(&sharp, level as f32) } else { sharp };
            with_noise(blurred, BASE_NOISE, k)
        }
        Condition::JpegQuality => {
            let image = Renderer::new(*camera, noisy(BASE_NOISE)).render(board, pose, k).clone();
            let mut bytes = Vec::new();
            JpegEncoder::new_with_quality(&mut bytes, level as u8).encode(
                image.as_raw(),
                image.width(),
                image.height(),
                ExtendedColorType::L8,
            )?;
            image::load_from_memory(&bytes)?.to_luma8()
        }
        Condition::BentPaperMm => with_noise(bent(camera, board, pose, level * 1e-3), BASE_NOISE, k),
    })
}

/// Gaussian noise of `sigma` gray levels added to `image`.
fn with_noise(mut image: GrayImage, sigma: f64, seed: u64) -> GrayImage {
    let table = GaussianTable::new(sigma);
    let mut rng = Xorshift64::new(seed);
    for pixel in image.iter_mut() {
        *pixel = (f32::from(*pixel) + table.sample(rng.next_u64()) + 0.5).clamp(0.0, 255.0) as u8;
    }
    image
}

/// The sheet bent into a cylinder across the tag's x: it bulges by `bend_m` towards the camera along the tag's
/// middle column and lies flat at its left and right edges (where the corners stay), ray-cast with 4 × 4 rays a
/// pixel. The tag's corners are where the flat tag's are.
fn bent(camera: &CameraIntrinsics, board: &Board, pose: &IsometryMatrix3<f64>, bend_m: f64) -> GrayImage {
    let tag = board.apriltag().expect("a tag board");
    let settings = RenderSettings::default();
    let [lo, hi] = board.extent_in_board;
    let half = 0.5 * tag.size_m();
    let centre = tag.centre_in_board();
    let height_m = |x: f64| {
        let u = ((x - centre.x) / half).clamp(-1.0, 1.0);
        bend_m * (1.0 - u * u)
    };
    let board_from_camera = pose.inverse();
    let origin = board_from_camera * Point3::origin();
    // the camera is on the board's −z side when the board faces it: towards the camera is the origin's side
    let towards_camera = origin.z.signum();
    let (fx, fy) = (camera.fx_px(), camera.fy_px());
    let principal = camera.principal_point_px();
    GrayImage::from_fn(camera.width_px(), camera.height_px(), |u, v| {
        let mut sum = 0.0;
        for j in 0..4 {
            for i in 0..4 {
                let x = (f64::from(u) + (f64::from(i) + 0.5) / 4.0 - principal.x) / fx;
                let y = (f64::from(v) + (f64::from(j) + 0.5) / 4.0 - principal.y) / fy;
                let direction = board_from_camera.rotation * Vector3::new(x, y, 1.0);
                // the ray meets z = towards_camera · h(x): from the flat plane, a few fixed-point steps
                let mut t = -origin.z / direction.z;
                for _ in 0..6 {
                    let hit_x = origin.x + t * direction.x;
                    t = (towards_camera * height_m(hit_x) - origin.z) / direction.z;
                }
                let hit = origin + t * direction;
                let on_sheet = hit.x >= lo.x && hit.x <= hi.x && hit.y >= lo.y && hit.y <= hi.y;
                sum += if !on_sheet || t <= 0.0 {
                    settings.background_gray
                } else if tag.is_black_at(hit.x, hit.y) == Some(true) {
                    settings.mark_gray
                } else {
                    settings.board_gray
                };
            }
        }
        image::Luma([(sum / 16.0).round() as u8])
    })
}

fn write_pgm(path: &Path, image: &GrayImage) -> Result<(), Box<dyn std::error::Error>> {
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    // binary PGM (P5): the encoder's default for a .pgm name would be PAM (P7)
    PnmEncoder::new(file).with_subtype(PnmSubtype::Graymap(SampleEncoding::Binary)).encode(
        image.as_raw().as_slice(),
        image.width(),
        image.height(),
        ExtendedColorType::L8,
    )?;
    Ok(())
}
