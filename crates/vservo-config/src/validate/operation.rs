//! The small optional sections of the running cell: `[faults]`, `[reacquire]` and `[viewer]`.

use super::checker::Checker;
use crate::raw::{RawFaults, RawReacquire, RawViewer};
use crate::{ConfigError, Faults, Reacquire, Robot, Viewer};

/// The most viewers `[viewer] max_clients` may allow (each one costs the viewer a thread and a queue).
const MAX_VIEWERS: u32 = 64;

/// When a fault stops the cell, and how it resumes.
pub fn faults(check: &Checker, f: &RawFaults) -> Result<Faults, ConfigError> {
    Ok(Faults {
        target_lost: check.duration("faults.target_lost_s", f.target_lost_s, 0.1, 600.0)?,
        saturation: check.duration("faults.saturation_s", f.saturation_s, 0.01, 60.0)?,
        resume: f.resume,
        resume_after: check.duration("faults.resume_after_s", f.resume_after_s, 0.1, 3600.0)?,
        camera_timeout_periods: check.whole(
            "faults.camera_timeout_periods",
            f.camera_timeout_periods,
            2u32,
            1000,
            "must be from 2 to 1000 vision periods",
        )?,
    })
}

/// A gain that does not overshoot within a frame, caps within the robot's camera limits. A key left out
/// takes its default, lowered to those limits where they are tighter.
pub fn reacquire(
    check: &Checker,
    r: &RawReacquire,
    robot: &Robot,
    vision_period_s: f64,
) -> Result<Reacquire, ConfigError> {
    let defaults = Reacquire::default();
    let key = |key: &str, value: Option<f64>, default: f64, low: f64, high: f64, unit: &str| match value {
        Some(value) => check.within(key, value, low, high, unit),
        None => Ok(default.min(high)),
    };
    Ok(Reacquire {
        gain_per_s: key(
            "reacquire.gain_per_s",
            r.gain_per_s,
            defaults.gain_per_s,
            0.01,
            1.0 / vision_period_s,
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

/// The live view's address (an IP address), port and number of viewers.
pub fn viewer(check: &Checker, v: &RawViewer) -> Result<Viewer, ConfigError> {
    if v.address.parse::<std::net::IpAddr>().is_err() {
        return Err(check.invalid(
            "viewer.address",
            format!("{:?}", v.address),
            "must be an IP address (127.0.0.1: this machine only; 0.0.0.0: every interface)",
        ));
    }
    let port = check.whole("viewer.port", v.port, 1u16, u16::MAX, "must be a TCP port from 1 to 65535")?;
    let max_clients = check.whole(
        "viewer.max_clients",
        v.max_clients,
        1u32,
        MAX_VIEWERS,
        &format!("must be from 1 to {MAX_VIEWERS} viewers at once"),
    )?;
    Ok(Viewer { enabled: v.enabled, address: v.address.clone(), port, max_clients })
}
