//! From the file as written to a [`Config`]: every check, each naming its key and value.

use nalgebra::{Point2, Point3, SMatrix, Vector3};
use vservo_arm::{JointVector, puma560};
use vservo_control::{ControlLaw, InputUnits, InputWeight, Interaction, LawOptions, StateWeight};
use vservo_scene::{Board, CameraIntrinsics, FEATURES, FeatureVector, MARKS};

use crate::raw::{RawConfig, RawController, RawPose};
use vservo_vision::{ExtractorSettings, RenderSettings, Threshold};

use vservo_sim::interpolator::InterpolatorSettings;

use crate::{
    CommandInterface, Config, ConfigError, Controller, Desired, JointServoSettings, PlantSettings, Robot,
    RobotDriver, Scenario, Timing, Vision, VisionSource, pose_from_rpy,
};

/// The largest entry of Q or R: beyond it the Riccati iteration loses its digits.
const MAX_WEIGHT: f64 = 1e12;

/// Builds errors for one file.
struct Checker<'a> {
    file: &'a str,
}

impl Checker<'_> {
    fn invalid(&self, key: &str, value: impl std::fmt::Display, reason: impl Into<String>) -> ConfigError {
        ConfigError::Invalid {
            file: self.file.to_string(),
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    fn positive(&self, key: &str, value: f64) -> Result<f64, ConfigError> {
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(self.invalid(key, value, "must be a positive number"))
        }
    }

    /// A number inside [low, high] (both finite), else an error saying the range.
    fn within(&self, key: &str, value: f64, low: f64, high: f64, unit: &str) -> Result<f64, ConfigError> {
        if value.is_finite() && (low..=high).contains(&value) {
            Ok(value)
        } else {
            Err(self.invalid(key, value, format!("must be from {low} to {high} {unit}")))
        }
    }

    fn finite<const N: usize>(&self, key: &str, values: [f64; N]) -> Result<[f64; N], ConfigError> {
        if values.iter().all(|v| v.is_finite()) {
            Ok(values)
        } else {
            Err(self.invalid(key, format!("{values:?}"), "every value must be a finite number"))
        }
    }

    /// Every value inside [low, high], else an error saying the range.
    fn all_within<const N: usize>(
        &self,
        key: &str,
        values: [f64; N],
        low: f64,
        high: f64,
        unit: &str,
    ) -> Result<[f64; N], ConfigError> {
        if values.iter().all(|v| v.is_finite() && (low..=high).contains(v)) {
            Ok(values)
        } else {
            Err(self.invalid(key, format!("{values:?}"), format!("each must be from {low} to {high} {unit}")))
        }
    }

    /// A pose whose translation stays within ±`reach_m` per axis, its angles within ±360°.
    fn pose(
        &self,
        key: &str,
        raw: &RawPose,
        reach_m: f64,
    ) -> Result<nalgebra::IsometryMatrix3<f64>, ConfigError> {
        let translation =
            self.all_within(&format!("{key}.translation_m"), raw.translation_m, -reach_m, reach_m, "m")?;
        let rpy =
            self.all_within(&format!("{key}.rotation_rpy_deg"), raw.rotation_rpy_deg, -360.0, 360.0, "°")?;
        Ok(pose_from_rpy(Vector3::from(translation), Vector3::from(rpy.map(f64::to_radians))))
    }

    /// A weight written as a number (times I), a list of N (the diagonal) or N lists of N (full).
    fn weight<const N: usize>(
        &self,
        key: &str,
        value: &toml::Value,
    ) -> Result<SMatrix<f64, N, N>, ConfigError> {
        let number = |v: &toml::Value| match v {
            toml::Value::Float(f) => Some(*f),
            toml::Value::Integer(i) => Some(*i as f64),
            _ => None,
        };
        let shape = format!("a number, a list of {N} numbers (the diagonal) or {N} lists of {N} numbers");
        let matrix = if let Some(scalar) = number(value) {
            SMatrix::<f64, N, N>::identity() * scalar
        } else if let toml::Value::Array(items) = value {
            if items.len() != N {
                return Err(self.invalid(
                    key,
                    value,
                    format!("has {} entries; expected {shape}", items.len()),
                ));
            }
            if let Some(diagonal) = items.iter().map(number).collect::<Option<Vec<f64>>>() {
                SMatrix::<f64, N, N>::from_diagonal(&nalgebra::SVector::<f64, N>::from_column_slice(
                    &diagonal,
                ))
            } else {
                let mut m = SMatrix::<f64, N, N>::zeros();
                for (row, item) in items.iter().enumerate() {
                    let entries = match item {
                        toml::Value::Array(entries) if entries.len() == N => entries,
                        _ => {
                            return Err(self.invalid(
                                key,
                                value,
                                format!("row {} is not {N} numbers; expected {shape}", row + 1),
                            ));
                        }
                    };
                    for (column, entry) in entries.iter().enumerate() {
                        m[(row, column)] = number(entry).ok_or_else(|| {
                            self.invalid(
                                key,
                                value,
                                format!("entry ({}, {}) is not a number", row + 1, column + 1),
                            )
                        })?;
                    }
                }
                m
            }
        } else {
            return Err(self.invalid(key, value, format!("expected {shape}")));
        };
        if !matrix.iter().all(|v| v.is_finite() && v.abs() <= MAX_WEIGHT) {
            return Err(self.invalid(key, value, format!("every entry must be within ±{MAX_WEIGHT:e}")));
        }
        Ok(matrix)
    }
}

