//! A client's joint move (`move_joints`, what `vservoctl calibrate` asks between its views), checked before the
//! cell is told: every goal of the arm's joints finite and inside its limits with
//! [`vservo_arm::GOAL_MARGIN_RAD`] to spare, no goal for a joint the arm does not have, and the share of the
//! speed limits in [[`MIN_SPEED_FRACTION`], 1] (`vservo_sim::joint_move`, the rule the rmrc applies too).

use vservo_arm::{GOAL_MARGIN_RAD, SerialArm};
use vservo_protocol::{CommandMsg, MAX_JOINTS, RobotState};
use vservo_sim::joint_move::{MIN_SPEED_FRACTION, speed_fraction_ok};

/// A joint move the cell carries out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMove {
    /// The goal (rad; the slots past the arm's joints zero).
    pub goal_rad: [f64; MAX_JOINTS],
    /// The share of each joint's speed limit it may move at.
    pub speed_fraction: f64,
    /// The arm's joints.
    pub joints: usize,
}

impl std::fmt::Display for JointMove {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let goal: Vec<_> = self.goal_rad[..self.joints].iter().map(|q| format!("{q:.4}")).collect();
        write!(
            f,
            "moving the joints to [{}] rad at up to {:.0} % of their speed limits (a torque-driven arm slower \
             where its drives' torque requires)",
            goal.join(", "),
            self.speed_fraction * 100.0
        )
    }
}

/// Why a joint move is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MoveRefused {
    /// A goal that is not a number.
    #[error("joint {joint}: the goal {goal_rad} rad is not a number")]
    NotFinite {
        /// The joint (from 1).
        joint: usize,
        /// Its goal.
        goal_rad: f64,
    },
    /// A goal outside the joint's limits (less the margin).
    #[error(
        "joint {joint}: the goal {goal_rad:.4} rad is outside its limits [{min_rad:.4}, {max_rad:.4}] rad \
         ({GOAL_MARGIN_RAD} rad inside them at least)"
    )]
    OutsideLimits {
        /// The joint (from 1).
        joint: usize,
        /// Its goal.
        goal_rad: f64,
        /// The lower limit.
        min_rad: f64,
        /// The upper limit.
        max_rad: f64,
    },
    /// Another count of joints than the arm's.
    #[error("{given} joint values for this {joints}-joint arm")]
    JointCount {
        /// The values given.
        given: u32,
        /// The arm's joints.
        joints: usize,
    },
    /// A goal for a joint the arm does not have.
    #[error("a goal ({goal_rad} rad) for joint {joint}, which this {joints}-joint arm does not have")]
    NoSuchJoint {
        /// The joint (from 1).
        joint: usize,
        /// Its goal.
        goal_rad: f64,
        /// The arm's joints.
        joints: usize,
    },
    /// The robot driver is not running (no joint state yet, or stalled).
    #[error("the robot driver is {}: a joint move needs its joint states", .0.name())]
    RobotNotRunning(RobotState),
    /// The share of the speed limits out of range.
    #[error("the speed fraction {0} is not in [{MIN_SPEED_FRACTION}, 1]")]
    SpeedFraction(f64),
}

/// The move a `move_joints` command asks of `arm`, or why it is refused.
pub fn check(command: &CommandMsg, arm: &SerialArm) -> Result<JointMove, MoveRefused> {
    let joints = arm.joint_count();
    if command.joint_count as usize != joints {
        return Err(MoveRefused::JointCount { given: command.joint_count, joints });
    }
    let fraction = command.speed_fraction;
    if !speed_fraction_ok(fraction) {
        return Err(MoveRefused::SpeedFraction(fraction));
    }
    for (j, &goal_rad) in command.joints_rad.iter().enumerate() {
        let joint = j + 1;
        if !goal_rad.is_finite() {
            return Err(MoveRefused::NotFinite { joint, goal_rad });
        }
        if j >= joints {
            if goal_rad != 0.0 {
                return Err(MoveRefused::NoSuchJoint { joint, goal_rad, joints });
            }
            continue;
        }
        let limits = arm.links[j].limits;
        let (min_rad, max_rad) = (limits.position_min, limits.position_max);
        if !limits.holds_goal(goal_rad) {
            return Err(MoveRefused::OutsideLimits { joint, goal_rad, min_rad, max_rad });
        }
    }
    Ok(JointMove { goal_rad: command.joints_rad, speed_fraction: fraction, joints })
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_protocol::CommandKind;

    fn command(joints_rad: [f64; MAX_JOINTS], speed_fraction: f64) -> CommandMsg {
        CommandMsg {
            joint_count: 6,
            joints_rad,
            speed_fraction,
            ..CommandMsg::new(CommandKind::MoveJoints, 1)
        }
    }

    #[test]
    fn a_goal_inside_the_limits_is_taken_and_anything_else_refused_naming_the_joint() {
        let arm = vservo_arm::puma560::puma560();
        let limits = arm.links[2].limits;
        let inside = [0.1, -0.5, 0.3, 0.0, 0.2, -0.1, 0.0];
        let taken = check(&command(inside, 0.25), &arm).expect("inside the limits");
        assert_eq!((taken.goal_rad, taken.speed_fraction, taken.joints), (inside, 0.25, 6));

        let mut beyond = inside;
        beyond[2] = limits.position_max - GOAL_MARGIN_RAD / 2.0;
        assert!(matches!(
            check(&command(beyond, 0.25), &arm),
            Err(MoveRefused::OutsideLimits { joint: 3, .. })
        ));
        beyond[2] = limits.position_min - 1.0;
        assert!(matches!(
            check(&command(beyond, 0.25), &arm),
            Err(MoveRefused::OutsideLimits { joint: 3, .. })
        ));
        let mut not_a_number = inside;
        not_a_number[4] = f64::NAN;
        assert!(matches!(
            check(&command(not_a_number, 0.25), &arm),
            Err(MoveRefused::NotFinite { joint: 5, .. })
        ));
        let mut seventh = inside;
        seventh[6] = 0.2;
        let refused = check(&command(seventh, 0.25), &arm).expect_err("no seventh joint");
        assert_eq!(refused, MoveRefused::NoSuchJoint { joint: 7, goal_rad: 0.2, joints: 6 });
        assert!(refused.to_string().contains("6-joint arm"), "{refused}");
        for fraction in [0.0, 0.005, -0.1, 1.5, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(check(&command(inside, fraction), &arm), Err(MoveRefused::SpeedFraction(_))),
                "{fraction}"
            );
        }
        assert!(check(&command(inside, 1.0), &arm).is_ok());
        let five = CommandMsg { joint_count: 5, ..command(inside, 0.25) };
        assert_eq!(check(&five, &arm), Err(MoveRefused::JointCount { given: 5, joints: 6 }));
    }
}
