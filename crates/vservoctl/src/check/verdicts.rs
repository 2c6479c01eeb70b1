//! The preflight's judgements: pure functions from what was observed of the cell (and the configuration in
//! force) to one [`Line`] each. Nothing here reads a message or a clock, so each can be checked on its own.

use serde_json::{Value, json};
use vservo_arm::{JointVector, SerialArm};
use vservo_cell::{Cell, DriverTick, TwistLimits};
use vservo_config::Config;
use vservo_control::Twist;
use vservo_protocol::{DaemonState, Fault};
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS};

/// A joint state period this far from the configured one (share of it, on the median) fails.
pub const PERIOD_TOLERANCE: f64 = 0.05;
/// The board seen farther than this from where the configuration places it (m) fails the kinematics check.
pub const BOARD_POSITION_TOLERANCE_M: f64 = 0.025;
/// … or turned more than this (rad, 5°).
pub const BOARD_ROTATION_TOLERANCE_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// Frames this much slower than the configured vision period (median) fail the camera check.
pub const FRAME_PERIOD_TOLERANCE: f64 = 0.5;
/// A limit is kept when the ratio to it is at most this (floating-point rounding of the differences).
const WITHIN: f64 = 1.0 + 1e-6;

/// One check's verdict: whether it passed, the line that says what was measured, and the values.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// The check's name.
    pub name: &'static str,
    /// Whether it passed.
    pub pass: bool,
    /// What was measured, in words.
    pub text: String,
    /// What was measured, as numbers (the JSON view).
    pub values: Value,
}

impl Line {
    fn new(name: &'static str, pass: bool, text: String, values: Value) -> Self {
        Self { name, pass, text, values }
    }
}

/// One joint state as the check keeps it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateSample {
    /// Its tick.
    pub tick: u64,
    /// When `q` was measured (ns).
    pub stamp_ns: u64,
    /// The period the driver declares (ns).
    pub period_ns: u64,
    /// The joints it says it carries.
    pub joint_count: u32,
    /// The joint angles (rad).
    pub q: JointVector,
}

/// One frame's features as the check keeps them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSample {
    /// When the image was taken (ns).
    pub capture_stamp_ns: u64,
    /// ξ (px), NaN where a mark is not valid.
    pub features: FeatureVector,
    /// The marks found.
    pub marks_found: u32,
    /// The camera's pose at capture from the measured joints, if known.
    pub base_from_camera: Option<IsometryMatrix3<f64>>,
}

/// What the check saw of the cell.
#[derive(Debug, Clone, Default)]
pub struct Observed {
    /// How long it looked (s).
    pub window_s: f64,
    /// The joint states, in order.
    pub states: Vec<StateSample>,
    /// The frames, in order.
    pub frames: Vec<FrameSample>,
    /// The daemon's state and its fault, if it answered.
    pub daemon: Option<(DaemonState, Fault)>,
    /// ξ_d in force (the daemon's gains), if they were read.
    pub desired_features: Option<FeatureVector>,
    /// The names the arm's ROS 2 node publishes on its joint states (the ROS 2 driver only), if heard.
    pub ros_joint_names: Option<Vec<String>>,
}

impl Observed {
    /// The newest joint state.
    pub fn newest_state(&self) -> Option<&StateSample> {
        self.states.last()
    }

    /// The newest frame that found all four marks and knows where the camera was.
    pub fn newest_whole_frame(&self) -> Option<(&FrameSample, IsometryMatrix3<f64>)> {
        self.frames
            .iter()
            .rev()
            .find_map(|f| (f.marks_found as usize == MARKS).then_some(f).zip(f.base_from_camera))
    }
}

/// The median of a non-empty slice (sorted in place).
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// The cell is held (nothing moves while the check looks): held at its start, or stopped safely.
pub fn held(observed: &Observed) -> Line {
    let (pass, text, state) = match observed.daemon {
        None => (false, "no status from vservod".to_string(), Value::Null),
        Some((DaemonState::SafeStop, fault)) => {
            let how = if fault == Fault::StartHeld {
                "held at its start".to_string()
            } else {
                format!("stopped safely ({fault})")
            };
            (true, format!("{how}: nothing moves until `vservoctl resume`"), json!(fault.name()))
        }
        Some((state, _)) => (
            false,
            format!(
                "the cell is {state}: the arm may move while the check looks (`vservoctl safe-stop` first, or \
                 [robot] start = \"held\")"
            ),
            json!(state.name()),
        ),
    };
    Line::new("held", pass, text, json!({ "state": state }))
}