pub fn validate(raw: RawConfig, file: &str) -> Result<Config, ConfigError> {
    let check = Checker { file };

    // instance
    let name = raw.instance.name.trim();
    if !crate::is_instance_name(name) {
        return Err(check.invalid(
            "instance.name",
            format!("{:?}", raw.instance.name),
            crate::INSTANCE_NAME_RULE,
        ));
    }

    // timing
    let t = &raw.timing;
    let vision_period_s = check.within("timing.vision_period_s", t.vision_period_s, 0.001, 10.0, "s")?;
    let control_period_s = check.within("timing.control_period_s", t.control_period_s, 1e-4, 0.1, "s")?;
    let ticks = vision_period_s / control_period_s;
    if (ticks - ticks.round()).abs() > 1e-6 * ticks || ticks.round() < 1.0 || ticks > 1e6 {
        return Err(check.invalid(
            "timing.vision_period_s",
            vision_period_s,
            format!(
                "must be a whole number of control periods ({control_period_s} s); it is {ticks} of them"
            ),
        ));
    }
    if !(0..=vservo_control::MAX_DELAY_FRAMES as i64).contains(&t.pipeline_delay_frames) {
        return Err(check.invalid(
            "timing.pipeline_delay_frames",
            t.pipeline_delay_frames,
            format!("must be between 0 and {}", vservo_control::MAX_DELAY_FRAMES),
        ));
    }
    let timing = Timing {
        vision_period_s,
        pipeline_delay_frames: t.pipeline_delay_frames as usize,
        control_period_s,
        control_ticks_per_frame: ticks.round() as u32,
    };

    // camera
    let c = &raw.camera;
    let size = |key: &str, v: i64| {
        u32::try_from(v)
            .ok()
            .filter(|&v| (1..=16384).contains(&v))
            .ok_or_else(|| check.invalid(key, v, "must be a whole number of pixels between 1 and 16384"))
    };
    let width_px = size("camera.width_px", c.width_px)?;
    let height_px = size("camera.height_px", c.height_px)?;
    let principal = check.finite("camera.principal_point_px", c.principal_point_px)?;
    if !(0.0..=f64::from(width_px)).contains(&principal[0])
        || !(0.0..=f64::from(height_px)).contains(&principal[1])
    {
        return Err(check.invalid(
            "camera.principal_point_px",
            format!("{principal:?}"),
            format!("must lie in the {width_px}×{height_px} image"),
        ));
    }
    let focal_px = check.within("camera.focal_px", c.focal_px, 1.0, 1e5, "px")?;
    let camera = CameraIntrinsics::new(focal_px, Point2::from(principal), width_px, height_px)
        .map_err(|e| check.invalid("camera", format!("{c:?}"), e.to_string()))?;
    let tool_from_camera = check.pose("camera.tool_from_camera", &c.tool_from_camera, 2.0)?;

    // object
    let o = &raw.object;
    let mark_diameter_m = check.within("object.mark_diameter_m", o.mark_diameter_m, 0.001, 1.0, "m")?;
    if o.marks_in_board_m.len() != MARKS {
        return Err(check.invalid(
            "object.marks_in_board_m",
            format!("{:?}", o.marks_in_board_m),
            format!("must list exactly {MARKS} marks, [x, y] each; it lists {}", o.marks_in_board_m.len()),
        ));
    }
    let mut marks_in_board = [Point3::origin(); MARKS];
    for (i, m) in o.marks_in_board_m.iter().enumerate() {
        let [x, y] = check.all_within("object.marks_in_board_m", *m, -5.0, 5.0, "m")?;
        marks_in_board[i] = Point3::new(x, y, 0.0);
    }
    for i in 0..MARKS {
        for j in (i + 1)..MARKS {
            let gap = (marks_in_board[i] - marks_in_board[j]).norm();
            if gap <= mark_diameter_m {
                return Err(check.invalid(
                    "object.marks_in_board_m",
                    format!("{:?}", o.marks_in_board_m),
                    format!(
                        "marks {} and {} are {gap} m apart, no more than a mark's diameter",
                        i + 1,
                        j + 1
                    ),
                ));
            }
        }
    }
    let [[x0, y0], [x1, y1]] = o.board_extent_m;
    let extent_ok = [x0, y0, x1, y1].iter().all(|v| v.is_finite() && v.abs() <= 5.0) && x0 < x1 && y0 < y1;
    let radius = 0.5 * mark_diameter_m;
    let marks_on_board = marks_in_board
        .iter()
        .all(|m| m.x - radius >= x0 && m.x + radius <= x1 && m.y - radius >= y0 && m.y + radius <= y1);
    if !extent_ok || !marks_on_board {
        return Err(check.invalid(
            "object.board_extent_m",
            format!("{:?}", o.board_extent_m),
            "must be [[x_min, y_min], [x_max, y_max]] within ±5 m with min < max, holding every mark whole",
        ));
    }
    let extent_in_board = [Point2::new(x0, y0), Point2::new(x1, y1)];
    let board = Board { marks_in_board, mark_diameter_m, extent_in_board };

    // desired pose
    let d = &raw.desired;
    let joints_key = "desired.joints_rad";
    if d.joints_rad.len() != 6 || !d.joints_rad.iter().all(|v| v.is_finite()) {
        return Err(check.invalid(
            joints_key,
            format!("{:?}", d.joints_rad),
            "must be 6 finite joint angles (rad)",
        ));
    }
    let joints = JointVector::from_column_slice(&d.joints_rad);
    let arm = validate_arm(&check, &raw.robot.arm)?;
    arm.check_positions(&joints).map_err(|v| {
        check.invalid(joints_key, format!("{:?}", d.joints_rad), format!("{v} (the {}'s range)", arm.name))
    })?;
    // a board beyond 5 m is no visual-servo cell (its marks would be a few pixels)
    let camera_from_board = check.pose("desired.camera_from_board", &d.camera_from_board, 5.0)?;
    let (features, depths) = camera.project_marks_with_depths(&board, &camera_from_board).map_err(|e| {
        check.invalid("desired.camera_from_board", format!("{:?}", d.camera_from_board), e.to_string())
    })?;
    for mark in 0..MARKS {
        let pixel = Point2::new(features[2 * mark], features[2 * mark + 1]);
        if !camera.contains(&pixel) {
            return Err(check.invalid(
                "desired.camera_from_board",
                format!("{:?}", d.camera_from_board),
                format!(
                    "mark {} images at ({:.1}, {:.1}) px, outside the {width_px}×{height_px} image",
                    mark + 1,
                    pixel.x,
                    pixel.y
                ),
            ));
        }
    }
    let desired = Desired { joints, camera_from_board, features, depths };

    // controller
    let k = &raw.controller;
    let law = ControlLaw::from_name(&k.law).ok_or_else(|| {
        check.invalid("controller.law", format!("{:?}", k.law), "must be \"paper\" or \"delay-aware\"")
    })?;
    let units = match k.r_units.as_str() {
        "mm-mrad" => InputUnits::MillimetreMilliradian,
        "si" => InputUnits::Si,
        _ => {
            return Err(check.invalid(
                "controller.r_units",
                format!("{:?}", k.r_units),
                "must be \"mm-mrad\" (mm/s and mrad/s, the paper's) or \"si\" (m/s and rad/s)",
            ));
        }
    };
    let q_matrix = check.weight::<FEATURES>("controller.q", &k.q)?;
    let q = StateWeight::new(q_matrix).map_err(|e| check.invalid("controller.q", &k.q, e.to_string()))?;
    let r_matrix = check.weight::<6>("controller.r", &k.r)?;
    let r =
        InputWeight::new(r_matrix, units).map_err(|e| check.invalid("controller.r", &k.r, e.to_string()))?;
    let options = validate_law_options(&check, k, &camera, &desired.features)?;

    let source = validate_camera_source(&check, &raw.camera)?;
    let vision = validate_vision(&check, &raw.vision, source)?;
    let (plant, interpolator, joint_servo, scenario) = validate_simulation(&check, &raw, &timing)?;
    let robot = validate_robot(&check, &raw.robot, &plant, &timing)?;
    let reacquire = validate_reacquire(&check, &raw.reacquire, &robot, timing.vision_period_s)?;
    if robot.driver == RobotDriver::Simulated && raw.robot.arm.preset != "puma560" {
        return Err(check.invalid(
            "robot.arm.preset",
            format!("{:?}", raw.robot.arm.preset),
            "the simulated driver simulates the PUMA 560's dynamics only; a custom arm needs robot.driver = \"external\"",
        ));
    }
    if vision.source == VisionSource::Simulated && robot.driver == RobotDriver::External {
        return Err(check.invalid(
            "camera.source",
            "\"simulated\"",
            "the simulated camera sees the simulated world, which an external robot driver has none of; set camera.source = \"external\" (a camera driver) or robot.driver = \"simulated\"",
        ));
    }

    Ok(Config {
        origin: file.to_string(),
        instance: name.to_string(),
        timing,
        camera,
        tool_from_camera,
        board,
        desired,
        controller: Controller { law, q, r, options },
        vision,
        plant,
        interpolator,
        joint_servo,
        scenario,
        runtime: validate_runtime(&check, &raw.runtime)?,
        robot,
        arm,
        faults: validate_faults(&check, &raw.faults)?,
        reacquire,
        viewer: validate_viewer(&check, &raw.viewer)?,
    })
}

