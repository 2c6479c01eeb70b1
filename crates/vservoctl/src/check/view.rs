//! The preflight's judgements of what the camera sees: the kinematics against the board seen, the frames and
//! the marks, and the desired pose's reach before the board.

use serde_json::{Value, json};
use vservo_config::Config;
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS};

use super::verdicts::{Line, Observed, finite, median};

/// The board seen farther than this from where the configuration places it (m) fails the kinematics check.
pub const BOARD_POSITION_TOLERANCE_M: f64 = 0.025;
/// … or turned more than this (rad, 5°).
pub const BOARD_ROTATION_TOLERANCE_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Frames this much slower than the configured vision period (median) fail the camera check.
pub const FRAME_PERIOD_TOLERANCE: f64 = 0.5;

/// The board as the camera sees it (features of a whole frame, the camera's pose from the measured joints),
/// in the frame that holds it: the base for a camera on the hand, the tool for a fixed one (the frame the
/// features' camera pose is in); `None` when no whole frame came or the features fit no board pose.
pub fn measured_board(observed: &Observed, config: &Config) -> Option<IsometryMatrix3<f64>> {
    let (frame, holder_from_camera) = observed.newest_whole_frame()?;
    let features = pinhole_features(config, &frame.features)?;
    let camera_from_board = config.cell.camera.board_pose_from_features(&config.cell.board, &features)?;
    Some(holder_from_camera * camera_from_board)
}

/// Where the configuration places the board, in the frame that holds it: standing in the base (by `[desired]`)
/// for a camera on the hand, on the tool for a fixed one.
fn configured_board(config: &Config) -> IsometryMatrix3<f64> {
    match config.cell.fixed_camera {
        None => config.cell.base_from_board(&config.cell.arm),
        Some(fixed) => fixed.tool_from_board,
    }
}

/// The features as the pinhole camera has them (undistorted when the vision node left them as seen).
fn pinhole_features(config: &Config, features: &FeatureVector) -> Option<FeatureVector> {
    if config.cell.vision.undistort {
        return Some(*features);
    }
    let mut pinhole = *features;
    for mark in 0..MARKS {
        let p = config
            .cell
            .camera
            .pinhole_of_observed(&nalgebra::Point2::new(features[2 * mark], features[2 * mark + 1]))?;
        pinhole[2 * mark] = p.x;
        pinhole[2 * mark + 1] = p.y;
    }
    Some(pinhole)
}

/// The arm's measured pose agrees with the configured kinematics: the board the camera sees, placed in the
/// base frame by the forward kinematics of the measured joints and `tool_from_camera` (a fixed camera's: on the
/// tool, by `base_from_camera` and the forward kinematics), is where the configuration places it (by
/// `[desired]`), within [`BOARD_POSITION_TOLERANCE_M`] and
/// [`BOARD_ROTATION_TOLERANCE_RAD`].
pub fn kinematics(observed: &Observed, config: &Config) -> Line {
    let name = "kinematics";
    let Some(measured) = measured_board(observed, config) else {
        return Line::new(
            name,
            false,
            "no frame with all four marks and the camera's pose: nothing to compare the kinematics with (see \
             camera)"
                .to_string(),
            Value::Null,
        );
    };
    let configured = configured_board(config);
    let offset = configured.inverse() * measured;
    let distance_m = offset.translation.vector.norm();
    let angle_rad = vservo_scene::rotation_angle_rad(&offset.rotation);
    let pass = distance_m <= BOARD_POSITION_TOLERANCE_M && angle_rad <= BOARD_ROTATION_TOLERANCE_RAD;
    let text = format!(
        "the board seen from the measured joints is {:.1} mm and {:.2}° from where the configuration places it \
         (at most {:.0} mm, {:.0}°){}",
        distance_m * 1e3,
        angle_rad.to_degrees(),
        BOARD_POSITION_TOLERANCE_M * 1e3,
        BOARD_ROTATION_TOLERANCE_RAD.to_degrees(),
        if pass {
            ""
        } else {
            ": the arm's kinematics, the camera's mount (tool_from_camera, base_from_camera), its intrinsics or \
             [desired] (which places the board) are not the cell's, or the board is not where it should be"
        }
    );
    let measured_key = if config.cell.fixed_camera.is_some() {
        "measured_tool_from_board_m"
    } else {
        "measured_base_from_board_m"
    };
    Line::new(
        name,
        pass,
        text,
        json!({ "board_offset_mm": distance_m * 1e3, "board_offset_deg": angle_rad.to_degrees(),
                measured_key: measured.translation.vector.as_slice() }),
    )
}

