//! `[franka]` and `robot.driver = "franka"`: a Franka arm over its own network protocol (the FCI), driven by
//! `vservo-franka`, which vservod starts.

use std::net::{IpAddr, SocketAddr};

use vservo_arm::JointVector;

use super::checker::Checker;
use crate::raw::{RawFranka, RawRobot, RawRobotDriver};
use crate::{ConfigError, Franka};

/// The Franka driver's settings with `robot.driver = "franka"`: a section without it is refused, as is an arm
/// that is not a seven-joint one or that has no jerk limits while the driver is to keep them
/// (`limit_rate`). `arm` is the interpolator's jerk limits and the arm's joint count.
pub fn franka(
    check: &Checker,
    r: &RawRobot,
    f: Option<&RawFranka>,
    &(jerk, joints): &(Option<JointVector>, usize),
) -> Result<Option<Franka>, ConfigError> {
    if r.driver != RawRobotDriver::Franka {
        return match f {
            Some(_) => Err(check.invalid(
                "franka",
                "(given)",
                "the Franka driver's section needs robot.driver = \"franka\"",
            )),
            None => Ok(None),
        };
    }
    let defaults = RawFranka::default();
    let f = f.unwrap_or(&defaults);
    let ip: IpAddr = f.address.trim().parse().map_err(|_| {
        check.invalid(
            "franka.address",
            format!("{:?}", f.address),
            "must be the robot's IP address (its FCI)",
        )
    })?;
    let port = check.whole("franka.port", f.port, 1u16, u16::MAX, "must be a TCP port, from 1 to 65535")?;
    if joints != 7 {
        return Err(check.invalid(
            "robot.arm",
            format!("{joints} joints"),
            "a Franka arm has seven joints (config/arms/fr3.toml is one)",
        ));
    }
    if f.limit_rate && jerk.is_none() {
        return Err(check.invalid(
            "robot.arm.jerk_limits_rad_s3",
            "(missing)",
            "the Franka aborts a motion above its jerk limits and franka.limit_rate keeps them: give the arm's \
             (config/arms/fr3.toml)",
        ));
    }
    Ok(Some(Franka {
        address: SocketAddr::new(ip, port),
        simulator: f.simulator,
        limit_rate: f.limit_rate,
        answer_within_s: check.within("franka.answer_within_s", f.answer_within_s, 0.0, 0.0009, "s")?,
        hold_after_s: check.within("franka.hold_after_s", f.hold_after_s, 0.002, 1.0, "s")?,
    }))
}