/// Joint states arrive at the declared period: the driver declares the configured period, and the median
/// gap between consecutive ticks is within [`PERIOD_TOLERANCE`] of it.
pub fn joint_states(observed: &Observed, config: &Config) -> Line {
    let configured_ns = config.robot.period_s * 1e9;
    let name = "joint_states";
    let Some(newest) = observed.newest_state() else {
        return Line::new(
            name,
            false,
            format!(
                "no joint state in {:.1} s: is the robot driver running (docs/DRIVERS.md), and is its stream for \
                 this instance?",
                observed.window_s
            ),
            json!({ "states": 0, "configured_period_ms": configured_ns / 1e6 }),
        );
    };
    let mut gaps: Vec<f64> = observed
        .states
        .windows(2)
        .filter(|w| w[1].tick == w[0].tick + 1)
        .map(|w| w[1].stamp_ns.saturating_sub(w[0].stamp_ns) as f64)
        .collect();
    let largest_gap_ns = gaps.iter().copied().fold(0.0, f64::max);
    let median_ns = if gaps.is_empty() { f64::NAN } else { median(&mut gaps) };
    let declared_ns = newest.period_ns as f64;
    let declared_ok = (declared_ns - configured_ns).abs() <= 1e3;
    let arriving_ok = (median_ns - configured_ns).abs() <= PERIOD_TOLERANCE * configured_ns;
    let text = format!(
        "{} states in {:.2} s, every {:.3} ms (median; largest gap {:.3} ms); the driver declares {:.3} ms, the \
         configuration (robot.period_s) {:.3} ms{}",
        observed.states.len(),
        observed.window_s,
        median_ns / 1e6,
        largest_gap_ns / 1e6,
        declared_ns / 1e6,
        configured_ns / 1e6,
        if !declared_ok {
            ": the driver runs at another period than configured"
        } else if !arriving_ok {
            ": the states do not come at the declared period"
        } else {
            ""
        }
    );
    Line::new(
        name,
        declared_ok && arriving_ok,
        text,
        json!({
            "states": observed.states.len(),
            "median_period_ms": finite(median_ns / 1e6),
            "largest_gap_ms": largest_gap_ns / 1e6,
            "declared_period_ms": declared_ns / 1e6,
            "configured_period_ms": configured_ns / 1e6,
        }),
    )
}

/// The names the driver addresses the arm's joints by, and where they come from: for the ROS 2 driver
/// `[ros2] joint_names`, else the URDF's, else joint1… (`vservo_ros2::convert::joint_names`); for others the
/// URDF's chain (none for a DH arm).
pub fn driver_joint_names(config: &Config) -> (Vec<String>, &'static str) {
    let arm = &config.arm;
    if config.ros2.driver.arm {
        let from =
            if config.ros2.joint_names.is_empty() { "the ROS 2 driver's names" } else { "ros2.joint_names" };
        (vservo_ros2::convert::joint_names(&config.ros2.joint_names, arm), from)
    } else if let Some(urdf) = urdf_joint_names(arm) {
        (urdf, "the URDF's chain")
    } else {
        (Vec::new(), "a DH arm: joints by number")
    }
}

/// The URDF chain's joint names, base outwards (`None` for a DH arm).
pub fn urdf_joint_names(arm: &SerialArm) -> Option<Vec<String>> {
    match &arm.geometry {
        vservo_arm::Geometry::Chain(chain) => Some(chain.joints.iter().map(|j| j.name.clone()).collect()),
        vservo_arm::Geometry::Dh => None,
    }
}

