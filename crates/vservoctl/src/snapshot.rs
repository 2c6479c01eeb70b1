//! `vservoctl snapshot`: what the camera of a running instance sees now, as a PNG a person can look at without
//! Foxglove: the newest camera image with, drawn on it, each mark the vision node found (a green cross), where
//! the servo wants it (a red ring: ξ_d of the gains in force) and the error between them (a yellow line). The
//! frame's numbers (its features, ξ_d, the error) are printed as one JSON object.
//!
//! The image and the features are of the same frame (the features message names its frame). Features are drawn
//! where they lie in the image: through the lens when the vision node undistorts them (`vision.undistort`).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use image::{Rgb, RgbImage};
use nalgebra::Point2;
use serde_json::json;
use vservo_protocol::{FeaturesMsg, GainsMsg, MARKS, Topic};

use crate::instance::{Connection, InstanceArg, when_there};
use crate::output::print_stdout;

/// A found mark.
const FOUND: Rgb<u8> = Rgb([0, 220, 0]);
/// Where the servo wants a mark.
const DESIRED: Rgb<u8> = Rgb([230, 0, 0]);
/// From a mark to where it is wanted.
const ERROR: Rgb<u8> = Rgb([240, 220, 0]);
/// Half the cross's arm (px).
const CROSS_PX: i64 = 7;
/// The desired ring's radius (px): outside a mark's image at the paper's distance.
const RING_PX: f64 = 11.0;

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
        if config.vision.undistort { config.camera.observed_of_pinhole(&point) } else { point }
    };
    let mut picture = gray_to_rgb(&frame);
    let mut marks = Vec::with_capacity(MARKS);
    for mark in 0..MARKS {
        let wanted = shown(desired[2 * mark], desired[2 * mark + 1]);
        ring(&mut picture, wanted, DESIRED);
        let seen = frame.features.valid_mask & (1 << mark) != 0;
        let found = shown(frame.features.features_px[2 * mark], frame.features.features_px[2 * mark + 1]);
        if seen {
            line(&mut picture, found, wanted, ERROR);
            cross(&mut picture, found, FOUND);
        }
        marks.push(json!({
            "mark": mark + 1,
            "found_px": seen.then_some([found.x, found.y]),
            "desired_px": [wanted.x, wanted.y],
            "error_px": seen.then(|| (found - wanted).norm()),
        }));
    }
    let mut png = std::io::Cursor::new(Vec::new());
    picture.write_to(&mut png, image::ImageFormat::Png).context("encoding the PNG")?;
    crate::new_file::write(&args.out, png.get_ref(), args.force, 0o644)?;
    let summary = json!({
        "instance": connection.instance,
        "frame": frame.features.frame,
        "image": args.out.display().to_string(),
        "features_px": frame.features.features_px.map(|v| if v.is_finite() { Some(v) } else { None }),
        "desired_features_px": desired,
        "marks": marks,
    });
    print_stdout(&format!("{summary}\n"))?;
    Ok(())
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

fn gray_to_rgb(frame: &Frame) -> RgbImage {
    RgbImage::from_fn(frame.width, frame.height, |u, v| {
        let gray = frame.pixels.get((v * frame.width + u) as usize).copied().unwrap_or(0);
        Rgb([gray, gray, gray])
    })
}

/// Sets the pixel holding `(x, y)` in vservo's pixels (a pixel's centre at + ½), if it is in the picture.
fn put(picture: &mut RgbImage, x: f64, y: f64, colour: Rgb<u8>) {
    let (u, v) = (x.floor(), y.floor());
    if u >= 0.0 && v >= 0.0 && (u as u32) < picture.width() && (v as u32) < picture.height() {
        picture.put_pixel(u as u32, v as u32, colour);
    }
}

fn cross(picture: &mut RgbImage, at: Point2<f64>, colour: Rgb<u8>) {
    for d in -CROSS_PX..=CROSS_PX {
        put(picture, at.x + d as f64, at.y, colour);
        put(picture, at.x, at.y + d as f64, colour);
    }
}

fn ring(picture: &mut RgbImage, at: Point2<f64>, colour: Rgb<u8>) {
    let steps = 128;
    for k in 0..steps {
        let angle = std::f64::consts::TAU * f64::from(k) / f64::from(steps);
        put(picture, at.x + RING_PX * angle.cos(), at.y + RING_PX * angle.sin(), colour);
    }
}

fn line(picture: &mut RgbImage, from: Point2<f64>, to: Point2<f64>, colour: Rgb<u8>) {
    let steps = (to - from).norm().ceil().clamp(1.0, 4096.0) as u32;
    for k in 0..=steps {
        let p = from + (to - from) * (f64::from(k) / f64::from(steps));
        put(picture, p.x, p.y, colour);
    }
}
