//! The views handed to the solver: each image as a PGM file and `dataset.json` with the arm's pose at each,
//! the camera as the configuration believes it and the board's layout (clients/python/vservo_calibrate.py reads
//! it). Kept after the run, so that a calibration can be solved again or looked at.

use std::path::{Path, PathBuf};

use image::ExtendedColorType;
use image::GrayImage;
use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
use serde_json::{Value, json};
use vservo_arm::JointVector;
use vservo_scene::{CameraIntrinsics, IsometryMatrix3, TagGrid};

use crate::{CalibrateError, Result};

/// One view: its image and the arm's joints and tool pose when it was taken.
pub struct View {
    /// The image.
    pub image: GrayImage,
    /// The joints.
    pub q: JointVector,
    /// The tool's pose they give.
    pub base_from_tool: IsometryMatrix3<f64>,
}

/// A 4 × 4 matrix as rows.
pub fn rows(m: &IsometryMatrix3<f64>) -> Vec<Vec<f64>> {
    let h = m.to_homogeneous();
    (0..4).map(|r| (0..4).map(|c| h[(r, c)]).collect()).collect()
}

/// Writes the views and `dataset.json` into `dir` (made new, or the user's own folder: never a link or another
/// user's, `vservo_config::new_file::folder`; a link at a file's name is refused, never written through);
/// returns `dataset.json`'s path.
pub fn write(
    dir: &Path,
    views: &[View],
    camera: &CameraIntrinsics,
    camera_in_mount: (&str, &IsometryMatrix3<f64>),
    grid: &TagGrid,
    joints: usize,
) -> Result<PathBuf> {
    vservo_config::new_file::folder(dir)?;
    let mut listed = Vec::with_capacity(views.len());
    for (k, view) in views.iter().enumerate() {
        let name = format!("view_{:02}.pgm", k + 1);
        write_pgm(&dir.join(&name), &view.image)?;
        listed.push(json!({
            "image": name,
            "q_rad": view.q.iter().take(joints).collect::<Vec<_>>(),
            "base_from_tool": rows(&view.base_from_tool),
        }));
    }
    let mut board = board_layout(grid);
    board["tag_size_m"] = json!(grid.tag_size_m());
    let dataset = json!({
        "image_size": [camera.width_px(), camera.height_px()],
        "camera": camera_json(camera),
        // "hand": the camera on the tool at tool_from_camera; "world": fixed at base_from_camera, the board on
        // the tool (the solver inverts the arm's poses: docs/CALIBRATION.md)
        "mount": if camera_in_mount.0 == "base_from_camera" { "world" } else { "hand" },
        camera_in_mount.0: rows(camera_in_mount.1),
        "board": board,
        "views": listed,
    });
    let path = dir.join("dataset.json");
    vservo_config::new_file::write(&path, format!("{dataset}\n").as_bytes(), true, 0o644)?;
    Ok(path)
}

/// The camera's intrinsics (vservo's pixels) and lens as the solver takes them.
pub fn camera_json(camera: &CameraIntrinsics) -> Value {
    json!({
        "fx": camera.fx_px(),
        "fy": camera.fy_px(),
        "cx": camera.principal_point_px().x,
        "cy": camera.principal_point_px().y,
        "distortion": camera.distortion().coefficients(),
    })
}

/// A binary PGM (P5), as a new file of the user's (`vservo_config::new_file`).
fn write_pgm(path: &Path, image: &GrayImage) -> Result<()> {
    let mut pgm = Vec::with_capacity(image.as_raw().len() + 32);
    PnmEncoder::new(&mut pgm)
        .with_subtype(PnmSubtype::Graymap(SampleEncoding::Binary))
        .encode(image.as_raw().as_slice(), image.width(), image.height(), ExtendedColorType::L8)
        .map_err(|source| CalibrateError::Image { path: path.to_path_buf(), source })?;
    Ok(vservo_config::new_file::write(path, &pgm, true, 0o644)?)
}

/// The layout: the grid's parameters and each tag's corners in the board frame (m).
pub fn board_layout(grid: &TagGrid) -> serde_json::Value {
    let tags: Vec<_> = grid
        .tags()
        .map(|tag| {
            let corners: Vec<[f64; 3]> = tag.corners_in_board().iter().map(|p| [p.x, p.y, p.z]).collect();
            json!({"id": tag.id(), "corners_in_board_m": corners})
        })
        .collect();
    let [low, high] = grid.extent_in_board();
    json!({
        "family": "tag36h11",
        "rows": grid.rows(),
        "columns": grid.columns(),
        "tag_size_m": grid.tag_size_m(),
        "gap_m": grid.gap_m(),
        "extent_in_board_m": [[low.x, low.y], [high.x, high.y]],
        "tags": tags,
    })
}
