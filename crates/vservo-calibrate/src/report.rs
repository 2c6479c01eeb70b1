//! What `vservoctl calibrate` prints: the plan (`--dry-run`), or the solution with its residuals per view and
//! overall, what it changes against the configuration (before → after), when the truth is known (the simulated
//! cell's `[camera.truth]`) its errors against it, and what `--apply` did.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Matrix4, Quaternion, UnitQuaternion};
use serde_json::{Value, json};
use vservo_config::{CameraTruth, Config};
use vservo_scene::IsometryMatrix3;

use crate::apply::Applied;
use crate::plan::PlannedPose;
use crate::solver::Solved;

/// The plan: each pose's joints and how much of the board it sees (the text `--dry-run` prints).
pub fn plan(config: &Config, planned: &[PlannedPose], json: bool) -> String {
    let joints = config.cell.arm.joint_count();
    if json {
        let poses: Vec<Value> = planned
            .iter()
            .map(|p| {
                json!({
                    "q_rad": p.q.iter().take(joints).collect::<Vec<_>>(),
                    "camera_from_board_translation_m": p.camera_from_board.translation.vector.as_slice(),
                    "tags_in_view": p.tags_in_view,
                })
            })
            .collect();
        return format!("{}\n", json!({"poses": poses, "moved": false}));
    }
    let mut text = format!(
        "{} poses planned, each reachable and with the board in view (nothing moved):\n",
        planned.len()
    );
    for (k, p) in planned.iter().enumerate() {
        let q: Vec<String> = p.q.iter().take(joints).map(|v| format!("{:7.1}", v.to_degrees())).collect();
        let _ = writeln!(
            text,
            "  pose {:2}: q = [{}]°, board {:.3} m away, {} tags in view",
            k + 1,
            q.join(" "),
            p.camera_from_board.translation.vector.norm(),
            p.tags_in_view
        );
    }
    text
}

/// The solved transform as an isometry.
pub fn isometry(rows: &[Vec<f64>]) -> Option<IsometryMatrix3<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    if flat.len() != 16 {
        return None;
    }
    let m = Matrix4::from_row_slice(&flat);
    let rotation = nalgebra::Rotation3::from_matrix(&m.fixed_view::<3, 3>(0, 0).into_owned());
    Some(IsometryMatrix3::from_parts(nalgebra::Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]), rotation))
}

/// How far `other` is from `truth`: translation (mm) and rotation angle (°) of truth⁻¹ · other.
fn pose_error(truth: &IsometryMatrix3<f64>, other: &IsometryMatrix3<f64>) -> (f64, f64) {
    let e = truth.inverse() * other;
    (e.translation.vector.norm() * 1e3, vservo_scene::rotation_angle_rad(&e.rotation).to_degrees())
}

/// The solved camera pose in its mount, named, as an isometry (NaN-free or none).
fn solved_mount(solved: &Solved) -> (&'static str, Option<IsometryMatrix3<f64>>) {
    match solved.camera_in_mount() {
        Ok((key, pose)) => (key, isometry(&pose.matrix)),
        Err(_) => ("tool_from_camera", None),
    }
}

/// How far a solution is from the truth (`true_in_mount`: the camera's pose in the frame it is fixed to).
fn errors(solved: &Solved, truth: &CameraTruth, true_in_mount: &IsometryMatrix3<f64>) -> Value {
    let (key, recovered) = solved_mount(solved);
    let (translation_mm, rotation_deg) =
        recovered.map_or((f64::NAN, f64::NAN), |r| pose_error(true_in_mount, &r));
    let percent = |got: f64, true_value: f64| 100.0 * (got - true_value) / true_value;
    let lens = truth.intrinsics.distortion().coefficients();
    json!({
        format!("{key}_translation_mm"): translation_mm,
        format!("{key}_rotation_deg"): rotation_deg,
        "fx_percent": percent(solved.fx, truth.intrinsics.fx_px()),
        "fy_percent": percent(solved.fy, truth.intrinsics.fy_px()),
        "cx_px": solved.cx - truth.intrinsics.principal_point_px().x,
        "cy_px": solved.cy - truth.intrinsics.principal_point_px().y,
        "k1": solved.k1 - lens[0],
    })
}

