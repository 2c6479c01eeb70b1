//! Joint limits and their violations.

use std::fmt;

/// The limits of one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lowest joint angle (rad).
    pub position_min: f64,
    /// Highest joint angle (rad).
    pub position_max: f64,
    /// Largest joint speed, either direction (rad/s).
    pub velocity_max: f64,
    /// Largest joint torque, either direction (N·m).
    pub torque_max: f64,
}

/// The share of an arm's speed, acceleration and jerk limits a jerk-limited reference uses at most (the rmrc's,
/// vservo-sim's interpolator), and a driver's last guard on what the robot is sent (the Franka driver's): a
/// controller that checks the discrete derivatives of the commands against the published numbers (libfranka checks
/// each minus 1e-3; franka-sim flags a jerk of 5000.000000000005 rad/s³ against 5000) sees every command inside
/// them, rounding included.
pub const LIMIT_MARGIN: f64 = 0.995;

/// How far inside its limits a joint's goal must be (rad): a goal on a limit would leave the arm's position check
/// a rounding error from a fault.
pub const GOAL_MARGIN_RAD: f64 = 0.01;

impl JointLimits {
    /// Whether `q` lies inside the position range (bounds included).
    #[inline]
    pub fn position_ok(&self, q: f64) -> bool {
        q >= self.position_min && q <= self.position_max
    }

    /// Whether `q` may be a joint move's goal: [`GOAL_MARGIN_RAD`] inside the position range.
    #[inline]
    pub fn holds_goal(&self, q: f64) -> bool {
        q >= self.position_min + GOAL_MARGIN_RAD && q <= self.position_max - GOAL_MARGIN_RAD
    }
}

/// Which quantity a limit bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LimitedQuantity {
    /// Joint angle.
    Position,
    /// Joint speed.
    Velocity,
    /// Joint torque.
    Torque,
}

impl LimitedQuantity {
    /// The SI unit of the quantity.
    pub fn unit(&self) -> &'static str {
        match self {
            LimitedQuantity::Position => "rad",
            LimitedQuantity::Velocity => "rad/s",
            LimitedQuantity::Torque => "N·m",
        }
    }
}

impl fmt::Display for LimitedQuantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LimitedQuantity::Position => "position",
            LimitedQuantity::Velocity => "velocity",
            LimitedQuantity::Torque => "torque",
        })
    }
}

/// A joint outside one of its limits (or not a finite number).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "joint {joint_number} {quantity} {value} {unit} is outside [{min:.4}, {max:.4}] {unit}",
    joint_number = .joint + 1,
    unit = .quantity.unit()
)]
pub struct LimitViolation {
    /// Zero-based joint index.
    pub joint: usize,
    /// What was out of range.
    pub quantity: LimitedQuantity,
    /// The offending value (SI).
    pub value: f64,
    /// The lower bound.
    pub min: f64,
    /// The upper bound.
    pub max: f64,
}

impl crate::SerialArm {
    /// The first joint outside its position range, if any (NaN counts as outside).
    pub fn check_positions(&self, q: &crate::JointVector) -> Result<(), LimitViolation> {
        self.check(q, LimitedQuantity::Position, |l| (l.position_min, l.position_max))
    }

    /// The first joint faster than its velocity limit, if any.
    pub fn check_velocities(&self, qd: &crate::JointVector) -> Result<(), LimitViolation> {
        self.check(qd, LimitedQuantity::Velocity, |l| (-l.velocity_max, l.velocity_max))
    }

    /// The first joint torque beyond its limit, if any.
    pub fn check_torques(&self, tau: &crate::JointVector) -> Result<(), LimitViolation> {
        self.check(tau, LimitedQuantity::Torque, |l| (-l.torque_max, l.torque_max))
    }

    fn check(
        &self,
        values: &crate::JointVector,
        quantity: LimitedQuantity,
        range: impl Fn(&JointLimits) -> (f64, f64),
    ) -> Result<(), LimitViolation> {
        for (joint, (link, &value)) in self.joints().iter().zip(values.iter()).enumerate() {
            let (min, max) = range(&link.limits);
            // written so that NaN fails the test
            if !(value >= min && value <= max) {
                return Err(LimitViolation { joint, quantity, value, min, max });
            }
        }
        Ok(())
    }

    /// Clamps each torque to its joint's limit.
    pub fn saturate_torques(&self, tau: &crate::JointVector) -> crate::JointVector {
        crate::JointVector::from_fn(|i, _| {
            let max = self.links[i].limits.torque_max;
            tau[i].clamp(-max, max)
        })
    }
}