/// `[reacquire]`: a gain that does not overshoot within a frame, caps within the robot's camera limits. A key
/// left out takes its default, lowered to those limits where they are tighter.
fn validate_reacquire(
    check: &Checker,
    r: &crate::raw::RawReacquire,
    robot: &crate::Robot,
    vision_period_s: f64,
) -> Result<crate::Reacquire, ConfigError> {
    let defaults = crate::Reacquire::default();
    let most_gain_per_s = 1.0 / vision_period_s;
    let key = |key: &str, value: Option<f64>, default: f64, low: f64, high: f64, unit: &str| match value {
        Some(value) => check.within(key, value, low, high, unit),
        None => Ok(default.min(high)),
    };
    Ok(crate::Reacquire {
        gain_per_s: key(
            "reacquire.gain_per_s",
            r.gain_per_s,
            defaults.gain_per_s,
            0.01,
            most_gain_per_s,
            "1/s (1 / vision period)",
        )?,
        max_speed_m_s: key(
            "reacquire.max_speed_m_s",
            r.max_speed_m_s,
            defaults.max_speed_m_s,
            0.001,
            robot.max_camera_speed_m_s,
            "m/s (robot.max_camera_speed_m_s)",
        )?,
        max_rotation_rad_s: key(
            "reacquire.max_rotation_rad_s",
            r.max_rotation_rad_s,
            defaults.max_rotation_rad_s,
            0.001,
            robot.max_camera_rotation_rad_s,
            "rad/s (robot.max_camera_rotation_rad_s)",
        )?,
    })
}

