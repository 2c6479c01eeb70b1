//! The arm's motion limits (`[robot.arm]` acceleration, jerk and tool speeds, where the vendor publishes
//! them) and the interpolator's limits in force (`[interpolator]` may narrow them, never widen them).
//!
//! Limits belong to the arm. The PUMA 560 preset has its own accelerations (what its torque limits give over
//! its inertia at the nominal pose) and no jerk limit (none is published for it). An arm of the user's
//! (`preset = "custom"` or `"urdf"`) must state its accelerations; it never inherits the PUMA's. Without
//! jerk limits, the reference's acceleration may step to its limit within a tick (the arm's controller must
//! accept that); with them, the reference is jerk-limited on every path.

use vservo_arm::{JointVector, SerialArm};

use super::checker::Checker;
use crate::ConfigError;
use crate::raw::{RawArm, RawArmPreset, RawInterpolator, RawRobotDriver};

/// The tool's speed (m/s) an arm on an external driver is held to when the configuration caps none: slow
/// enough to stop by hand on a first motion.
pub const EXTERNAL_TOOL_SPEED_M_S: f64 = 0.25;

/// The tool's angular speed (rad/s) an arm on an external driver is held to when the configuration caps none.
pub const EXTERNAL_TOOL_ROTATION_RAD_S: f64 = 0.75;

/// The dynamics override an arm on any driver but the simulated one starts at when the configuration gives
/// none (`robot.speed_scale`): a real arm's first motion at a quarter of its limits, as a pendant's slider
/// would start it.
pub const EXTERNAL_SPEED_SCALE: f64 = 0.25;

/// The limits the interpolator keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionLimitsInForce {
    /// Each joint's acceleration (rad/s²).
    pub acceleration: JointVector,
    /// Each joint's jerk (rad/s³), where the arm declares it.
    pub jerk: Option<JointVector>,
    /// The tool's speed (m/s; infinite: none).
    pub tool_speed_m_s: f64,
    /// The tool's angular speed (rad/s; infinite: none).
    pub tool_rotation_rad_s: f64,
}

/// The arm's limits, narrowed by the interpolator's where it gives its own; an external driver's tool speeds
/// capped at [`EXTERNAL_TOOL_SPEED_M_S`] and [`EXTERNAL_TOOL_ROTATION_RAD_S`] unless the configuration caps
/// them itself.
pub fn limits_in_force(
    check: &Checker,
    a: &RawArm,
    i: &RawInterpolator,
    driver: RawRobotDriver,
    arm: &SerialArm,
) -> Result<MotionLimitsInForce, ConfigError> {
    let arm_acceleration = arm_acceleration(check, a, arm)?;
    let acceleration = match &i.acceleration_limit_rad_s2 {
        None => arm_acceleration,
        Some(values) => {
            let key = "interpolator.acceleration_limit_rad_s2";
            let narrowed = check.per_joint(key, values, arm, (0.01, 1000.0), "rad/s²")?;
            if let Some(j) = (0..arm.joint_count()).find(|&j| narrowed[j] > arm_acceleration[j]) {
                return Err(check.invalid(
                    key,
                    format!("{values:?}"),
                    format!(
                        "joint {} asks for {} rad/s², above the arm's {} rad/s² (robot.arm.acceleration_limits_rad_s2)",
                        j + 1,
                        narrowed[j],
                        arm_acceleration[j]
                    ),
                ));
            }
            narrowed
        }
    };
    let jerk = a
        .jerk_limits_rad_s3
        .as_ref()
        .map(|values| check.per_joint("robot.arm.jerk_limits_rad_s3", values, arm, (1.0, 1e6), "rad/s³"))
        .transpose()?;
    let external = driver != RawRobotDriver::Simulated;
    let (speed_default, rotation_default) = if external {
        (EXTERNAL_TOOL_SPEED_M_S, EXTERNAL_TOOL_ROTATION_RAD_S)
    } else {
        (f64::INFINITY, f64::INFINITY)
    };
    let tool_speed_m_s = tool_limit(
        check,
        ("robot.arm.tool_speed_limit_m_s", a.tool_speed_limit_m_s),
        ("interpolator.tool_speed_limit_m_s", i.tool_speed_limit_m_s),
        speed_default,
        "m/s",
    )?;
    let tool_rotation_rad_s = tool_limit(
        check,
        ("robot.arm.tool_rotation_limit_rad_s", a.tool_rotation_limit_rad_s),
        ("interpolator.tool_rotation_limit_rad_s", i.tool_rotation_limit_rad_s),
        rotation_default,
        "rad/s",
    )?;
    Ok(MotionLimitsInForce { acceleration, jerk, tool_speed_m_s, tool_rotation_rad_s })
}

/// The arm's own accelerations: given, or the PUMA 560's for its preset; an arm of the user's without them
/// is refused, naming the keys to write.
fn arm_acceleration(check: &Checker, a: &RawArm, arm: &SerialArm) -> Result<JointVector, ConfigError> {
    let key = "robot.arm.acceleration_limits_rad_s2";
    match (&a.acceleration_limits_rad_s2, a.preset) {
        (Some(values), _) => check.per_joint(key, values, arm, (0.01, 1000.0), "rad/s²"),
        (None, RawArmPreset::Puma560) => Ok(vservo_arm::puma560::ACCELERATION_LIMITS_RAD_S2),
        (None, _) => Err(check.invalid(
            key,
            "(missing)",
            format!(
                "the {} has no acceleration limits of its own (it does not take the PUMA 560's): write the \
                 vendor's, one per joint, in robot.arm.acceleration_limits_rad_s2, and its jerk limits in \
                 robot.arm.jerk_limits_rad_s3 (config/arms/fr3.toml shows both, with their sources)",
                arm.name
            ),
        )),
    }
}

/// A tool speed limit: the lower of the arm's and the interpolator's, each checked; `default` where neither
/// is given.
fn tool_limit(
    check: &Checker,
    (arm_key, arm_value): (&str, Option<f64>),
    (cap_key, cap_value): (&str, Option<f64>),
    default: f64,
    unit: &str,
) -> Result<f64, ConfigError> {
    let arm = arm_value.map(|v| check.within(arm_key, v, 0.001, 100.0, unit)).transpose()?;
    let cap = cap_value.map(|v| check.within(cap_key, v, 0.001, 100.0, unit)).transpose()?;
    Ok(match (arm, cap) {
        (None, None) => default,
        (Some(arm), None) => arm.min(default),
        (None, Some(cap)) => cap,
        (Some(arm), Some(cap)) => arm.min(cap),
    })
}
