//! `vservoctl tags IMAGE…`: every tag36h11 tag in any picture — 8-bit or 16-bit gray or colour PNG, JPEG or
//! PGM, of any size — as vservo's detector sees it (quads searched at full resolution, each corner refined
//! or the decoder's own, `vservo_vision::tag::detect_tags`): id, corners, centre and how they were measured,
//! and the time it took. A repeated id is listed once per tag, marked as repeated. With `--config`, the
//! camera's lens gives the undistorted corners too (when the picture is the camera's size), and the target's
//! tag is marked. `--draw` writes the picture with each tag outlined and its id written in it.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use nalgebra::Point2;
use serde_json::{Value, json};
use vservo_scene::CameraIntrinsics;
use vservo_vision::tag::{TagDetection, detect_tags};
use vservo_vision::tag_refine::Straight;

use crate::UsageError;
use crate::annotate;
use crate::output::print_stdout;

/// Arguments of `vservoctl tags`.
#[derive(Args)]
pub struct TagsArgs {
    /// The pictures: PNG, JPEG or PGM, gray or colour, any size.
    #[arg(required = true, value_name = "IMAGE")]
    images: Vec<PathBuf>,
    /// A configuration: its camera's lens undistorts the corners, and its target's tag is marked.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// One JSON object per picture, one per line.
    #[arg(long)]
    json: bool,
    /// Write the (one) picture with each tag outlined, its first corner crossed and its id written, as a PNG
    /// (a new name: a link or another user's file there is refused, one's own file too unless --force).
    #[arg(long, value_name = "OUT.png")]
    draw: Option<PathBuf>,
    /// Replace one's own file at --draw.
    #[arg(long)]
    force: bool,
}

/// What the configuration adds: the camera (for its lens) and the target's tag ids (one, or a bundle's).
struct Camera {
    intrinsics: CameraIntrinsics,
    target_ids: Vec<u32>,
}

/// One picture's tags.
struct Seen {
    path: PathBuf,
    width_px: u32,
    height_px: u32,
    colour: String,
    detections: Vec<TagDetection>,
    detect_ms: f64,
    /// The camera's lens, when it applies to this picture (its size).
    lens: Option<CameraIntrinsics>,
    /// Why the configured lens was not applied, if it was not.
    lens_note: Option<String>,
    gray: image::GrayImage,
}

/// Runs the command.
pub fn run(args: &TagsArgs) -> Result<()> {
    if args.draw.is_some() && args.images.len() != 1 {
        return Err(UsageError("--draw takes one picture".into()).into());
    }
    let camera = args.config.as_deref().map(camera_of).transpose()?;
    for path in &args.images {
        let seen = look_at(path, camera.as_ref())?;
        let target_ids = camera.as_ref().map_or(&[][..], |c| &c.target_ids[..]);
        let text =
            if args.json { format!("{}\n", to_json(&seen, target_ids)) } else { to_text(&seen, target_ids) };
        print_stdout(&text)?;
        if let Some(out) = &args.draw {
            draw(&seen, target_ids, out, args.force)?;
        }
    }
    Ok(())
}

/// The camera and target of a configuration file.
fn camera_of(path: &Path) -> Result<Camera> {
    let config = vservo_config::Config::load(path).map_err(|e| UsageError(e.to_string()))?;
    let target_ids = config.cell.board.target_tags().iter().map(|tag| tag.id()).collect();
    Ok(Camera { intrinsics: config.cell.camera, target_ids })
}

/// Reads one picture and finds its tags.
fn look_at(path: &Path, camera: Option<&Camera>) -> Result<Seen> {
    let (gray, colour) =
        vservo_vision::source::read_image_as_gray(path).map_err(|e| UsageError(e.to_string()))?;
    let (width_px, height_px) = gray.dimensions();
    let (lens, lens_note) = match camera {
        None => (None, None),
        Some(c) if (c.intrinsics.width_px(), c.intrinsics.height_px()) == (width_px, height_px) => {
            (Some(c.intrinsics), None)
        }
        Some(c) => (
            None,
            Some(format!(
                "the picture is {width_px}×{height_px}, the configured camera {}×{}: its lens is not applied",
                c.intrinsics.width_px(),
                c.intrinsics.height_px()
            )),
        ),
    };
    let straight =
        camera.map_or(Straight::InImage, |c| Straight::for_picture(&c.intrinsics, width_px, height_px));
    let began = Instant::now();
    let detections = detect_tags(&gray, straight);
    let detect_ms = began.elapsed().as_secs_f64() * 1e3;
    Ok(Seen {
        path: path.to_path_buf(),
        width_px,
        height_px,
        colour: format!("{colour:?}"),
        detections,
        detect_ms,
        lens,
        lens_note,
        gray,
    })
}

/// How many tags of `id` the picture holds.
fn count_of(seen: &Seen, id: u32) -> usize {
    seen.detections.iter().filter(|d| d.id == id).count()
}

