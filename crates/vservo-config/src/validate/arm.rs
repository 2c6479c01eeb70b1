//! `[robot.arm]`: the built-in PUMA 560 (`preset = "puma560"`, the default: kinematics, dynamics, limits of
//! the Robotics Toolbox's model) or a standard-DH table of the user's (`preset = "custom"`: kinematics and
//! limits only, for a velocity- or position-commanded arm).

use std::f64::consts::TAU;

use vservo_arm::{DhParameters, JointLimits, SerialArm, puma560};

use super::checker::Checker;
use crate::ConfigError;
use crate::raw::{RawArm, RawArmPreset};

/// The arm's model.
pub fn arm(check: &Checker, a: &RawArm) -> Result<SerialArm, ConfigError> {
    match a.preset {
        RawArmPreset::Puma560 => {
            no_table_for_the_preset(check, a)?;
            Ok(puma560::puma560())
        }
        RawArmPreset::Custom => custom(check, a),
    }
}

/// The PUMA 560 has its own table: one given is refused.
fn no_table_for_the_preset(check: &Checker, a: &RawArm) -> Result<(), ConfigError> {
    let given = [
        ("robot.arm.dh", a.dh.is_some()),
        ("robot.arm.joint_limits_rad", a.joint_limits_rad.is_some()),
        ("robot.arm.velocity_limits_rad_s", a.velocity_limits_rad_s.is_some()),
    ];
    match given.iter().find(|(_, is)| *is) {
        Some((key, _)) => Err(check.invalid(
            key,
            "(given)",
            "the preset \"puma560\" has its own table; set robot.arm.preset = \"custom\" to give one",
        )),
        None => Ok(()),
    }
}

/// A custom arm: six rows of DH parameters, position limits and speed limits.
fn custom(check: &Checker, a: &RawArm) -> Result<SerialArm, ConfigError> {
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
    let mut limits =
        [JointLimits { position_min: 0.0, position_max: 0.0, velocity_max: 0.0, torque_max: f64::INFINITY };
            6];
    for joint in 0..6 {
        rows[joint] = dh_row(check, joint, dh[joint])?;
        limits[joint] = joint_limits(check, joint, positions[joint], velocities[joint])?;
    }
    Ok(SerialArm::kinematic("custom arm", rows, limits))
}

/// One row of `robot.arm.dh`: a and d within ±10 m, α and the offset within ±2π.
fn dh_row(check: &Checker, joint: usize, row: [f64; 4]) -> Result<DhParameters, ConfigError> {
    let [a_m, alpha, d_m, offset] = check.finite("robot.arm.dh", row)?;
    if a_m.abs() > 10.0 || d_m.abs() > 10.0 || alpha.abs() > TAU || offset.abs() > TAU {
        return Err(check.invalid(
            "robot.arm.dh",
            format!("{row:?}"),
            format!("joint {}: a and d must be within ±10 m, α and the offset within ±2π", joint + 1),
        ));
    }
    Ok(DhParameters::new(a_m, alpha, d_m, offset))
}

/// One joint's range (lowest < highest, at most 4 turns apart) and speed limit (up to 100 rad/s).
fn joint_limits(
    check: &Checker,
    joint: usize,
    range: [f64; 2],
    speed: f64,
) -> Result<JointLimits, ConfigError> {
    let [low, high] = check.finite("robot.arm.joint_limits_rad", range)?;
    if low >= high || high - low > 4.0 * TAU {
        return Err(check.invalid(
            "robot.arm.joint_limits_rad",
            format!("{range:?}"),
            format!(
                "joint {}: must be [lowest, highest] with lowest < highest, at most 4 turns apart",
                joint + 1
            ),
        ));
    }
    if !(speed.is_finite() && speed > 0.0 && speed <= 100.0) {
        return Err(check.invalid(
            "robot.arm.velocity_limits_rad_s",
            speed,
            format!("joint {}: must be a positive speed up to 100 rad/s", joint + 1),
        ));
    }
    Ok(JointLimits { position_min: low, position_max: high, velocity_max: speed, torque_max: f64::INFINITY })
}
