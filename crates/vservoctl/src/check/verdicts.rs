//! The preflight's judgements of the stream and the joints, and what every judgement shares: pure functions from
//! what was observed of the cell (and the configuration in force) to one [`Line`] each. Nothing here reads a
//! message or a clock, so each can be checked on its own. The camera's view: [`super::view`]; the first twist:
//! [`super::first_twist`].

use serde_json::{Value, json};
use vservo_arm::{JointVector, SerialArm};
use vservo_config::Config;
use vservo_protocol::{DaemonState, Fault};
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS};

/// A joint state period this far from the configured one (share of it, on the median) fails.
pub const PERIOD_TOLERANCE: f64 = 0.05;

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
    /// A check that passed but saw something to watch: what, and what to do.
    pub warning: Option<String>,
}

impl Line {
    pub(super) fn new(name: &'static str, pass: bool, text: String, values: Value) -> Self {
        Self { name, pass, text, values, warning: None }
    }

    /// The line with `warning` (none when `None`).
    pub(super) fn warning(mut self, warning: Option<String>) -> Self {
        self.warning = warning;
        self
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
    /// The dynamics override in force, if the daemon answered.
    pub speed_scale: Option<f64>,
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
pub(super) fn median(values: &mut [f64]) -> f64 {
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
    let configured_ns = vservo_time::nanos(config.cell.robot.period_s) as f64;
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
    let arm = &config.cell.arm;
    if config.cell.robot.driver == vservo_config::RobotDriver::Ros2 {
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
    let arm = &config.cell.arm;
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
                // the nearest of the published names that are not the arm's other joints
                let others = published.iter().filter(|p| !names.contains(p)).map(String::as_str);
                let nearest = vservo_config::did_you_mean(name, others)
                    .map_or(String::new(), |nearest| format!("; did you mean {nearest:?}?"));
                problems.push(format!(
                    "the arm's joint states have no joint {name:?} ({names_from}[{}]); they name {}{nearest}",
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

/// A number for JSON: `null` when not finite.
pub(super) fn finite(value: f64) -> Value {
    if value.is_finite() { json!(value) } else { Value::Null }
}

/// The cells the checks' unit tests look at.
#[cfg(test)]
pub(super) mod fixtures {
    use super::*;

    pub fn ur5e() -> Config {
        Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/arms/ur5e.toml"))
            .expect("ur5e.toml loads")
    }

    /// States every `gap_ns` declaring `period_ns`, at the desired joints.
    pub fn states(config: &Config, count: u64, gap_ns: u64, period_ns: u64) -> Vec<StateSample> {
        (0..count)
            .map(|tick| StateSample {
                tick,
                stamp_ns: 1_000_000 + tick * gap_ns,
                period_ns,
                joint_count: 6,
                q: config.cell.desired.joints,
            })
            .collect()
    }

    /// Frames of the board seen from the desired pose, `marks` of them valid.
    pub fn frames(config: &Config, count: u64, marks: usize) -> Vec<FrameSample> {
        let base_from_camera =
            config.cell.arm.base_from_tool(&config.cell.desired.joints) * config.cell.tool_from_camera;
        let mut features = config.cell.desired.features;
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

    pub fn observed(config: &Config) -> Observed {
        Observed {
            window_s: 1.0,
            states: states(config, 500, 2_000_000, 2_000_000),
            frames: frames(config, 12, 4),
            daemon: Some((DaemonState::SafeStop, Fault::StartHeld)),
            speed_scale: Some(1.0),
            desired_features: None,
            ros_joint_names: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::*;
    use super::*;

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
        assert!(!line.text.contains("did you mean"), "{line:?}");
        // a slip in one name: the name meant is said
        let (names, _) = driver_joint_names(&config);
        let mut published = names.clone();
        published[1] = "shoulder_lift_joint_".into();
        let seen = Observed { ros_joint_names: Some(published), ..observed(&config) };
        let line = joints(&seen, &config);
        assert!(line.text.contains("did you mean \"shoulder_lift_joint_\"?"), "{line:?}");
        let mut seen = observed(&config);
        seen.states.iter_mut().for_each(|s| s.q[2] = 4.0);
        let line = joints(&seen, &config);
        assert!(!line.pass && line.text.contains("joint 3 is at 4.0000 rad"), "{line:?}");
    }
}