fn centre_of(corners: &[Point2<f64>; 4]) -> Point2<f64> {
    corners.iter().fold(Point2::origin(), |sum, c| sum + c.coords / 4.0)
}

fn points_json(points: &[Point2<f64>]) -> Value {
    Value::from(points.iter().map(|p| json!([p.x, p.y])).collect::<Vec<_>>())
}

/// A number, or null where it is NaN (an edge not measured).
fn finite_or_null(value: f64) -> Value {
    if value.is_finite() { json!(value) } else { Value::Null }
}

fn to_json(seen: &Seen, target_ids: &[u32]) -> Value {
    let tags: Vec<Value> = seen
        .detections
        .iter()
        .map(|d| {
            let undistorted: Option<Vec<Point2<f64>>> =
                seen.lens.map(|lens| d.corners.iter().filter_map(|c| lens.pinhole_of_observed(c)).collect());
            json!({
                "id": d.id,
                "corners_px": points_json(&d.corners),
                "centre_px": points_json(&[centre_of(&d.corners)])[0],
                "undistorted_corners_px": undistorted.map(|p| points_json(&p)),
                "decoder_corners_px": points_json(&d.decoder_corners),
                "refined": d.quality.refined,
                "edge_rms_px": d.quality.edge_rms_px.map(finite_or_null),
                "decision_margin": d.quality.decision_margin,
                "bits_corrected": d.quality.bits_corrected,
                "repeated": count_of(seen, d.id) > 1,
                "target": target_ids.contains(&d.id),
            })
        })
        .collect();
    json!({
        "image": seen.path.display().to_string(),
        "width_px": seen.width_px,
        "height_px": seen.height_px,
        "colour": seen.colour,
        "detect_ms": seen.detect_ms,
        "lens_note": seen.lens_note,
        // one tag's id (null for a bundle: target_ids lists its tags)
        "target_id": match target_ids { [one] => Some(*one), _ => None },
        "target_ids": target_ids,
        "target_found": (!target_ids.is_empty()).then(|| target_ids.iter().map(|&id| count_of(seen, id)).sum::<usize>()),
        "tags": tags,
    })
}

fn to_text(seen: &Seen, target_ids: &[u32]) -> String {
    let mut out = format!(
        "{}: {}×{} {}, {} tag(s) in {:.1} ms\n",
        seen.path.display(),
        seen.width_px,
        seen.height_px,
        seen.colour,
        seen.detections.len(),
        seen.detect_ms
    );
    if let Some(note) = &seen.lens_note {
        out.push_str(&format!("  note: {note}\n"));
    }
    for d in &seen.detections {
        let centre = centre_of(&d.corners);
        let corners: Vec<String> = d.corners.iter().map(|c| format!("({:.2}, {:.2})", c.x, c.y)).collect();
        let mut marks = Vec::new();
        if count_of(seen, d.id) > 1 {
            marks.push(format!("repeated ×{}", count_of(seen, d.id)));
        }
        if target_ids.contains(&d.id) {
            marks.push(if target_ids.len() == 1 { "the target" } else { "the target's bundle" }.to_string());
        }
        out.push_str(&format!(
            "  id {:>3}  centre ({:.2}, {:.2}) px  corners {}  refined {}/4  margin {:.1}  bits {}{}\n",
            d.id,
            centre.x,
            centre.y,
            corners.join(" "),
            d.quality.refined_count(),
            d.quality.decision_margin,
            d.quality.bits_corrected,
            if marks.is_empty() { String::new() } else { format!("  ({})", marks.join(", ")) }
        ));
    }
    let missing: Vec<String> =
        target_ids.iter().filter(|&&id| count_of(seen, id) == 0).map(|id| id.to_string()).collect();
    match missing.as_slice() {
        [] => {}
        [id] if target_ids.len() == 1 => {
            out.push_str(&format!("  the target's tag (id {id}) is not in the picture\n"))
        }
        ids => out.push_str(&format!("  the target's bundle: id(s) {} not in the picture\n", ids.join(", "))),
    }
    out
}

/// The picture with its tags drawn: the target's in green, the others in yellow.
fn draw(seen: &Seen, target_ids: &[u32], out: &Path, force: bool) -> Result<()> {
    let mut picture = annotate::gray_to_rgb(seen.width_px, seen.height_px, seen.width_px, seen.gray.as_raw());
    for d in &seen.detections {
        let colour = if target_ids.contains(&d.id) { annotate::FOUND } else { annotate::ERROR };
        annotate::draw_tag(&mut picture, &d.corners, d.id, colour);
    }
    let mut png = std::io::Cursor::new(Vec::new());
    picture.write_to(&mut png, image::ImageFormat::Png).context("encoding the PNG")?;
    vservo_config::new_file::write(out, png.get_ref(), force, 0o644)?;
    eprintln!("wrote {} ({} tag(s))", out.display(), seen.detections.len());
    Ok(())
}