/// The joints: the count the driver sends is the arm's; the names the driver addresses them by are the
/// URDF's (in its order) and, for the ROS 2 driver, in the arm's joint states; every measured angle inside
/// its limits.
pub fn joints(observed: &Observed, config: &Config) -> Line {
    let arm = &config.arm;
    let (names, names_from) = driver_joint_names(config);
    let mut problems = Vec::new();
    let count = observed.newest_state().map(|s| s.joint_count);
    match count {
        Some(n) if n as usize != arm.joint_count() => problems.push(format!(
            "the driver sends {n} joints, the arm ({}) has {}",
            arm.name,
            arm.joint_count()
        )),
        None => problems.push("no joint state to count the joints of".to_string()),
        Some(_) => {}
    }
    if let Some(urdf) = urdf_joint_names(arm) {
        for (j, (name, expected)) in names.iter().zip(&urdf).enumerate() {
            if name != expected {
                problems.push(format!(
                    "{names_from}[{}] is {name:?}, the URDF's joint {} is {expected:?}",
                    j + 1,
                    j + 1
                ));
            }
        }
    }
    if let Some(published) = &observed.ros_joint_names {
        for (j, name) in names.iter().enumerate() {
            if !published.contains(name) {
                problems.push(format!(
                    "the arm's joint states have no joint {name:?} ({names_from}[{}]); they name {}",
                    j + 1,
                    published.join(", ")
                ));
            }
        }
    }
    if let Some(state) = observed.newest_state() {
        for (j, limits) in arm.limits().enumerate() {
            let q = state.q[j];
            if !limits.position_ok(q) {
                problems.push(format!(
                    "joint {} is at {q:.4} rad, outside its limits [{:.4}, {:.4}]",
                    j + 1,
                    limits.position_min,
                    limits.position_max
                ));
            }
        }
    }
    let pass = problems.is_empty();
    let text = if pass {
        let named = if names.is_empty() { names_from.to_string() } else { names.join(", ") };
        format!(
            "{} joints as the arm ({}): {named}; every angle inside its limits",
            arm.joint_count(),
            arm.name
        )
    } else {
        problems.join("; ")
    };
    Line::new(
        "joints",
        pass,
        text,
        json!({ "joint_count": count, "arm_joint_count": arm.joint_count(), "names": names,
                "names_from": names_from, "published_names": observed.ros_joint_names }),
    )
}

/// The board as the camera sees it (features of a whole frame, the camera's pose from the measured joints),
/// in the base frame; `None` when no whole frame came or the features fit no board pose.
pub fn measured_board(observed: &Observed, config: &Config) -> Option<IsometryMatrix3<f64>> {
    let (frame, base_from_camera) = observed.newest_whole_frame()?;
    let features = pinhole_features(config, &frame.features)?;
    let camera_from_board = config.camera.board_pose_from_features(&config.board, &features)?;
    Some(base_from_camera * camera_from_board)
}

/// The features as the pinhole camera has them (undistorted when the vision node left them as seen).
fn pinhole_features(config: &Config, features: &FeatureVector) -> Option<FeatureVector> {
    if config.vision.undistort {
        return Some(*features);
    }
    let mut pinhole = *features;
    for mark in 0..MARKS {
        let p = config
            .camera
            .pinhole_of_observed(&nalgebra::Point2::new(features[2 * mark], features[2 * mark + 1]))?;
        pinhole[2 * mark] = p.x;
        pinhole[2 * mark + 1] = p.y;
    }
    Some(pinhole)
}

/// The arm's measured pose agrees with the configured kinematics: the board the camera sees, placed in the
/// base frame by the forward kinematics of the measured joints and `tool_from_camera`, is where the
/// configuration places it (by `[desired]`), within [`BOARD_POSITION_TOLERANCE_M`] and
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
    let configured = config.base_from_board(&config.arm);
    let offset = configured.inverse() * measured;
    let distance_m = offset.translation.vector.norm();
    let angle_rad = offset.rotation.angle();
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
            ": the arm's kinematics, tool_from_camera, the camera's intrinsics or [desired] (which places the \
             board) are not the cell's, or the board is not where it should stand"
        }
    );
    Line::new(
        name,
        pass,
        text,
        json!({ "board_offset_mm": distance_m * 1e3, "board_offset_deg": angle_rad.to_degrees(),
                "measured_base_from_board_m": measured.translation.vector.as_slice() }),
    )
}

