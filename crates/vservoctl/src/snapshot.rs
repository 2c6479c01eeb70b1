//! `vservoctl snapshot`: what the camera of a running instance sees now, as a PNG a person can look at without
//! Foxglove: the newest camera image with its marks drawn on it (`crate::annotate`: found, wanted by the gains
//! in force, the error), and every tag36h11 tag in view outlined with its id (the target's green, the others
//! yellow; found as `vservoctl tags` finds them), and the collision guard's obstacles (`[[scene.obstacles]]`) as
//! wireframes where the camera saw them from at that frame. The frame's numbers (its features, ξ_d, the error,
//! the tags, the obstacles in view) are printed as one JSON object.
//!
//! The image and the features are of the same frame (the features message names its frame).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use nalgebra::Point2;
use serde_json::json;
use vservo_protocol::{FeaturesMsg, GainsMsg, Topic};

use crate::annotate;
use crate::instance::{Connection, InstanceArg, when_there};
use crate::output::print_stdout;

/// Arguments of `vservoctl snapshot`.
#[derive(Args)]
pub struct SnapshotArgs {
    #[command(flatten)]
    instance: InstanceArg,
    /// Where to write the PNG (a new name: a link or another user's file there is refused, one's own file too
    /// unless --force).
    #[arg(long, value_name = "FILE.png", default_value = "snapshot.png")]
    out: PathBuf,
    /// Replace one's own file at --out.
    #[arg(long)]
    force: bool,
    /// The longest wait for a frame and its features (s).
    #[arg(long, default_value_t = 5.0, value_parser = crate::seconds_arg::seconds)]
    timeout_s: f64,
}

/// One frame: its pixels and what the vision node found in it.
struct Frame {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
    features: FeaturesMsg,
}

/// Runs the command.
pub fn run(args: &SnapshotArgs) -> anyhow::Result<()> {
    if args.out.extension().and_then(|e| e.to_str()) != Some("png") {
        return Err(
            crate::UsageError(format!("--out {}: the file must end in .png", args.out.display())).into()
        );
    }
    let until = Instant::now() + Duration::from_secs_f64(args.timeout_s);
    let connection = Connection::open_when_there(&args.instance, || Instant::now() >= until)?;
    let config = args.instance.configuration_in_force(&connection.instance)?;
    let gains = when_there(Some(until), || connection.subscriber::<GainsMsg>(Topic::Gains))?;
    let desired = crate::instance::wait_for(until.saturating_duration_since(Instant::now()), || {
        gains.receive().ok().flatten().map(|sample| sample.desired_features_px)
    })
    .context("no gains from the daemon (is it running?)")?;
    let frame = newest_frame(&connection, until)?;
    let shown = |x: f64, y: f64| {
        let point = Point2::new(x, y);
        if config.cell.vision.undistort { config.cell.camera.observed_of_pinhole(&point) } else { point }
    };
    let mut picture = annotate::gray_to_rgb(frame.width, frame.height, frame.width, &frame.pixels);
    let obstacles = draw_obstacles(&mut picture, &config.cell, &frame.features);
    let tags = tags_in_view(&frame, &config.cell.camera);
    let target_ids: Vec<u32> = config.cell.board.target_tags().iter().map(|tag| tag.id()).collect();
    for tag in &tags {
        let colour = if target_ids.contains(&tag.id) { annotate::FOUND } else { annotate::ERROR };
        annotate::draw_tag(&mut picture, &tag.corners, tag.id, colour);
    }
    let drawn = annotate::draw_marks(
        &mut picture,
        &frame.features.features_px,
        frame.features.valid_mask,
        &desired,
        shown,
    );
    let marks: Vec<_> = drawn
        .iter()
        .enumerate()
        .map(|(mark, drawn)| {
            json!({
                "mark": mark + 1,
                "found_px": drawn.found.map(|found| [found.x, found.y]),
                "desired_px": [drawn.wanted.x, drawn.wanted.y],
                "error_px": drawn.error_px(),
            })
        })
        .collect();
    let mut png = std::io::Cursor::new(Vec::new());
    picture.write_to(&mut png, image::ImageFormat::Png).context("encoding the PNG")?;
    vservo_config::new_file::write(&args.out, png.get_ref(), args.force, 0o644)?;
    let summary = json!({
        "instance": connection.instance,
        "frame": frame.features.frame,
        "image": args.out.display().to_string(),
        "features_px": frame.features.features_px.map(|v| if v.is_finite() { Some(v) } else { None }),
        "desired_features_px": desired,
        "marks": marks,
        "tags": tags.iter().map(|tag| json!({
            "id": tag.id,
            "corners_px": tag.corners.map(|c| [c.x, c.y]),
            "refined": tag.quality.refined,
            "target": target_ids.contains(&tag.id),
        })).collect::<Vec<_>>(),
        "obstacles": obstacles,
    });
    print_stdout(&format!("{summary}\n"))?;
    Ok(())
}