fn validate_viewer(check: &Checker, v: &crate::raw::RawViewer) -> Result<crate::Viewer, ConfigError> {
    if v.address.parse::<std::net::IpAddr>().is_err() {
        return Err(check.invalid(
            "viewer.address",
            format!("{:?}", v.address),
            "must be an IP address (127.0.0.1: this machine only; 0.0.0.0: every interface)",
        ));
    }
    let port = u16::try_from(v.port)
        .ok()
        .filter(|p| *p >= 1)
        .ok_or_else(|| check.invalid("viewer.port", v.port, "must be a TCP port from 1 to 65535"))?;
    Ok(crate::Viewer { enabled: v.enabled, address: v.address.clone(), port })
}

fn validate_faults(check: &Checker, f: &crate::raw::RawFaults) -> Result<crate::Faults, ConfigError> {
    let resume = match f.resume.as_str() {
        "command" => crate::ResumePolicy::Command,
        "automatic" => crate::ResumePolicy::Automatic,
        other => {
            return Err(check.invalid(
                "faults.resume",
                format!("{other:?}"),
                "must be \"command\" (vservoctl resume) or \"automatic\"",
            ));
        }
    };
    Ok(crate::Faults {
        target_lost_s: check.within("faults.target_lost_s", f.target_lost_s, 0.1, 600.0, "s")?,
        saturation_s: check.within("faults.saturation_s", f.saturation_s, 0.01, 60.0, "s")?,
        resume,
        resume_after_s: check.within("faults.resume_after_s", f.resume_after_s, 0.1, 3600.0, "s")?,
    })
}

fn validate_runtime(check: &Checker, r: &crate::raw::RawRuntime) -> Result<crate::Runtime, ConfigError> {
    let node = |name: &str, n: &crate::raw::RawNodeRealtime| -> Result<crate::NodeRealtime, ConfigError> {
        let key = format!("runtime.{name}.fifo_priority");
        let fifo_priority = u8::try_from(n.fifo_priority)
            .ok()
            .filter(|p| *p <= 99)
            .ok_or_else(|| check.invalid(&key, n.fifo_priority, "must be 0 (normal scheduling) or 1–99"))?;
        let key = format!("runtime.{name}.cpus");
        let cpus = n
            .cpus
            .iter()
            .map(|&c| usize::try_from(c).ok().filter(|c| *c < 1024))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| check.invalid(&key, format!("{:?}", n.cpus), "CPU numbers must be 0–1023"))?;
        Ok(crate::NodeRealtime { fifo_priority, cpus })
    };
    let timer_slack_ns =
        u64::try_from(r.timer_slack_ns).ok().filter(|s| (1..=1_000_000_000).contains(s)).ok_or_else(
            || check.invalid("runtime.timer_slack_ns", r.timer_slack_ns, "must be from 1 to 1000000000 ns"),
        )?;
    let hold_after_missed_ticks = u32::try_from(r.hold_after_missed_ticks)
        .ok()
        .filter(|t| (1..=10_000).contains(t))
        .ok_or_else(|| {
            check.invalid(
                "runtime.hold_after_missed_ticks",
                r.hold_after_missed_ticks,
                "must be from 1 to 10000",
            )
        })?;
    // ranges that keep the daemon working: telemetry well inside the 0.5 s health window, waits that
    // std::time can hold and a user would still call a restart or a stop
    let telemetry_period_s =
        check.within("runtime.telemetry_period_s", r.telemetry_period_s, 0.01, 0.2, "s")?;
    let restart_backoff_initial_s =
        check.within("runtime.restart_backoff_initial_s", r.restart_backoff_initial_s, 0.01, 60.0, "s")?;
    let restart_backoff_max_s =
        check.within("runtime.restart_backoff_max_s", r.restart_backoff_max_s, 0.01, 600.0, "s")?;
    if restart_backoff_max_s < restart_backoff_initial_s {
        return Err(check.invalid(
            "runtime.restart_backoff_max_s",
            restart_backoff_max_s,
            "must be at least runtime.restart_backoff_initial_s",
        ));
    }
    let stop_timeout_s = check.within("runtime.stop_timeout_s", r.stop_timeout_s, 0.1, 60.0, "s")?;
    let hang_timeout_s = check.within(
        "runtime.hang_timeout_s",
        r.hang_timeout_s,
        (3.0 * telemetry_period_s).max(0.3),
        60.0,
        "s (at least three telemetry periods)",
    )?;
    Ok(crate::Runtime {
        lock_memory: r.lock_memory,
        timer_slack_ns,
        telemetry_period_s,
        restart_backoff_initial_s,
        restart_backoff_max_s,
        hold_after_missed_ticks,
        stop_timeout_s,
        hang_timeout_s,
        plant: node("plant", &r.plant)?,
        rmrc: node("rmrc", &r.rmrc)?,
        servo: node("servo", &r.servo)?,
        vision: node("vision", &r.vision)?,
    })
}