/// Frames arrive (at about the configured vision period) and the target is found: all four marks in the
/// newest frame.
pub fn camera(observed: &Observed, config: &Config) -> Line {
    let name = "camera";
    let configured_ms = config.cell.timing.vision_period_s * 1e3;
    let Some(newest) = observed.frames.last() else {
        return Line::new(
            name,
            false,
            format!(
                "no frame in {:.1} s: is the camera (or its driver) running, and the vision node healthy \
                 (`vservoctl status`)?",
                observed.window_s
            ),
            json!({ "frames": 0 }),
        );
    };
    let mut gaps: Vec<f64> = observed
        .frames
        .windows(2)
        .map(|w| w[1].capture_stamp_ns.saturating_sub(w[0].capture_stamp_ns) as f64 / 1e6)
        .collect();
    let median_ms = if gaps.is_empty() { f64::NAN } else { median(&mut gaps) };
    let slow = median_ms.is_finite() && median_ms > configured_ms * (1.0 + FRAME_PERIOD_TOLERANCE);
    let found = newest.marks_found;
    let whole = found as usize == MARKS;
    let text = format!(
        "{} frames in {:.2} s (every {:.1} ms, median; configured {:.1} ms); the newest found {found} of {MARKS} \
         marks{}",
        observed.frames.len(),
        observed.window_s,
        median_ms,
        configured_ms,
        if !whole {
            ": the board is not (all) in view — move the arm or the board until the camera sees it"
        } else if slow {
            ": frames come slower than configured"
        } else {
            ""
        }
    );
    Line::new(
        name,
        whole && !slow,
        text,
        json!({ "frames": observed.frames.len(), "median_frame_period_ms": finite(median_ms),
                "configured_frame_period_ms": configured_ms, "marks_found": found }),
    )
}

/// Where the camera is to end relative to the board (as seen, else as configured) with the target in force in
/// front of it, in the frame that holds the board (the base on the hand, the tool fixed); `None` when the
/// target's features fit no board pose.
pub fn desired_camera(observed: &Observed, config: &Config) -> Option<IsometryMatrix3<f64>> {
    let base_from_board = measured_board(observed, config).unwrap_or_else(|| configured_board(config));
    let camera_from_board = match observed.desired_features {
        Some(features) if features != config.cell.desired.features => {
            config.cell.camera.board_pose_from_features(&config.cell.board, &features)?
        }
        _ => config.cell.desired.camera_from_board,
    };
    Some(base_from_board * camera_from_board.inverse())
}

