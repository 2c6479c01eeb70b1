//! `[plant]`, `[interpolator]` and `[joint_servo]`: the simulated arm, the resolved-motion-rate interpolator
//! and the joint servo.

use vservo_arm::{SerialArm, six_joints};
use vservo_settings::simulation::InterpolatorSettings;
use vservo_settings::simulation::{MIN_SPEED_SCALE, NullSpaceTask};

use super::checker::Checker;
use vservo_settings::simulation::{KinematicFollows, KinematicResponse};

use crate::raw::{
    RawArm, RawInterpolator, RawJointServo, RawKinematicFollows, RawNullSpace, RawPlant, RawRobotDriver,
};
use crate::{ConfigError, JointServoSettings, PlantSettings, Timing};

/// The plant's mode and its integration steps.
pub fn plant(check: &Checker, p: &RawPlant) -> Result<PlantSettings, ConfigError> {
    let rk4_substeps =
        check.whole("plant.rk4_substeps", p.rk4_substeps, 1u32, 100, "must be from 1 to 100")?;
    let lag_s = check.within("plant.kinematic_lag_s", p.kinematic_lag_s, 0.0, 1.0, "s")?;
    let follows = match p.kinematic_follows {
        RawKinematicFollows::Position => KinematicFollows::Position,
        RawKinematicFollows::Velocity => KinematicFollows::Velocity,
    };
    Ok(PlantSettings { mode: p.mode.into(), rk4_substeps, kinematic: KinematicResponse { follows, lag_s } })
}

/// The interpolator, stepping at the control period between vision periods, for `arm` (written as `a`) on
/// `driver`: within the arm's motion limits ([`super::motion`]).
pub fn interpolator(
    check: &Checker,
    i: &RawInterpolator,
    timing: &Timing,
    (a, arm): (&RawArm, &SerialArm),
    (driver, speed_scale): (RawRobotDriver, Option<f64>),
) -> Result<InterpolatorSettings, ConfigError> {
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
    let limits = super::motion::limits_in_force(check, a, i, driver, arm)?;
    Ok(InterpolatorSettings {
        hold: i.twist_hold.into(),
        vision_period_s: timing.vision_period_s,
        control_period_s: timing.control_period_s,
        manipulability_threshold,
        max_damping,
        stale_after_s: stale_frames * timing.vision_period_s,
        stop_ramp_s,
        acceleration_limit: limits.acceleration,
        jerk_limit: limits.jerk,
        tool_speed_limit_m_s: limits.tool_speed_m_s,
        tool_rotation_limit_rad_s: limits.tool_rotation_rad_s,
        null_space: null_space(check, &i.null_space, arm)?,
        speed_scale: speed_scale
            .map(|scale| {
                check.within(
                    "robot.speed_scale",
                    scale,
                    MIN_SPEED_SCALE,
                    1.0,
                    "(a share of the arm's limits)",
                )
            })
            .transpose()?
            .unwrap_or(if driver == RawRobotDriver::Simulated {
                1.0
            } else {
                super::motion::EXTERNAL_SPEED_SCALE
            }),
    })
}

/// The joint servo's law and gains, in bands a 1 ms joint servo can hold (computed torque: kp 1e6 /s² is a
/// 1000 rad/s loop).
pub fn joint_servo(check: &Checker, j: &RawJointServo) -> Result<JointServoSettings, ConfigError> {
    let kp = check.all_within("joint_servo.kp", j.kp, 1e-3, 1e6, "")?;
    let kv = check.all_within("joint_servo.kv", j.kv, 0.0, 1e4, "")?;
    Ok(JointServoSettings { law: j.law.into(), kp: six_joints(kp), kv: six_joints(kv) })
}

/// `[interpolator.null_space]`: the push away from the limits, and the posture if one is given (one angle
/// per joint, inside the arm's range).
fn null_space(check: &Checker, n: &RawNullSpace, arm: &SerialArm) -> Result<NullSpaceTask, ConfigError> {
    let key = "interpolator.null_space";
    let limit_zone_rad = check.within(&format!("{key}.limit_zone_rad"), n.limit_zone_rad, 0.0, 1.0, "rad")?;
    let limit_gain = check.within(&format!("{key}.limit_gain"), n.limit_gain, 0.0, 100.0, "1/s")?;
    let posture_gain = check.within(&format!("{key}.posture_gain"), n.posture_gain, 0.0, 100.0, "1/s")?;
    let posture = match &n.posture_rad {
        None => None,
        Some(values) => {
            let posture_key = format!("{key}.posture_rad");
            let posture = check.per_joint(&posture_key, values, arm, (-10.0, 10.0), "rad")?;
            arm.check_positions(&posture).map_err(|v| {
                check.invalid(&posture_key, format!("{values:?}"), format!("{v} (the {}'s range)", arm.name))
            })?;
            Some(posture)
        }
    };
    Ok(NullSpaceTask { limit_zone_rad, limit_gain, posture, posture_gain })
}