/// Frames arrive (at about the configured vision period) and the target is found: all four marks in the
/// newest frame.
pub fn camera(observed: &Observed, config: &Config) -> Line {
    let name = "camera";
    let configured_ms = config.timing.vision_period_s * 1e3;
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

/// Where the camera is to end: the board (as seen, else as configured) with the target in force in front of
/// it; `None` when the target's features fit no board pose.
pub fn desired_camera(observed: &Observed, config: &Config) -> Option<IsometryMatrix3<f64>> {
    let base_from_board =
        measured_board(observed, config).unwrap_or_else(|| config.base_from_board(&config.arm));
    let camera_from_board = match observed.desired_features {
        Some(features) if features != config.desired.features => {
            config.camera.board_pose_from_features(&config.board, &features)?
        }
        _ => config.desired.camera_from_board,
    };
    Some(base_from_board * camera_from_board.inverse())
}

/// The desired pose is reachable: joints inside the limits put the camera there (nearest the joints now),
/// and the arm is not at a singularity there (manipulability above the interpolator's damping threshold).
pub fn desired_pose(observed: &Observed, config: &Config) -> Line {
    let name = "desired_pose";
    let arm = &config.arm;
    let q_now = observed.newest_state().map_or(config.desired.joints, |s| s.q);
    let Some(base_from_camera) = desired_camera(observed, config) else {
        return Line::new(name, false, "the target's features fit no board pose".to_string(), Value::Null);
    };
    let board_from =
        if measured_board(observed, config).is_some() { "as seen" } else { "as configured: not seen" };
    let base_from_tool = base_from_camera * config.tool_from_camera.inverse();
    let position = base_from_camera.translation.vector;
    let Some(q) = arm.reach(&base_from_tool, &q_now) else {
        return Line::new(
            name,
            false,
            format!(
                "unreachable: no joints inside the limits put the camera at its desired pose ({:.3}, {:.3}, {:.3}) m \
                 in the base frame, {:.3} m from the base (the target before the board {board_from})",
                position.x,
                position.y,
                position.z,
                position.norm(),
            ),
            json!({ "reachable": false, "desired_camera_position_m": position.as_slice() }),
        );
    };
    let manipulability = arm.manipulability(&q);
    let threshold = config.interpolator.manipulability_threshold;
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

/// The motion the first twist makes over one frame, run through the cell's own interpolator from the joints
/// now: the largest share of each limit it reaches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirstMotion {
    /// The twist (camera frame: m/s, rad/s).
    pub twist: Twist,
    /// Whether the rmrc would take it (within robot.max_camera_speed_m_s and _rotation_rad_s).
    pub admitted: bool,
    /// Largest |q̇| / velocity limit.
    pub velocity_ratio: f64,
    /// Largest |q̈| / acceleration limit.
    pub acceleration_ratio: f64,
    /// Largest |q⃛| / jerk limit (`None` without jerk limits).
    pub jerk_ratio: Option<f64>,
    /// Largest tool speed / its cap (0 without a cap).
    pub tool_speed_ratio: f64,
}

/// Runs the first twist (the law's on the newest whole frame) through the rmrc for one frame.
pub fn first_motion(observed: &Observed, cell: &Cell) -> Option<FirstMotion> {
    let config = cell.config();
    let (frame, base_from_camera) = observed.newest_whole_frame()?;
    let q_now = observed.newest_state()?.q;
    let mut servo = cell.servo();
    let step = servo.step(Some(vservo_cell::ServoInput {
        frame: 1,
        features: &frame.features,
        base_from_camera: Some(&base_from_camera),
    }));
    let twist = step.twist;
    let period_s = config.robot.period_s;
    let period_ns = (period_s * 1e9).round() as u64;
    let ticks = (config.timing.vision_period_s / period_s).round().max(1.0) as u64;
    let mut rmrc = cell.rmrc(&q_now);
    let arm = cell.arm();
    let n = arm.joint_count();
    let limits: Vec<_> = arm.limits().collect();
    let settings = &config.interpolator;
    let (mut q, mut qd, mut qdd) = (q_now, JointVector::zeros(), JointVector::zeros());
    let mut admitted = true;
    let mut worst = FirstMotion {
        twist,
        admitted,
        velocity_ratio: 0.0,
        acceleration_ratio: 0.0,
        jerk_ratio: settings.jerk_limit.map(|_| 0.0),
        tool_speed_ratio: 0.0,
    };
    for tick in 0..=ticks {
        let at = DriverTick { epoch: 1, tick, stamp_ns: tick * period_ns, holding: false };
        rmrc.follow(at, &q, &qd);
        if tick == 0 {
            admitted = rmrc.take_twist(&twist, step.verdict.moves(), &TwistLimits::of(config), 0);
        }
        rmrc.step(tick, &q, &qd);
        let reference = *rmrc.reference();
        let qdd_now = (reference.qd - qd) / period_s;
        for j in 0..n {
            worst.velocity_ratio = worst.velocity_ratio.max(reference.qd[j].abs() / limits[j].velocity_max);
            worst.acceleration_ratio =
                worst.acceleration_ratio.max(qdd_now[j].abs() / settings.acceleration_limit[j]);
            if let (Some(jerk), Some(limit)) = (worst.jerk_ratio.as_mut(), settings.jerk_limit) {
                *jerk = jerk.max(((qdd_now[j] - qdd[j]) / period_s).abs() / limit[j]);
            }
        }
        let tool_velocity = arm.jacobian_base(&reference.q) * reference.qd;
        let tool_speed = tool_velocity.fixed_rows::<3>(0).norm();
        if settings.tool_speed_limit_m_s.is_finite() {
            worst.tool_speed_ratio = worst.tool_speed_ratio.max(tool_speed / settings.tool_speed_limit_m_s);
        }
        (q, qd, qdd) = (reference.q, reference.qd, qdd_now);
    }
    worst.admitted = admitted;
    Some(worst)
}

/// The first twist's joint motion is within the limits: the rmrc takes the twist, and over the first frame
/// the joint reference keeps every joint's speed, acceleration and jerk limit and the tool's speed cap.
pub fn first_twist(observed: &Observed, cell: &Cell) -> Line {
    let name = "first_twist";
    let Some(motion) = first_motion(observed, cell) else {
        return Line::new(
            name,
            false,
            "no frame with all four marks, or no joint state: no first twist to check".to_string(),
            Value::Null,
        );
    };
    let v = motion.twist.fixed_rows::<3>(0).norm();
    let w = motion.twist.fixed_rows::<3>(3).norm();
    let within = motion.velocity_ratio <= WITHIN
        && motion.acceleration_ratio <= WITHIN
        && motion.jerk_ratio.is_none_or(|r| r <= WITHIN)
        && motion.tool_speed_ratio <= WITHIN;
    let pass = motion.admitted && within;
    let config = cell.config();
    let text = format!(
        "the law's first twist |v| {v:.3} m/s, |ω| {w:.3} rad/s{}; over its frame the joints reach {:.2} of their \
         speed, {:.2} of their acceleration and {} of their jerk limits, the tool {:.2} of its speed cap",
        if motion.admitted {
            String::new()
        } else {
            format!(
                " is beyond robot.max_camera_speed_m_s {} / max_camera_rotation_rad_s {}: the rmrc would refuse it \
                 and stop the arm",
                config.robot.max_camera_speed_m_s, config.robot.max_camera_rotation_rad_s
            )
        },
        motion.velocity_ratio,
        motion.acceleration_ratio,
        motion.jerk_ratio.map_or("(no jerk limit)".to_string(), |r| format!("{r:.2}")),
        motion.tool_speed_ratio
    );
    Line::new(
        name,
        pass,
        text,
        json!({ "twist": motion.twist.as_slice(), "admitted": motion.admitted,
                "velocity_ratio": motion.velocity_ratio, "acceleration_ratio": motion.acceleration_ratio,
                "jerk_ratio": motion.jerk_ratio, "tool_speed_ratio": motion.tool_speed_ratio }),
    )
}

/// A number for JSON: `null` when not finite.
fn finite(value: f64) -> Value {
    if value.is_finite() { json!(value) } else { Value::Null }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ur5e() -> Config {
        Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/arms/ur5e.toml"))
            .expect("ur5e.toml loads")
    }

    /// States every `gap_ns` declaring `period_ns`, at the desired joints.
    fn states(config: &Config, count: u64, gap_ns: u64, period_ns: u64) -> Vec<StateSample> {
        (0..count)
            .map(|tick| StateSample {
                tick,
                stamp_ns: 1_000_000 + tick * gap_ns,
                period_ns,
                joint_count: 6,
                q: config.desired.joints,
            })
            .collect()
    }

    /// Frames of the board seen from the desired pose, `marks` of them valid.
    fn frames(config: &Config, count: u64, marks: usize) -> Vec<FrameSample> {
        let base_from_camera = config.arm.base_from_tool(&config.desired.joints) * config.tool_from_camera;
        let mut features = config.desired.features;
        for mark in marks..MARKS {
            features[2 * mark] = f64::NAN;
            features[2 * mark + 1] = f64::NAN;
        }
        (0..count)
            .map(|i| FrameSample {
                capture_stamp_ns: i * 84_000_000,
                features,
                marks_found: marks as u32,
                base_from_camera: Some(base_from_camera),
            })
            .collect()
    }

    fn observed(config: &Config) -> Observed {
        Observed {
            window_s: 1.0,
            states: states(config, 500, 2_000_000, 2_000_000),
            frames: frames(config, 12, 4),
            daemon: Some((DaemonState::SafeStop, Fault::StartHeld)),
            desired_features: None,
            ros_joint_names: None,
        }
    }

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
    fn a_servoing_cell_is_not_held() {
        let config = ur5e();
        let seen = Observed { daemon: Some((DaemonState::Running, Fault::None)), ..observed(&config) };
        let line = held(&seen);
        assert!(!line.pass && line.text.contains("running"), "{line:?}");
    }

    #[test]
    fn states_at_another_period_or_none_fail_and_jitter_around_the_period_passes() {
        let config = ur5e();
        let declared_4ms =
            Observed { states: states(&config, 250, 4_000_000, 4_000_000), ..observed(&config) };
        let line = joint_states(&declared_4ms, &config);
        assert!(!line.pass && line.text.contains("another period"), "{line:?}");
        // declared right, arriving every 2.5 ms
        let slow = Observed { states: states(&config, 400, 2_500_000, 2_000_000), ..observed(&config) };
        let line = joint_states(&slow, &config);
        assert!(!line.pass && line.text.contains("do not come at the declared period"), "{line:?}");
        let none = Observed { states: Vec::new(), ..observed(&config) };
        assert!(!joint_states(&none, &config).pass);
        // one late state in ten: the median keeps the period
        let mut jittery = observed(&config);
        for (i, state) in jittery.states.iter_mut().enumerate() {
            state.stamp_ns += if i % 10 == 5 { 900_000 } else { 0 };
        }
        assert!(joint_states(&jittery, &config).pass);
    }

    #[test]
    fn another_joint_count_a_name_the_arm_does_not_publish_and_an_angle_out_of_range_fail() {
        let config = ur5e();
        let mut seen = observed(&config);
        seen.states.iter_mut().for_each(|s| s.joint_count = 7);
        let line = joints(&seen, &config);
        assert!(!line.pass && line.text.contains("sends 7 joints"), "{line:?}");
        let mut seen = observed(&config);
        seen.ros_joint_names = Some(vec!["a".into(), "b".into()]);
        let line = joints(&seen, &config);
        assert!(!line.pass && line.text.contains("no joint \"shoulder_pan_joint\""), "{line:?}");
        let mut seen = observed(&config);
        seen.states.iter_mut().for_each(|s| s.q[2] = 4.0);
        let line = joints(&seen, &config);
        assert!(!line.pass && line.text.contains("joint 3 is at 4.0000 rad"), "{line:?}");
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

    #[test]
    fn the_first_twist_from_the_scenario_start_keeps_every_limit_and_uses_the_jerk() {
        // a real UR5e's cell (the file's own simulated plant is the ideal robot, which keeps no limit)
        let mut config = ur5e();
        config.robot.driver = vservo_config::RobotDriver::External;
        let cell = Cell::new(&config).expect("the UR5e cell");
        let start = *cell.start_joints();
        let base_from_camera = config.arm.base_from_tool(&start) * config.tool_from_camera;
        let features = config
            .camera
            .project_marks(&config.board, &config.camera_from_board_at(&config.arm, &start))
            .expect("the board in front");
        let mut seen = observed(&config);
        seen.states.iter_mut().for_each(|s| s.q = start);
        seen.frames.iter_mut().for_each(|f| {
            f.features = features;
            f.base_from_camera = Some(base_from_camera);
        });
        let line = first_twist(&seen, &cell);
        assert!(line.pass, "{line:?}");
        let jerk = line.values["jerk_ratio"].as_f64().expect("the UR5e has jerk limits");
        assert!(jerk > 0.5 && jerk <= WITHIN, "{line:?}");
        // the servo's own twist limit: a cell that allows only a crawl refuses this twist
        let mut crawl = config.clone();
        crawl.robot.max_camera_speed_m_s = 0.01;
        let cell = Cell::new(&crawl).expect("the UR5e cell");
        let line = first_twist(&seen, &cell);
        assert!(!line.pass && line.text.contains("would refuse it"), "{line:?}");
    }
}
