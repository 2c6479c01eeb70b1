//! `[robot.arm]`: the built-in PUMA 560 (`preset = "puma560"`, the default: kinematics, dynamics, limits of
//! the Robotics Toolbox's model), a standard-DH table of the user's (`preset = "custom"`) or the chain of a
//! URDF file (`preset = "urdf"`, between `base_link` and `tip_link`, limits from the file unless given here).
//! The last two are kinematics and limits only, for a velocity- or position-commanded arm.

use std::f64::consts::TAU;

use vservo_arm::urdf::UrdfArm;
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
        RawArmPreset::Custom => {
            no_urdf_keys(check, a, "custom")?;
            custom(check, a)
        }
        RawArmPreset::Urdf => urdf(check, a),
    }
}

/// The PUMA 560 has its own table: one given is refused.
fn no_table_for_the_preset(check: &Checker, a: &RawArm) -> Result<(), ConfigError> {
    no_urdf_keys(check, a, "puma560")?;
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

/// The URDF's keys belong to `preset = "urdf"`.
fn no_urdf_keys(check: &Checker, a: &RawArm, preset: &str) -> Result<(), ConfigError> {
    let given = [
        ("robot.arm.urdf", a.urdf.is_some()),
        ("robot.arm.base_link", a.base_link.is_some()),
        ("robot.arm.tip_link", a.tip_link.is_some()),
    ];
    match given.iter().find(|(_, is)| *is) {
        Some((key, _)) => Err(check.invalid(
            key,
            "(given)",
            format!("belongs to an arm from a URDF: set robot.arm.preset = \"urdf\" (it is {preset:?})"),
        )),
        None => Ok(()),
    }
}

/// An arm from a URDF: the chain between the base and tool links, the file's limits unless given here.
fn urdf(check: &Checker, a: &RawArm) -> Result<SerialArm, ConfigError> {
    if a.dh.is_some() {
        return Err(check.invalid(
            "robot.arm.dh",
            "(given)",
            "an arm from a URDF takes its geometry from the file",
        ));
    }
    let key = "robot.arm.urdf";
    let file = a.urdf.as_deref().unwrap_or("");
    if file.trim().is_empty() {
        return Err(check.invalid(key, format!("{file:?}"), "must name the arm's URDF file"));
    }
    let text = crate::layers::read_bounded(std::path::Path::new(file))
        .map_err(|reason| check.invalid(key, format!("{file:?}"), format!("cannot read: {reason}")))?;
    let arm = vservo_arm::urdf::parse(&text, file, a.base_link.as_deref(), a.tip_link.as_deref())
        .map_err(|e| urdf_refused(check, a, file, e))?;
    let far = arm.chain.joints.iter().find(|j| j.parent_from_joint.translation.vector.amax() > 10.0);
    if let Some(joint) = far.map(|j| j.name.as_str()).or_else(|| {
        (arm.chain.last_from_tip.translation.vector.amax() > 10.0).then_some(arm.chain.tip_link.as_str())
    }) {
        return Err(check.invalid(
            key,
            format!("{file:?}"),
            format!("{joint:?}: an origin more than 10 m away"),
        ));
    }
    let limits = urdf_limits(check, a, &arm)?;
    SerialArm::from_chain("URDF arm", arm.chain, &limits)
        .ok_or_else(|| check.invalid(key, format!("{file:?}"), "not a chain of six or seven joints"))
}

/// A URDF refused, said of the key at fault: a link the file does not have is the fault of the key that named it
/// (`robot.arm.tip_link` or `base_link`, in the file that wrote it), with the file's link nearest it.
fn urdf_refused(check: &Checker, a: &RawArm, file: &str, error: vservo_arm::urdf::UrdfError) -> ConfigError {
    if let vservo_arm::urdf::UrdfError::NoSuchLink { link, known } = &error {
        let named_by = [("robot.arm.tip_link", &a.tip_link), ("robot.arm.base_link", &a.base_link)]
            .into_iter()
            .find(|(_, written)| written.as_deref() == Some(link.as_str()));
        if let Some((key, _)) = named_by {
            let nearest = crate::layers::did_you_mean(link, known.split(", "))
                .map(|nearest| format!("; did you mean {nearest:?}?"))
                .unwrap_or_default();
            return check.invalid(
                key,
                format!("{link:?}"),
                format!("{file} has no such link{nearest} (its links: {known})"),
            );
        }
    }
    check.invalid("robot.arm.urdf", format!("{file:?}"), error.to_string())
}

/// Each joint's limits: the configuration's where given (all joints), else the file's; a joint left with
/// none is refused by name.
fn urdf_limits(check: &Checker, a: &RawArm, arm: &UrdfArm) -> Result<Vec<JointLimits>, ConfigError> {
    let count = arm.chain.joint_count();
    let rows = |key: &str, n: Option<usize>| match n {
        Some(n) if n != count => {
            Err(check.invalid(key, format!("{n} rows"), format!("must list the {count} joints")))
        }
        _ => Ok(()),
    };
    rows("robot.arm.joint_limits_rad", a.joint_limits_rad.as_ref().map(Vec::len))?;
    rows("robot.arm.velocity_limits_rad_s", a.velocity_limits_rad_s.as_ref().map(Vec::len))?;
    let mut limits = vec![
        JointLimits {
            position_min: 0.0,
            position_max: 0.0,
            velocity_max: 0.0,
            torque_max: f64::INFINITY
        };
        count
    ];
    for (j, joint) in arm.chain.joints.iter().enumerate() {
        let missing = |key: &str, what: &str| {
            check.invalid(
                key,
                "(missing)",
                format!(
                    "joint {:?} has no {what} in the URDF: give robot.arm.{}",
                    joint.name,
                    key.trim_start_matches("robot.arm.")
                ),
            )
        };
        let range = match (&a.joint_limits_rad, arm.position_limits[j]) {
            (Some(given), _) => given[j],
            (None, Some(file)) => file,
            (None, None) => {
                return Err(missing(
                    "robot.arm.joint_limits_rad",
                    "position limits (continuous, or no <limit>)",
                ));
            }
        };
        let speed = match (&a.velocity_limits_rad_s, arm.velocity_limits[j]) {
            (Some(given), _) => given[j],
            (None, Some(file)) => file,
            (None, None) => return Err(missing("robot.arm.velocity_limits_rad_s", "speed limit")),
        };
        limits[j] = joint_limits(check, j, range, speed)?;
    }
    Ok(limits)
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