/// The configuration's belief against the truth, for scale.
fn belief_errors(config: &Config, truth: &CameraTruth, true_in_mount: &IsometryMatrix3<f64>) -> Value {
    let (key, believed) = config.cell.camera_in_mount();
    let (translation_mm, rotation_deg) = pose_error(true_in_mount, &believed);
    json!({
        format!("{key}_translation_mm"): translation_mm,
        format!("{key}_rotation_deg"): rotation_deg,
        "fx_percent": 100.0 * (config.cell.camera.fx_px() - truth.intrinsics.fx_px()) / truth.intrinsics.fx_px(),
        "fy_percent": 100.0 * (config.cell.camera.fy_px() - truth.intrinsics.fy_px()) / truth.intrinsics.fy_px(),
        "k1": config.cell.camera.distortion().coefficients()[0] - truth.intrinsics.distortion().coefficients()[0],
    })
}

/// What the calibration changes, before (the configuration) against after (the solution): each value of the
/// lens, and the mount's move.
fn changes(config: &Config, solved: &Solved) -> Value {
    let camera = &config.cell.camera;
    let before_lens = camera.distortion().coefficients();
    let (key, mount) = solved_mount(solved);
    let (_, believed) = config.cell.camera_in_mount();
    let (moved_mm, turned_deg) = mount.map_or((f64::NAN, f64::NAN), |m| pose_error(&believed, &m));
    let after = mount.map_or([f64::NAN; 3], |m| [m.translation.x, m.translation.y, m.translation.z]);
    let pair = |before: f64, after: f64| json!({"before": before, "after": after});
    json!({
        "fx_px": pair(camera.fx_px(), solved.fx),
        "fy_px": pair(camera.fy_px(), solved.fy),
        "cx_px": pair(camera.principal_point_px().x, solved.cx),
        "cy_px": pair(camera.principal_point_px().y, solved.cy),
        "distortion": {"before": before_lens, "after": solved.distortion},
        "mount": key,
        key: {
            "before_translation_m": believed.translation.vector.as_slice(),
            "after_translation_m": after,
            "moved_mm": moved_mm,
            "turned_deg": turned_deg,
        },
    })
}

/// The lines of [`changes`].
fn changes_text(changes: &Value) -> String {
    let number = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    let mut text = String::from(
        "  before → after (the configuration → the calibration):
",
    );
    for (key, name) in [("fx_px", "fx"), ("fy_px", "fy"), ("cx_px", "cx"), ("cy_px", "cy")] {
        let (before, after) = (number(&changes[key]["before"]), number(&changes[key]["after"]));
        let _ = writeln!(text, "    {name}: {before:.3} → {after:.3} px ({:+.3} px)", after - before);
    }
    let lens = |side: &str| -> Vec<String> {
        changes["distortion"][side]
            .as_array()
            .map_or(Vec::new(), |v| v.iter().map(|c| format!("{:.5}", number(c))).collect())
    };
    let _ = writeln!(
        text,
        "    distortion (k1, k2, p1, p2, k3): [{}] → [{}]",
        lens("before").join(", "),
        lens("after").join(", ")
    );
    let key = changes["mount"].as_str().unwrap_or("tool_from_camera");
    let mount = &changes[key];
    let _ = writeln!(
        text,
        "    {key}: moved {:.2} mm and turned {:.3}°",
        number(&mount["moved_mm"]),
        number(&mount["turned_deg"])
    );
    text
}

/// A simulated cell's truth: its camera (`[camera.truth]`), the camera's pose in the frame it is fixed to, and
/// the board's in the frame that holds it (the base on the hand, the tool fixed).
pub struct Truth {
    /// The camera as it really is.
    pub camera: CameraTruth,
    /// `tool_from_camera` on the hand, `base_from_camera` fixed.
    pub camera_in_mount: IsometryMatrix3<f64>,
    /// `base_from_board` on the hand, `tool_from_board` fixed.
    pub board: IsometryMatrix3<f64>,
}

/// A solved calibration and where it went.
pub struct Solution<'a> {
    /// The solver's result.
    pub solved: &'a Solved,
    /// The simulated cell's truth, when known.
    pub truth: Option<&'a Truth>,
    /// The calibration file written.
    pub out: &'a Path,
    /// Where the views are.
    pub views_dir: &'a Path,
}