fn validate_simulation(
    check: &Checker,
    raw: &RawConfig,
    timing: &Timing,
) -> Result<(PlantSettings, InterpolatorSettings, JointServoSettings, Scenario), ConfigError> {
    use vservo_sim::interpolator::TwistHold;
    use vservo_sim::joint_servo::JointServoLaw;
    use vservo_sim::plant::PlantMode;
    use vservo_sim::world::ObjectMotion;

    let p = &raw.plant;
    let mode = PlantMode::from_name(&p.mode).ok_or_else(|| {
        check.invalid("plant.mode", format!("{:?}", p.mode), "must be \"dynamic\" or \"kinematic\"")
    })?;
    if !(1..=100).contains(&p.rk4_substeps) {
        return Err(check.invalid("plant.rk4_substeps", p.rk4_substeps, "must be from 1 to 100"));
    }
    let plant = PlantSettings { mode, rk4_substeps: p.rk4_substeps as u32 };

    let i = &raw.interpolator;
    let hold = match i.twist_hold.as_str() {
        "zero-order" => TwistHold::ZeroOrder,
        "linear" => TwistHold::Linear,
        other => {
            return Err(check.invalid(
                "interpolator.twist_hold",
                format!("{other:?}"),
                "must be \"zero-order\" or \"linear\"",
            ));
        }
    };
    let manipulability_threshold =
        check.within("interpolator.manipulability_threshold", i.manipulability_threshold, 0.0, 10.0, "")?;
    let max_damping = check.within("interpolator.max_damping", i.max_damping, 0.0, 10.0, "")?;
    let stale_frames = check.within(
        "interpolator.stale_twist_frames",
        i.stale_twist_frames,
        0.5,
        100.0,
        "vision periods",
    )?;
    let stop_ramp_s = check.within("interpolator.stop_ramp_s", i.stop_ramp_s, 0.001, 10.0, "s")?;
    let limits = check.all_within(
        "interpolator.acceleration_limit_rad_s2",
        i.acceleration_limit_rad_s2,
        0.01,
        1000.0,
        "rad/s²",
    )?;
    let interpolator = InterpolatorSettings {
        hold,
        vision_period_s: timing.vision_period_s,
        control_period_s: timing.control_period_s,
        manipulability_threshold,
        max_damping,
        stale_after_s: stale_frames * timing.vision_period_s,
        stop_ramp_s,
        acceleration_limit: JointVector::from(limits),
    };

    let j = &raw.joint_servo;
    let law = match j.law.as_str() {
        "computed-torque" => JointServoLaw::ComputedTorque,
        "pd-gravity" => JointServoLaw::PdGravity,
        other => {
            return Err(check.invalid(
                "joint_servo.law",
                format!("{other:?}"),
                "must be \"computed-torque\" or \"pd-gravity\"",
            ));
        }
    };
    // bands a 1 ms joint servo can hold (computed torque: kp 1e6 /s² is a 1000 rad/s loop)
    let kp = check.all_within("joint_servo.kp", j.kp, 1e-3, 1e6, "")?;
    let kv = check.all_within("joint_servo.kv", j.kv, 0.0, 1e4, "")?;
    let joint_servo = JointServoSettings { law, kp: JointVector::from(kp), kv: JointVector::from(kv) };

    let s = &raw.scenario;
    let duration_s = check.within("scenario.duration_s", s.duration_s, 0.001, 86_400.0, "s")?;
    let translation = check.all_within(
        "scenario.initial_camera_translation_m",
        s.initial_camera_translation_m,
        -1.0,
        1.0,
        "m",
    )?;
    let rotation = check.all_within(
        "scenario.initial_camera_rotation_deg",
        s.initial_camera_rotation_deg,
        -180.0,
        180.0,
        "°",
    )?;
    // every key is checked, whichever motion uses it
    let at_s = check.within("scenario.step_at_s", s.step_at_s, 0.0, 86_400.0, "s")?;
    let by = check.all_within("scenario.step_translation_m", s.step_translation_m, -1.0, 1.0, "m")?;
    let radius_m = check.within("scenario.circle_radius_m", s.circle_radius_m, 0.001, 1.0, "m")?;
    let rev_per_min =
        check.within("scenario.circle_rev_per_min", s.circle_rev_per_min, 0.001, 60.0, "rev/min")?;
    let object = match s.object_motion.as_str() {
        "hold" => ObjectMotion::Hold,
        "step" => ObjectMotion::Step { at_s, translation_m: Vector3::from(by) },
        "circle" => ObjectMotion::Circle { radius_m, rev_per_min },
        other => {
            return Err(check.invalid(
                "scenario.object_motion",
                format!("{other:?}"),
                "must be \"hold\", \"step\" or \"circle\"",
            ));
        }
    };
    let mut occlusions = [None; crate::MAX_OCCLUSIONS];
    if raw.scenario.occlusions.len() > crate::MAX_OCCLUSIONS {
        return Err(check.invalid(
            "scenario.occlusions",
            raw.scenario.occlusions.len(),
            format!("at most {} occlusions", crate::MAX_OCCLUSIONS),
        ));
    }
    for (i, o) in raw.scenario.occlusions.iter().enumerate() {
        let key = format!("scenario.occlusions[{i}]");
        if !(1..=MARKS as i64).contains(&o.mark) {
            return Err(check.invalid(&format!("{key}.mark"), o.mark, "must be a mark number, 1 to 4"));
        }
        if !(o.from_s.is_finite() && o.until_s.is_finite() && 0.0 <= o.from_s && o.from_s < o.until_s) {
            return Err(check.invalid(
                &format!("{key}.until_s"),
                o.until_s,
                format!("must come after from_s ({}), both at least 0 s", o.from_s),
            ));
        }
        occlusions[i] =
            Some(crate::Occlusion { mark: (o.mark - 1) as usize, from_s: o.from_s, until_s: o.until_s });
    }
    let scenario = Scenario {
        duration_s,
        initial_camera_translation_m: Vector3::from(translation),
        initial_camera_rotation: Vector3::from(rotation.map(f64::to_radians)),
        object,
        occlusions,
    };
    Ok((plant, interpolator, joint_servo, scenario))
}

