//! `[plant]`, `[interpolator]` and `[joint_servo]`: the simulated arm, the resolved-motion-rate interpolator
//! and the joint servo.

use vservo_arm::JointVector;
use vservo_sim::interpolator::InterpolatorSettings;

use super::checker::Checker;
use vservo_sim::plant::{KinematicFollows, KinematicResponse};

use crate::raw::{RawInterpolator, RawJointServo, RawKinematicFollows, RawPlant};
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

/// The interpolator, stepping at the control period between vision periods.
pub fn interpolator(
    check: &Checker,
    i: &RawInterpolator,
    timing: &Timing,
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
    let limits = check.all_within(
        "interpolator.acceleration_limit_rad_s2",
        i.acceleration_limit_rad_s2,
        0.01,
        1000.0,
        "rad/s²",
    )?;
    Ok(InterpolatorSettings {
        hold: i.twist_hold.into(),
        vision_period_s: timing.vision_period_s,
        control_period_s: timing.control_period_s,
        manipulability_threshold,
        max_damping,
        stale_after_s: stale_frames * timing.vision_period_s,
        stop_ramp_s,
        acceleration_limit: JointVector::from(limits),
    })
}

/// The joint servo's law and gains, in bands a 1 ms joint servo can hold (computed torque: kp 1e6 /s² is a
/// 1000 rad/s loop).
pub fn joint_servo(check: &Checker, j: &RawJointServo) -> Result<JointServoSettings, ConfigError> {
    let kp = check.all_within("joint_servo.kp", j.kp, 1e-3, 1e6, "")?;
    let kv = check.all_within("joint_servo.kv", j.kv, 0.0, 1e4, "")?;
    Ok(JointServoSettings { law: j.law.into(), kp: JointVector::from(kp), kv: JointVector::from(kv) })
}