/// The guard's obstacles as wireframes, seen from where the camera was at the frame (a hand camera: the pose its
/// features give; a fixed one: where it is mounted); each obstacle's name and whether it is in view.
fn draw_obstacles(
    picture: &mut image::RgbImage,
    cell: &vservo_config::CellConfig,
    features: &FeaturesMsg,
) -> Vec<serde_json::Value> {
    let Some(collision) = &cell.collision else { return Vec::new() };
    let base_from_camera = match cell.mount() {
        vservo_scene::CameraMount::Hand { .. } => {
            vservo_scene::pose_rows::pose_from_rows(&features.base_from_camera)
        }
        vservo_scene::CameraMount::World { base_from_camera, .. } => Some(base_from_camera),
    };
    let Some(camera_from_base) = base_from_camera.map(|pose| pose.inverse()) else { return Vec::new() };
    collision
        .obstacles
        .iter()
        .map(|obstacle| {
            let segments: Vec<_> = obstacle
                .primitives()
                .iter()
                .flat_map(|primitive| primitive.edges())
                .map(|[a, b]| [camera_from_base * a, camera_from_base * b])
                .collect();
            let in_view = annotate::draw_wireframe(picture, &segments, &cell.camera, annotate::OBSTACLE);
            json!({"name": obstacle.name, "in_view": in_view})
        })
        .collect()
}

/// Every tag36h11 tag in the frame (as `vservoctl tags` finds them), its edges straight through the camera's lens.
fn tags_in_view(frame: &Frame, camera: &vservo_scene::CameraIntrinsics) -> Vec<vservo_vision::TagDetection> {
    let Some(gray) = vservo_vision::GrayImage::from_raw(frame.width, frame.height, frame.pixels.clone())
    else {
        return Vec::new();
    };
    let straight = vservo_vision::tag_refine::Straight::for_picture(camera, frame.width, frame.height);
    vservo_vision::tag::detect_tags(&gray, straight)
}

/// The newest camera image whose features have come, within `until`.
fn newest_frame(connection: &Connection, until: Instant) -> anyhow::Result<Frame> {
    let images = when_there(Some(until), || {
        Ok(vservo_protocol::camera_image_subscriber(
            &connection.node,
            &connection.instance,
            vservo_protocol::Opening::OpenOnly,
        )?)
    })?;
    let features = when_there(Some(until), || connection.subscriber::<FeaturesMsg>(Topic::Features))?;
    // the images of the last frames, by frame number, until the features of one of them come
    let mut held: Vec<(u64, u32, u32, Vec<u8>)> = Vec::new();
    while Instant::now() < until {
        while let Some(sample) = images.receive()? {
            let header = sample.user_header();
            held.push((header.frame, header.width, header.height, sample.payload().to_vec()));
            if held.len() > 8 {
                held.remove(0);
            }
        }
        while let Some(sample) = features.receive()? {
            let message = *sample;
            if let Some(index) = held.iter().position(|(frame, ..)| *frame == message.frame) {
                let (_, width, height, pixels) = held.swap_remove(index);
                return Ok(Frame { width, height, pixels, features: message });
            }
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    anyhow::bail!(
        "no camera frame with its features within the time given (--timeout-s): is the camera publishing, and \
         the vision node running?"
    )
}