/// The report of a solved calibration: text, or one JSON object on the last line.
pub fn solved(config: &Config, solution: &Solution, applied: Option<&Applied>, json: bool) -> String {
    let Solution { solved, truth, out, views_dir } = *solution;
    let against_truth = truth.map(|t| {
        (errors(solved, &t.camera, &t.camera_in_mount), belief_errors(config, &t.camera, &t.camera_in_mount))
    });
    let changes = changes(config, solved);
    if json {
        let mut object = serde_json::to_value(solved).unwrap_or(Value::Null);
        object["calibration_file"] = json!(out.display().to_string());
        object["views_dir"] = json!(views_dir.display().to_string());
        object["changes"] = changes;
        object["applied"] = applied.map_or(Value::Null, Applied::json);
        if let (Some((error, believed)), Some(t)) = (&against_truth, truth) {
            object["error_against_truth"] = error.clone();
            object["configured_error_against_truth"] = believed.clone();
            let (mount_key, _) = config.cell.camera_in_mount();
            let board_key = if config.cell.mount().is_hand() { "base_from_board" } else { "tool_from_board" };
            object["truth"] = json!({
                "camera": super::dataset::camera_json(&t.camera.intrinsics),
                mount_key: super::dataset::rows(&t.camera_in_mount),
                board_key: super::dataset::rows(&t.board),
            });
        }
        return format!("{object}\n");
    }
    let mut text = String::new();
    let _ = writeln!(text, "calibrated from {} views ({}):", solved.views.len(), solved.solver);
    let _ = writeln!(
        text,
        "  fx {:.3} px, fy {:.3} px, principal point ({:.3}, {:.3}) px, distortion [{}]",
        solved.fx,
        solved.fy,
        solved.cx,
        solved.cy,
        solved.distortion.iter().map(|v| format!("{v:.5}")).collect::<Vec<_>>().join(", ")
    );
    let (key, t) = match solved.camera_in_mount() {
        Ok(found) => found,
        Err(e) => return format!("{e}\n"),
    };
    let q = UnitQuaternion::from_quaternion(Quaternion::new(
        t.quaternion_xyzw[3],
        t.quaternion_xyzw[0],
        t.quaternion_xyzw[1],
        t.quaternion_xyzw[2],
    ));
    let (roll, pitch, yaw) = q.euler_angles();
    let _ = writeln!(
        text,
        "  {key}: translation [{:.5}, {:.5}, {:.5}] m, rotation rpy [{:.3}, {:.3}, {:.3}]°",
        t.translation_m[0],
        t.translation_m[1],
        t.translation_m[2],
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    );
    let _ = writeln!(
        text,
        "  residuals: reprojection {:.3} px RMS; AX = XB {:.4}° and {:.3} mm RMS over every pair of views",
        solved.rms_px, solved.ax_xb_rotation_deg, solved.ax_xb_translation_mm
    );
    for (k, view) in solved.views.iter().enumerate() {
        let _ = writeln!(
            text,
            "    view {:2} ({}): {} tags, {:.3} px RMS, its own board pose {:.4}° / {:.3} mm from the joint one",
            k + 1,
            view.image,
            view.tags_found,
            view.rms_px,
            view.hand_eye_rotation_deg,
            view.hand_eye_translation_mm
        );
    }
    if !solved.views_unused.is_empty() {
        let _ = writeln!(text, "  not used (too few tags found): {}", solved.views_unused.join(", "));
    }
    if let Some((error, believed)) = &against_truth {
        let _ = writeln!(
            text,
            "  against [camera.truth]: {key} {:.3} mm and {:.4}° off, fx {:+.4} %, fy {:+.4} %, k1 {:+.5} (the configuration was {:.2} mm, {:.3}°, fx {:+.2} %, fy {:+.2} %, k1 {:+.4} off)",
            error[format!("{key}_translation_mm")].as_f64().unwrap_or(f64::NAN),
            error[format!("{key}_rotation_deg")].as_f64().unwrap_or(f64::NAN),
            error["fx_percent"].as_f64().unwrap_or(f64::NAN),
            error["fy_percent"].as_f64().unwrap_or(f64::NAN),
            error["k1"].as_f64().unwrap_or(f64::NAN),
            believed[format!("{key}_translation_mm")].as_f64().unwrap_or(f64::NAN),
            believed[format!("{key}_rotation_deg")].as_f64().unwrap_or(f64::NAN),
            believed["fx_percent"].as_f64().unwrap_or(f64::NAN),
            believed["fy_percent"].as_f64().unwrap_or(f64::NAN),
            believed["k1"].as_f64().unwrap_or(f64::NAN),
        );
    }
    text.push_str(&changes_text(&changes));
    let _ = writeln!(text, "wrote {} (the views are in {})", out.display(), views_dir.display());
    if let Some(applied) = applied {
        text.push_str(&applied.text());
    }
    text
}