fn validate_camera_source(check: &Checker, c: &crate::raw::RawCamera) -> Result<VisionSource, ConfigError> {
    Ok(match c.source.as_str() {
        "simulated" => VisionSource::Simulated,
        "external" => VisionSource::External,
        "directory" => {
            if c.directory.trim().is_empty() {
                return Err(check.invalid(
                    "camera.directory",
                    "\"\"",
                    "must name a directory when camera.source = \"directory\"",
                ));
            }
            VisionSource::Directory(std::path::PathBuf::from(&c.directory))
        }
        other => {
            return Err(check.invalid(
                "camera.source",
                format!("{other:?}"),
                "must be \"simulated\", \"external\" or \"directory\"",
            ));
        }
    })
}

/// `[robot.arm]`: the built-in PUMA 560 (`preset = "puma560"`, the default: kinematics, dynamics, limits
/// of the Robotics Toolbox's model) or a standard-DH table of the user's (`preset = "custom"`: kinematics
/// and limits only, for a velocity- or position-commanded arm).
fn validate_arm(check: &Checker, a: &crate::raw::RawArm) -> Result<vservo_arm::SerialArm, ConfigError> {
    use vservo_arm::{DhParameters, JointLimits, SerialArm};
    let given = [
        ("robot.arm.dh", a.dh.is_some()),
        ("robot.arm.joint_limits_rad", a.joint_limits_rad.is_some()),
        ("robot.arm.velocity_limits_rad_s", a.velocity_limits_rad_s.is_some()),
    ];
    match a.preset.as_str() {
        "puma560" => {
            if let Some((key, _)) = given.iter().find(|(_, is)| *is) {
                return Err(check.invalid(
                    key,
                    "(given)",
                    "the preset \"puma560\" has its own table; set robot.arm.preset = \"custom\" to give one",
                ));
            }
            Ok(puma560::puma560())
        }
        "custom" => {
            let six = |key: &str, n: Option<usize>| match n {
                Some(6) => Ok(()),
                Some(n) => Err(check.invalid(key, format!("{n} rows"), "must list the 6 joints")),
                None => Err(check.invalid(key, "(missing)", "a custom arm must give it")),
            };
            six("robot.arm.dh", a.dh.as_ref().map(Vec::len))?;
            six("robot.arm.joint_limits_rad", a.joint_limits_rad.as_ref().map(Vec::len))?;
            six("robot.arm.velocity_limits_rad_s", a.velocity_limits_rad_s.as_ref().map(Vec::len))?;
            let (Some(dh), Some(positions), Some(velocities)) =
                (&a.dh, &a.joint_limits_rad, &a.velocity_limits_rad_s)
            else {
                return Err(check.invalid(
                    "robot.arm",
                    "(incomplete)",
                    "a custom arm needs dh, joint_limits_rad and velocity_limits_rad_s",
                ));
            };
            let mut rows = [DhParameters::new(0.0, 0.0, 0.0, 0.0); 6];
            let mut limits = [JointLimits {
                position_min: 0.0,
                position_max: 0.0,
                velocity_max: 0.0,
                torque_max: f64::INFINITY,
            }; 6];
            for j in 0..6 {
                let [a_m, alpha, d_m, offset] = check.finite("robot.arm.dh", dh[j])?;
                if a_m.abs() > 10.0
                    || d_m.abs() > 10.0
                    || alpha.abs() > std::f64::consts::TAU
                    || offset.abs() > std::f64::consts::TAU
                {
                    return Err(check.invalid(
                        "robot.arm.dh",
                        format!("{:?}", dh[j]),
                        format!("joint {}: a and d must be within ±10 m, α and the offset within ±2π", j + 1),
                    ));
                }
                rows[j] = DhParameters::new(a_m, alpha, d_m, offset);
                let [low, high] = check.finite("robot.arm.joint_limits_rad", positions[j])?;
                if low >= high || high - low > 4.0 * std::f64::consts::TAU {
                    return Err(check.invalid(
                        "robot.arm.joint_limits_rad",
                        format!("{:?}", positions[j]),
                        format!("joint {}: must be [lowest, highest] with lowest < highest, at most 4 turns apart", j + 1),
                    ));
                }
                let speed = velocities[j];
                if !(speed.is_finite() && speed > 0.0 && speed <= 100.0) {
                    return Err(check.invalid(
                        "robot.arm.velocity_limits_rad_s",
                        speed,
                        format!("joint {}: must be a positive speed up to 100 rad/s", j + 1),
                    ));
                }
                limits[j] = JointLimits {
                    position_min: low,
                    position_max: high,
                    velocity_max: speed,
                    torque_max: f64::INFINITY,
                };
            }
            Ok(SerialArm::kinematic("custom arm", rows, limits))
        }
        other => Err(check.invalid(
            "robot.arm.preset",
            format!("{other:?}"),
            "must be \"puma560\" (built in) or \"custom\" (a DH table in robot.arm.dh)",
        )),
    }
}

