//! Runs the solver, clients/python/vservo_calibrate.py (OpenCV and SciPy, docs/CALIBRATION.md), on a dataset
//! and reads its answer.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::Deserialize;

use crate::{CalibrateError, Result};

/// A transform as the solver gives it.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
pub struct SolvedTransform {
    /// The 4 × 4 matrix, rows.
    pub matrix: Vec<Vec<f64>>,
    /// Its translation (m).
    pub translation_m: [f64; 3],
    /// Its rotation as a unit quaternion [x, y, z, w].
    pub quaternion_xyzw: [f64; 4],
}

/// One view's residuals.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
pub struct ViewResidual {
    /// The image file.
    pub image: String,
    /// Tags found in it.
    pub tags_found: usize,
    /// Reprojection RMS through the arm's pose (px).
    pub rms_px: f64,
    /// The board's pose from this view alone against the joint solution: rotation (°).
    pub hand_eye_rotation_deg: f64,
    /// … and translation (mm).
    pub hand_eye_translation_mm: f64,
}

/// The solver's answer.
#[derive(Debug, Clone, Deserialize, serde::Serialize)]
pub struct Solved {
    /// Focal lengths (px).
    pub fx: f64,
    /// fy.
    pub fy: f64,
    /// Principal point (px, vservo's pixels).
    pub cx: f64,
    /// cy.
    pub cy: f64,
    /// k1.
    pub k1: f64,
    /// OpenCV's k1, k2, p1, p2, k3.
    pub distortion: [f64; 5],
    /// The hand-eye transform (a camera on the hand).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_from_camera: Option<SolvedTransform>,
    /// The board in the arm's base (a camera on the hand).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_from_board: Option<SolvedTransform>,
    /// The camera in the arm's base (a fixed camera: the eye-to-hand case).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_from_camera: Option<SolvedTransform>,
    /// The board on the tool (a fixed camera).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_from_board: Option<SolvedTransform>,
    /// Reprojection RMS over every corner (px).
    pub rms_px: f64,
    /// AX = XB over every pair of views: RMS rotation (°).
    pub ax_xb_rotation_deg: f64,
    /// … and translation (mm).
    pub ax_xb_translation_mm: f64,
    /// Per view.
    pub views: Vec<ViewResidual>,
    /// Views that found too few tags.
    pub views_unused: Vec<String>,
    /// What solved it.
    pub solver: String,
}

/// The solver script: `--solver`, else beside the executable in a source tree (`target/<profile>/` →
/// clients/python/), else where the Debian package puts it.
pub fn locate(given: Option<&Path>) -> Result<PathBuf> {
    if let Some(path) = given {
        return Ok(path.to_path_buf());
    }
    let exe = std::env::current_exe().ok();
    let candidates = exe
        .iter()
        .flat_map(|exe| {
            exe.ancestors().skip(1).take(4).map(|dir| dir.join("clients/python/vservo_calibrate.py"))
        })
        .chain(std::iter::once(PathBuf::from("/usr/share/vservo/vservo_calibrate.py")));
    let mut looked = Vec::new();
    for candidate in candidates {
        if candidate.is_file() {
            return Ok(candidate);
        }
        looked.push(candidate.display().to_string());
    }
    Err(CalibrateError::Refused(format!(
        "the solver vservo_calibrate.py is not found (looked at {}); give it with --solver",
        looked.join(", ")
    )))
}

/// The Python that runs the solver: `--python`, else the project's environment beside this executable in a source
/// tree (`target/<profile>/vservoctl` → `target/python-venv/bin/python`, made by scripts/setup.sh with OpenCV,
/// SciPy and NumPy), else the active virtual environment's (`$VIRTUAL_ENV`), else `python3` (the Debian
/// package's dependencies).
pub fn python(given: Option<&Path>) -> PathBuf {
    if let Some(path) = given {
        return path.to_path_buf();
    }
    let exe = std::env::current_exe().ok();
    let project = exe
        .iter()
        .flat_map(|exe| exe.ancestors().skip(1).take(3).map(|dir| dir.join("python-venv/bin/python")))
        .find(|candidate| candidate.is_file());
    let active = std::env::var_os("VIRTUAL_ENV")
        .map(|env| PathBuf::from(env).join("bin/python"))
        .filter(|candidate| candidate.is_file());
    project.or(active).unwrap_or_else(|| PathBuf::from("python3"))
}

