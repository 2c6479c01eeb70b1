//! The calibration file: an OpenCV FileStorage YAML (what `cv2.FileStorage` reads, and what
//! `camera.calibration_file` takes) with the image size, the camera matrix, the lens and, as a 4 × 4
//! `tool_from_camera`, the hand-eye transform (a fixed camera's: `base_from_camera`). The principal point is
//! written in OpenCV's pixels (a pixel's
//! centre at integers), so that OpenCV's users read it right; vservo adds the half pixel back when it reads it.

use std::path::Path;

use vservo_config::Config;
use vservo_scene::OPENCV_TO_VSERVO_PX;

use crate::solver::Solved;
use crate::{CalibrateError, Result};

/// Writes the file as a new one (`vservo_config::new_file`: one of the user's own at the name replaced with `force` only).
pub fn write(path: &Path, force: bool, config: &Config, solved: &Solved) -> Result<()> {
    let views = solved.views.len();
    let number = |v: f64| format!("{v:.10e}");
    let matrix = |name: &str, rows: usize, cols: usize, data: &[f64]| {
        let values: Vec<String> = data.iter().map(|&v| number(v)).collect();
        format!(
            "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
            values.join(", ")
        )
    };
    let (cx, cy) = (solved.cx - OPENCV_TO_VSERVO_PX, solved.cy - OPENCV_TO_VSERVO_PX);
    let camera_matrix = [solved.fx, 0.0, cx, 0.0, solved.fy, cy, 0.0, 0.0, 1.0];
    let (mount_key, mount) = solved.camera_in_mount()?;
    let pose: Vec<f64> = mount.matrix.iter().flatten().copied().collect();
    if pose.len() != 16 || !pose.iter().all(|v| v.is_finite()) {
        return Err(CalibrateError::Solver(format!(
            "the solver's {mount_key} is not a 4 × 4 matrix of numbers: {:?}",
            mount.matrix
        )));
    }
    let text = format!(
        "%YAML:1.0\n---\n# vservoctl calibrate, {views} views of the board of {}: reprojection {:.3} px RMS, AX = XB {:.4}° / {:.3} mm RMS\n# ({})\nimage_width: {}\nimage_height: {}\n{}{}{}",
        config.origin,
        solved.rms_px,
        solved.ax_xb_rotation_deg,
        solved.ax_xb_translation_mm,
        solved.solver,
        config.cell.camera.width_px(),
        config.cell.camera.height_px(),
        matrix("camera_matrix", 3, 3, &camera_matrix),
        matrix("distortion_coefficients", 1, 5, &solved.distortion),
        matrix(mount_key, 4, 4, &pose),
    );
    Ok(vservo_config::new_file::write(path, text.as_bytes(), force, 0o644)?)
}