/// `[robot]`: which driver, the command it takes, its period and deadline. The simulated driver's command
/// follows from `plant.mode` (dynamic: torque; kinematic: position, the ideal robot).
fn validate_robot(
    check: &Checker,
    r: &crate::raw::RawRobot,
    plant: &PlantSettings,
    timing: &Timing,
) -> Result<Robot, ConfigError> {
    use vservo_sim::plant::PlantMode;
    let driver = match r.driver.as_str() {
        "simulated" => RobotDriver::Simulated,
        "external" => RobotDriver::External,
        other => {
            return Err(check.invalid(
                "robot.driver",
                format!("{other:?}"),
                "must be \"simulated\" or \"external\"",
            ));
        }
    };
    let declared = match r.command.as_deref() {
        None => None,
        Some(name) => Some(CommandInterface::from_name(name).ok_or_else(|| {
            check.invalid(
                "robot.command",
                format!("{name:?}"),
                "must be \"torque\", \"velocity\" or \"position\"",
            )
        })?),
    };
    let command = match driver {
        RobotDriver::Simulated => {
            let simulated = match plant.mode {
                PlantMode::Dynamic => CommandInterface::Torque,
                PlantMode::Kinematic => CommandInterface::Position,
            };
            if let Some(declared) = declared.filter(|d| *d != simulated) {
                return Err(check.invalid(
                    "robot.command",
                    format!("{:?}", declared.name()),
                    format!(
                        "the simulated driver with plant.mode = {:?} takes {:?}; leave robot.command out",
                        plant.mode.name(),
                        simulated.name()
                    ),
                ));
            }
            simulated
        }
        RobotDriver::External => declared.ok_or_else(|| {
            check.invalid(
                "robot.command",
                "(missing)",
                "an external driver must declare the command it takes: \"torque\", \"velocity\" or \"position\"",
            )
        })?,
    };
    let period_s = match (driver, r.period_s) {
        (RobotDriver::Simulated, Some(p)) if p != timing.control_period_s => {
            return Err(check.invalid(
                "robot.period_s",
                p,
                format!(
                    "the simulated driver runs at timing.control_period_s ({} s); leave it out",
                    timing.control_period_s
                ),
            ));
        }
        (_, Some(p)) => {
            let p = check.positive("robot.period_s", p)?;
            if !(1e-4..=0.1).contains(&p) {
                return Err(check.invalid(
                    "robot.period_s",
                    p,
                    "must be from 0.0001 to 0.1 s (10 kHz to 10 Hz)",
                ));
            }
            p
        }
        (_, None) => timing.control_period_s,
    };
    if !(2..=1000).contains(&r.state_timeout_periods) {
        return Err(check.invalid(
            "robot.state_timeout_periods",
            r.state_timeout_periods,
            "must be from 2 to 1000 driver periods",
        ));
    }
    let max_camera_speed_m_s =
        check.within("robot.max_camera_speed_m_s", r.max_camera_speed_m_s, 0.001, 10.0, "m/s")?;
    let max_camera_rotation_rad_s =
        check.within("robot.max_camera_rotation_rad_s", r.max_camera_rotation_rad_s, 0.001, 20.0, "rad/s")?;
    Ok(Robot {
        driver,
        command,
        period_s,
        state_timeout_periods: r.state_timeout_periods as u32,
        max_camera_speed_m_s,
        max_camera_rotation_rad_s,
    })
}