impl Solved {
    /// The camera's pose in the frame it is fixed to, named (`tool_from_camera` on the hand, `base_from_camera`
    /// fixed); refused when the solver gave neither.
    pub fn camera_in_mount(&self) -> Result<(&'static str, &SolvedTransform)> {
        match (&self.tool_from_camera, &self.base_from_camera) {
            (Some(tool), None) => Ok(("tool_from_camera", tool)),
            (None, Some(base)) => Ok(("base_from_camera", base)),
            _ => Err(CalibrateError::Solver(
                "the solver gave not one camera pose (tool_from_camera or base_from_camera)".into(),
            )),
        }
    }
}

/// Runs `python solver dataset_dir`; a refusal (exit 2) is the user's to act on.
pub fn solve(python: &Path, solver: &Path, dataset_dir: &Path) -> Result<Solved> {
    let text = run(python, solver, &[dataset_dir.as_os_str()], "the views cannot be solved")?;
    parse(&text)
}

/// Where the board is in a view.
#[derive(Debug, Clone, Deserialize)]
pub struct Located {
    /// The board in the camera's frame, through the camera as the configuration believes it.
    pub camera_from_board: SolvedTransform,
    /// Tags found.
    pub tags_found: usize,
    /// Reprojection RMS of the corners (px).
    pub rms_px: f64,
}

/// Runs `python solver --locate dataset_dir`: the board's pose in the dataset's first view.
pub fn locate_board(python: &Path, solver: &Path, dataset_dir: &Path) -> Result<Located> {
    let text = run(
        python,
        solver,
        &[std::ffi::OsStr::new("--locate"), dataset_dir.as_os_str()],
        "the board cannot be located",
    )?;
    parse(&text)
}

/// Runs the solver with `args`; its standard output, or its refusal (exit 2) prefixed by `refused`.
fn run(python: &Path, solver: &Path, args: &[&std::ffi::OsStr], refused: &str) -> Result<String> {
    let output = Command::new(python).arg(solver).args(args).output().map_err(|e| {
        CalibrateError::Solver(format!("starting {} {}: {e}", python.display(), solver.display()))
    })?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    if let Some(module) = missing_module(&stderr) {
        return Err(CalibrateError::Refused(format!(
            "the solver's Python ({}) has no module {module:?}: run scripts/setup.sh (it makes target/python-venv \
             with OpenCV, SciPy and NumPy), or give an interpreter that has them with --python",
            python.display()
        )));
    }
    match output.status.code() {
        Some(0) => Ok(String::from_utf8_lossy(&output.stdout).into_owned()),
        Some(2) => Err(CalibrateError::Refused(format!("{refused}: {}", stderr.trim()))),
        _ => Err(CalibrateError::Solver(format!(
            "the solver {} failed ({}): {}",
            solver.display(),
            output.status,
            stderr.trim()
        ))),
    }
}

/// The module Python's `ModuleNotFoundError` names in `stderr`, if it says one.
fn missing_module(stderr: &str) -> Option<&str> {
    let after = stderr.split("ModuleNotFoundError: No module named ").nth(1)?;
    after.lines().next().map(|name| name.trim().trim_matches('\''))
}

fn parse<T: serde::de::DeserializeOwned>(text: &str) -> Result<T> {
    serde_json::from_str(text.trim()).map_err(|e| {
        CalibrateError::Solver(format!(
            "reading the solver's answer: {e}: {}",
            text.chars().take(200).collect::<String>()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_module_is_named_from_pythons_error() {
        let stderr = "Traceback (most recent call last):\n  File \"x.py\", line 3, in <module>\n    import cv2\n\
                      ModuleNotFoundError: No module named 'cv2'\n";
        assert_eq!(missing_module(stderr), Some("cv2"));
        assert_eq!(missing_module("the views cannot be solved: 2 views"), None);
    }

    #[test]
    fn the_given_python_is_taken_as_it_is() {
        assert_eq!(python(Some(Path::new("/opt/py/bin/python"))), PathBuf::from("/opt/py/bin/python"));
    }
}
