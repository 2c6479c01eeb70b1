//! The preflight's judgement of the first twist: the law's twist on the frame now, run through the cell's own
//! rmrc stage from the joints now, against every joint's speed, acceleration and jerk limit and the tool's cap.

use serde_json::{Value, json};
use vservo_arm::JointVector;
use vservo_cell::{Cell, DriverTick, TwistLimits};
use vservo_control::Twist;

use super::verdicts::{Line, Observed};

/// A limit is kept when the ratio to it is at most this (floating-point rounding of the differences).
const WITHIN: f64 = 1.0 + 1e-6;

/// From this share of its acceleration or jerk limit on, the first frame saturates the reference: it cannot
/// follow the law's twist within the frame (the generator keeps 0.990 and 0.985 of them at most).
const SATURATED: f64 = 0.95;

/// The motion the first twist makes over one frame, run through the cell's own interpolator from the joints
/// now: the largest share of each limit it reaches.
#[derive(Debug, Clone, PartialEq)]
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
    /// The dynamics override it ran at.
    pub speed_scale: f64,
    /// The joint reference at each tick of the frame, the joints now first.
    pub path: Vec<JointVector>,
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
        holder_from_camera: Some(&base_from_camera),
        unseen_s: 0.0,
    }));
    let twist = step.twist;
    let period_s = config.robot.period_s;
    let period_ns = vservo_time::nanos(period_s);
    let ticks = (config.timing.vision_period_s / period_s).round().max(1.0) as u64;
    let mut rmrc = cell.rmrc(&q_now);
    // the dynamics override in force (`vservoctl speed`), else the configuration's
    rmrc.set_speed_scale(observed.speed_scale.unwrap_or(config.interpolator.speed_scale));
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
        speed_scale: rmrc.speed_scale(),
        path: vec![q_now],
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
        worst.path.push(q);
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
        "the law's first twist |v| {v:.3} m/s, |ω| {w:.3} rad/s{}; over its frame (speed scale {}) the joints reach \
         {:.2} of their speed, {:.2} of their acceleration and {} of their jerk limits, the tool {:.2} of its speed \
         cap",
        if motion.admitted {
            String::new()
        } else {
            format!(
                " is beyond robot.max_camera_speed_m_s {} / max_camera_rotation_rad_s {}: the rmrc would refuse it \
                 and stop the arm",
                config.robot.max_camera_speed_m_s, config.robot.max_camera_rotation_rad_s
            )
        },
        motion.speed_scale,
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
                "jerk_ratio": motion.jerk_ratio, "tool_speed_ratio": motion.tool_speed_ratio,
                "speed_scale": motion.speed_scale }),
    )
    .warning(saturation_warning(&motion))
}

/// When the first frame already reaches the acceleration or jerk limits in force (the arm's at the speed scale):
/// the reference lags the twist, which the law's design (an arm that follows its twist within a period) does
/// not know.
fn saturation_warning(motion: &FirstMotion) -> Option<String> {
    let scale = motion.speed_scale;
    let saturated: Vec<String> =
        [("acceleration", Some(motion.acceleration_ratio)), ("jerk", motion.jerk_ratio)]
            .into_iter()
            .filter_map(|(limit, ratio)| {
                ratio.map(|r| r / scale).filter(|r| *r >= SATURATED).map(|r| format!("{r:.2} of its {limit}"))
            })
            .collect();
    let in_force = if scale < 1.0 { format!(" (at speed scale {scale})") } else { String::new() };
    (!saturated.is_empty()).then(|| {
        format!(
            "the first frame already reaches {} limits{in_force}: the reference cannot follow the law's twist \
             within the frame, and a law designed for an arm that follows its twist may swing; start slower \
             (robot.max_camera_speed_m_s, robot.max_camera_rotation_rad_s) or nearer the target \
             (docs/DRIVERS.md, \"First motion on a real arm\")",
            saturated.join(" and ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::super::verdicts::fixtures::*;
    use super::*;

    #[test]
    fn the_first_twist_from_the_scenario_start_keeps_every_limit_and_uses_the_jerk() {
        // a real UR5e's cell (the file's own simulated plant is the ideal robot, which keeps no limit)
        let mut config = ur5e();
        config.cell.robot.driver = vservo_config::RobotDriver::External;
        let cell = Cell::new(&config.cell).expect("the UR5e cell");
        let start = *cell.start_joints();
        let base_from_camera = config.cell.arm.base_from_tool(&start) * config.cell.tool_from_camera;
        let features = config
            .cell
            .camera
            .project_marks(&config.cell.board, &config.cell.camera_from_board_at(&config.cell.arm, &start))
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
        // the UR5e's limits are low: the first frame reaches them, and the line says so
        assert!(
            line.warning.as_deref().is_some_and(|w| w.contains("limits: the reference cannot")),
            "{line:?}"
        );
        // the servo's own twist limit: a cell that allows only a crawl refuses this twist
        let mut crawl = config.clone();
        crawl.cell.robot.max_camera_speed_m_s = 0.01;
        let cell = Cell::new(&crawl.cell).expect("the UR5e cell");
        let line = first_twist(&seen, &cell);
        assert!(!line.pass && line.text.contains("would refuse it"), "{line:?}");
    }

    #[test]
    fn a_first_frame_at_the_acceleration_or_jerk_limit_is_a_warning() {
        let motion = |acceleration_ratio, jerk_ratio| FirstMotion {
            twist: Twist::zeros(),
            admitted: true,
            velocity_ratio: 0.3,
            acceleration_ratio,
            jerk_ratio,
            tool_speed_ratio: 0.2,
            speed_scale: 1.0,
            path: Vec::new(),
        };
        let both = saturation_warning(&motion(0.99, Some(0.985))).expect("a warning");
        assert!(both.contains("0.99 of its acceleration and 0.98 of its jerk limits"), "{both}");
        assert!(
            saturation_warning(&motion(0.97, None)).is_some_and(|w| w.contains("0.97 of its acceleration"))
        );
        assert_eq!(saturation_warning(&motion(0.6, Some(0.94))), None);
        assert_eq!(saturation_warning(&motion(0.6, None)), None);
    }
}