/// The desired pose is reachable: joints inside the limits put the camera there (nearest the joints now),
/// and the arm is not at a singularity there (manipulability above the interpolator's damping threshold).
pub fn desired_pose(observed: &Observed, config: &Config) -> Line {
    let name = "desired_pose";
    let arm = &config.cell.arm;
    let q_now = observed.newest_state().map_or(config.cell.desired.joints, |s| s.q);
    let Some(holder_from_camera) = desired_camera(observed, config) else {
        return Line::new(name, false, "the target's features fit no board pose".to_string(), Value::Null);
    };
    let board_from =
        if measured_board(observed, config).is_some() { "as seen" } else { "as configured: not seen" };
    // a hand camera goes to its desired pose; a fixed camera stays, and the tool brings the board before it
    let (base_from_tool, what, position) = match config.cell.fixed_camera {
        None => {
            let base_from_tool = holder_from_camera * config.cell.tool_from_camera.inverse();
            (base_from_tool, "camera", holder_from_camera.translation.vector)
        }
        Some(fixed) => {
            let base_from_tool = fixed.base_from_camera * holder_from_camera.inverse();
            (base_from_tool, "tool", base_from_tool.translation.vector)
        }
    };
    let Some(q) = arm.reach(&base_from_tool, &q_now) else {
        return Line::new(
            name,
            false,
            format!(
                "unreachable: no joints inside the limits put the {what} at its desired pose ({:.3}, {:.3}, {:.3}) m \
                 in the base frame, {:.3} m from the base (the target before the board {board_from})",
                position.x,
                position.y,
                position.z,
                position.norm(),
            ),
            json!({ "reachable": false, format!("desired_{what}_position_m"): position.as_slice() }),
        );
    };
    let manipulability = arm.manipulability(&q);
    let threshold = config.cell.interpolator.manipulability_threshold;
    let farthest_rad = (q - q_now).amax();
    let pass = manipulability > threshold;
    let text = format!(
        "reachable (the target before the board {board_from}): joints [{}] rad, at most {farthest_rad:.3} rad from \
         now; manipulability {manipulability:.4} (the interpolator damps below {threshold:.4}){}",
        q.iter().take(arm.joint_count()).map(|v| format!("{v:.3}")).collect::<Vec<_>>().join(", "),
        if pass { "" } else { ": the desired pose is at a singularity" }
    );
    Line::new(
        name,
        pass,
        text,
        json!({ "reachable": true, "joints_rad": &q.as_slice()[..arm.joint_count()],
                "largest_joint_move_rad": farthest_rad, "manipulability": manipulability,
                "manipulability_threshold": threshold }),
    )
}

#[cfg(test)]
mod tests {
    use super::super::verdicts::fixtures::*;
    use super::super::verdicts::{held, joint_states, joints};
    use super::*;

    #[test]
    fn the_cell_as_configured_passes_every_pure_check() {
        let config = ur5e();
        let seen = observed(&config);
        for line in [
            held(&seen),
            joint_states(&seen, &config),
            joints(&seen, &config),
            kinematics(&seen, &config),
            camera(&seen, &config),
            desired_pose(&seen, &config),
        ] {
            assert!(line.pass, "{line:?}");
        }
        // the board seen where the configuration places it, to rounding
        assert!(kinematics(&seen, &config).values["board_offset_mm"].as_f64().expect("the offset") < 1e-6);
    }

    #[test]
    fn three_marks_or_no_frame_fail_the_camera_and_leave_nothing_to_compare() {
        let config = ur5e();
        let seen = Observed { frames: frames(&config, 12, 3), ..observed(&config) };
        let line = camera(&seen, &config);
        assert!(!line.pass && line.text.contains("3 of 4"), "{line:?}");
        assert!(!kinematics(&seen, &config).pass);
        assert!(!camera(&Observed { frames: Vec::new(), ..observed(&config) }, &config).pass);
    }

    #[test]
    fn a_board_seen_away_from_where_it_is_configured_fails_the_kinematics() {
        let config = ur5e();
        let mut seen = observed(&config);
        // the camera believed 3 cm higher than the joints put it: the board seems 3 cm off
        for frame in &mut seen.frames {
            let pose = frame.base_from_camera.expect("known");
            frame.base_from_camera = Some(nalgebra::Translation3::new(0.0, 0.0, 0.03) * pose);
        }
        let line = kinematics(&seen, &config);
        assert!(!line.pass, "{line:?}");
        let offset = line.values["board_offset_mm"].as_f64().expect("the offset");
        assert!((offset - 30.0).abs() < 1e-6, "{offset}");
    }
}