fn validate_vision(
    check: &Checker,
    v: &crate::raw::RawVision,
    source: VisionSource,
) -> Result<Vision, ConfigError> {
    let threshold = match &v.threshold {
        toml::Value::String(s) if s == "otsu" => Threshold::Otsu,
        toml::Value::Integer(level) if (1..=255).contains(level) => Threshold::Fixed(*level as u8),
        other => {
            return Err(check.invalid(
                "vision.threshold",
                other,
                "must be \"otsu\" or a gray level from 1 to 255",
            ));
        }
    };
    let area = |key: &str, value: i64| {
        u32::try_from(value)
            .ok()
            .filter(|&a| a >= 1)
            .ok_or_else(|| check.invalid(key, value, "must be a whole number of pixels, at least 1"))
    };
    let min_area_px = area("vision.min_mark_area_px", v.min_mark_area_px)?;
    let max_area_px = area("vision.max_mark_area_px", v.max_mark_area_px)?;
    if max_area_px <= min_area_px {
        return Err(check.invalid(
            "vision.max_mark_area_px",
            max_area_px,
            format!("must exceed vision.min_mark_area_px ({min_area_px})"),
        ));
    }
    check.within("vision.max_elongation", v.max_elongation, 1.0, 100.0, "")?;
    if !(v.min_ellipse_fill.is_finite() && (0.0..=1.0).contains(&v.min_ellipse_fill)) {
        return Err(check.invalid("vision.min_ellipse_fill", v.min_ellipse_fill, "must be between 0 and 1"));
    }
    let gate_px = check.within("vision.gate_px", v.gate_px, 0.1, 16384.0, "px")?;
    let r = &v.render;
    let gray = |key: &str, value: f64| {
        if value.is_finite() && (0.0..=255.0).contains(&value) {
            Ok(value)
        } else {
            Err(check.invalid(key, value, "must be a gray level from 0 to 255"))
        }
    };
    let background_gray = gray("vision.render.background_gray", r.background_gray)?;
    let board_gray = gray("vision.render.board_gray", r.board_gray)?;
    let mark_gray = gray("vision.render.mark_gray", r.mark_gray)?;
    if board_gray - mark_gray < 20.0 {
        return Err(check.invalid(
            "vision.render.mark_gray",
            mark_gray,
            format!("must be at least 20 levels darker than the board ({board_gray})"),
        ));
    }
    if !(r.noise_sigma_gray.is_finite() && (0.0..=50.0).contains(&r.noise_sigma_gray)) {
        return Err(check.invalid(
            "vision.render.noise_sigma_gray",
            r.noise_sigma_gray,
            "must be between 0 and 50 gray levels",
        ));
    }
    let gradient = check.finite("vision.render.lighting_gradient", r.lighting_gradient)?;
    if gradient.iter().any(|g| g.abs() >= 1.0) {
        return Err(check.invalid(
            "vision.render.lighting_gradient",
            format!("{gradient:?}"),
            "each must be between −1 and 1 (a fraction of the brightness)",
        ));
    }
    if !(1..=16).contains(&r.supersampling) {
        return Err(check.invalid(
            "vision.render.supersampling",
            r.supersampling,
            "must be from 1 to 16 samples per axis",
        ));
    }
    Ok(Vision {
        source,
        extractor: ExtractorSettings {
            threshold,
            min_area_px,
            max_area_px,
            max_elongation: v.max_elongation,
            min_ellipse_fill: v.min_ellipse_fill,
            gate_px,
        },
        render: RenderSettings {
            background_gray,
            board_gray,
            mark_gray,
            noise_sigma_gray: r.noise_sigma_gray,
            // the seed's bits as written, negative numbers included
            noise_seed: r.noise_seed as u64,
            lighting_gradient: gradient,
            supersampling: r.supersampling as u32,
        },
    })
}

/// `controller.interaction`, `controller.border_margin_px` and `controller.feedforward`: optional, the paper's
/// law as published when left out. A margin must leave ξ_d inside it.
fn validate_law_options(
    check: &Checker,
    k: &RawController,
    camera: &CameraIntrinsics,
    desired_features: &FeatureVector,
) -> Result<LawOptions, ConfigError> {
    let interaction = match &k.interaction {
        None => Interaction::Desired,
        Some(name) => Interaction::from_name(name).ok_or_else(|| {
            check.invalid(
                "controller.interaction",
                format!("{name:?}"),
                "must be \"desired\" (the paper's fixed gain), \"mean\" or \"current\"",
            )
        })?,
    };
    let border_margin_px = k.border_margin_px.unwrap_or(0.0);
    let half = f64::from(camera.width_px().min(camera.height_px())) / 2.0;
    if !(border_margin_px.is_finite() && (0.0..half).contains(&border_margin_px)) {
        return Err(check.invalid(
            "controller.border_margin_px",
            border_margin_px,
            format!("must be at least 0 and less than half the image ({half} px)"),
        ));
    }
    let (width, height) = (f64::from(camera.width_px()), f64::from(camera.height_px()));
    for mark in 0..MARKS {
        let (x, y) = (desired_features[2 * mark], desired_features[2 * mark + 1]);
        let inside = |v: f64, limit: f64| v >= border_margin_px && v <= limit - border_margin_px;
        if !(inside(x, width) && inside(y, height)) {
            return Err(check.invalid(
                "controller.border_margin_px",
                border_margin_px,
                format!(
                    "desired mark {} images at ({x:.1}, {y:.1}) px, inside the margin: the barrier would keep the servo from its goal",
                    mark + 1
                ),
            ));
        }
    }
    Ok(LawOptions { interaction, border_margin_px, feedforward: k.feedforward.unwrap_or(false) })
}
