//! The robot's 41 error flags (`research_interface::robot::Error`, `error.h`), in protocol order.
//!
//! A `RobotState` carries two arrays of 41 bools: `errors` (active now; libfranka's `current_errors`) and
//! `reflex_reason` (the errors that aborted the last motion; libfranka's `last_motion_errors`). Bool *i*
//! stands for [`RobotError`] *i*. [`RobotErrors`] holds such a set as a bit mask and names its members with
//! libfranka's `getErrorName()` strings.

use std::fmt;

/// How many error flags protocol v10 defines.
pub const ERROR_COUNT: usize = 41;

wire_enum! {
    /// One of the robot's error flags; its wire value is its index in the `errors` array.
    pub enum RobotError: u8 {
        /// `joint_position_limits_violation`, bit 0.
        JointPositionLimitsViolation = 0 => "joint_position_limits_violation",
        /// `cartesian_position_limits_violation`, bit 1.
        CartesianPositionLimitsViolation = 1 => "cartesian_position_limits_violation",
        /// `self_collision_avoidance_violation`, bit 2.
        SelfCollisionAvoidanceViolation = 2 => "self_collision_avoidance_violation",
        /// `joint_velocity_violation`, bit 3.
        JointVelocityViolation = 3 => "joint_velocity_violation",
        /// `cartesian_velocity_violation`, bit 4.
        CartesianVelocityViolation = 4 => "cartesian_velocity_violation",
        /// `force_control_safety_violation`, bit 5.
        ForceControlSafetyViolation = 5 => "force_control_safety_violation",
        /// `joint_reflex`, bit 6.
        JointReflex = 6 => "joint_reflex",
        /// `cartesian_reflex`, bit 7.
        CartesianReflex = 7 => "cartesian_reflex",
        /// `max_goal_pose_deviation_violation`, bit 8.
        MaxGoalPoseDeviationViolation = 8 => "max_goal_pose_deviation_violation",
        /// `max_path_pose_deviation_violation`, bit 9.
        MaxPathPoseDeviationViolation = 9 => "max_path_pose_deviation_violation",
        /// `cartesian_velocity_profile_safety_violation`, bit 10.
        CartesianVelocityProfileSafetyViolation = 10 => "cartesian_velocity_profile_safety_violation",
        /// `joint_position_motion_generator_start_pose_invalid`, bit 11.
        JointPositionMotionGeneratorStartPoseInvalid = 11 => "joint_position_motion_generator_start_pose_invalid",
        /// `joint_motion_generator_position_limits_violation`, bit 12.
        JointMotionGeneratorPositionLimitsViolation = 12 => "joint_motion_generator_position_limits_violation",
        /// `joint_motion_generator_velocity_limits_violation`, bit 13.
        JointMotionGeneratorVelocityLimitsViolation = 13 => "joint_motion_generator_velocity_limits_violation",
        /// `joint_motion_generator_velocity_discontinuity`, bit 14.
        JointMotionGeneratorVelocityDiscontinuity = 14 => "joint_motion_generator_velocity_discontinuity",
        /// `joint_motion_generator_acceleration_discontinuity`, bit 15.
        JointMotionGeneratorAccelerationDiscontinuity = 15 => "joint_motion_generator_acceleration_discontinuity",
        /// `cartesian_position_motion_generator_start_pose_invalid`, bit 16.
        CartesianPositionMotionGeneratorStartPoseInvalid = 16 => "cartesian_position_motion_generator_start_pose_invalid",
        /// `cartesian_motion_generator_elbow_limit_violation`, bit 17.
        CartesianMotionGeneratorElbowLimitViolation = 17 => "cartesian_motion_generator_elbow_limit_violation",
        /// `cartesian_motion_generator_velocity_limits_violation`, bit 18.
        CartesianMotionGeneratorVelocityLimitsViolation = 18 => "cartesian_motion_generator_velocity_limits_violation",
        /// `cartesian_motion_generator_velocity_discontinuity`, bit 19.
        CartesianMotionGeneratorVelocityDiscontinuity = 19 => "cartesian_motion_generator_velocity_discontinuity",
        /// `cartesian_motion_generator_acceleration_discontinuity`, bit 20.
        CartesianMotionGeneratorAccelerationDiscontinuity = 20 => "cartesian_motion_generator_acceleration_discontinuity",
        /// `cartesian_motion_generator_elbow_sign_inconsistent`, bit 21.
        CartesianMotionGeneratorElbowSignInconsistent = 21 => "cartesian_motion_generator_elbow_sign_inconsistent",
        /// `cartesian_motion_generator_start_elbow_invalid`, bit 22.
        CartesianMotionGeneratorStartElbowInvalid = 22 => "cartesian_motion_generator_start_elbow_invalid",
        /// `force_controller_desired_force_tolerance_violation`, bit 23.
        ForceControllerDesiredForceToleranceViolation = 23 => "force_controller_desired_force_tolerance_violation",
        /// `start_elbow_sign_inconsistent`, bit 24.
        StartElbowSignInconsistent = 24 => "start_elbow_sign_inconsistent",
        /// `communication_constraints_violation`, bit 25.
        CommunicationConstraintsViolation = 25 => "communication_constraints_violation",
        /// `power_limit_violation`, bit 26.
        PowerLimitViolation = 26 => "power_limit_violation",
        /// `cartesian_motion_generator_joint_position_limits_violation`, bit 27.
        CartesianMotionGeneratorJointPositionLimitsViolation = 27 => "cartesian_motion_generator_joint_position_limits_violation",
        /// `cartesian_motion_generator_joint_velocity_limits_violation`, bit 28.
        CartesianMotionGeneratorJointVelocityLimitsViolation = 28 => "cartesian_motion_generator_joint_velocity_limits_violation",
        /// `cartesian_motion_generator_joint_velocity_discontinuity`, bit 29.
        CartesianMotionGeneratorJointVelocityDiscontinuity = 29 => "cartesian_motion_generator_joint_velocity_discontinuity",
        /// `cartesian_motion_generator_joint_acceleration_discontinuity`, bit 30.
        CartesianMotionGeneratorJointAccelerationDiscontinuity = 30 => "cartesian_motion_generator_joint_acceleration_discontinuity",
        /// `cartesian_position_motion_generator_invalid_frame_flag`, bit 31.
        CartesianPositionMotionGeneratorInvalidFrameFlag = 31 => "cartesian_position_motion_generator_invalid_frame_flag",
        /// `controller_torque_discontinuity`, bit 32.
        ControllerTorqueDiscontinuity = 32 => "controller_torque_discontinuity",
        /// `joint_p2p_insufficient_torque_for_planning`, bit 33.
        JointP2pInsufficientTorqueForPlanning = 33 => "joint_p2p_insufficient_torque_for_planning",
        /// `tau_J_range_violation`, bit 34.
        TauJRangeViolation = 34 => "tau_J_range_violation",
        /// `instability_detected`, bit 35.
        InstabilityDetected = 35 => "instability_detected",
        /// `joint_move_in_wrong_direction`, bit 36.
        JointMoveInWrongDirection = 36 => "joint_move_in_wrong_direction",
        /// `cartesian_spline_motion_generator_violation`, bit 37.
        CartesianSplineMotionGeneratorViolation = 37 => "cartesian_spline_motion_generator_violation",
        /// `joint_via_motion_generator_planning_joint_limit_violation`, bit 38.
        JointViaMotionGeneratorPlanningJointLimitViolation = 38 => "joint_via_motion_generator_planning_joint_limit_violation",
        /// `base_acceleration_initialization_timeout`, bit 39.
        BaseAccelerationInitializationTimeout = 39 => "base_acceleration_initialization_timeout",
        /// `base_acceleration_invalid_reading`, bit 40.
        BaseAccelerationInvalidReading = 40 => "base_acceleration_invalid_reading",
    }
}

impl RobotError {
    /// The flag's index in the state's bool arrays.
    pub const fn index(self) -> usize {
        self.to_wire() as usize
    }
}

/// A set of [`RobotError`]s, as carried by `RobotState::errors` or `RobotState::reflex_reason`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct RobotErrors {
    bits: u64,
}

impl RobotErrors {
    /// The mask of all 41 defined bits.
    const DEFINED: u64 = (1 << ERROR_COUNT) - 1;

    /// No error.
    pub const NONE: RobotErrors = RobotErrors { bits: 0 };

    /// The set whose bit *i* stands for [`RobotError`] *i*; bits past 40 are dropped.
    pub const fn from_bits(bits: u64) -> Self {
        RobotErrors { bits: bits & Self::DEFINED }
    }

    /// The bit mask (bit *i* = [`RobotError`] *i*).
    pub const fn bits(self) -> u64 {
        self.bits
    }

    /// The set of the flags that are true in `flags` (index = error).
    pub fn from_flags(flags: &[bool; ERROR_COUNT]) -> Self {
        let bits = flags.iter().enumerate().filter(|(_, f)| **f).fold(0u64, |acc, (i, _)| acc | (1 << i));
        RobotErrors { bits }
    }

    /// The 41 flags, index = error.
    pub fn to_flags(self) -> [bool; ERROR_COUNT] {
        let mut flags = [false; ERROR_COUNT];
        for (i, f) in flags.iter_mut().enumerate() {
            *f = self.bits & (1 << i) != 0;
        }
        flags
    }

    /// This set with `error` added.
    #[must_use]
    pub const fn with(self, error: RobotError) -> Self {
        RobotErrors { bits: self.bits | (1 << error.index()) }
    }

    /// True if `error` is in the set.
    pub const fn contains(self, error: RobotError) -> bool {
        self.bits & (1 << error.index()) != 0
    }

    /// True if no error is set.
    pub const fn is_empty(self) -> bool {
        self.bits == 0
    }

    /// How many errors are set.
    pub const fn len(self) -> usize {
        self.bits.count_ones() as usize
    }

    /// The errors in the set, in protocol order.
    pub fn iter(self) -> impl Iterator<Item = RobotError> {
        RobotError::ALL.iter().copied().filter(move |e| self.contains(*e))
    }

    /// The names of the errors in the set, in protocol order
    /// (e.g. `joint_motion_generator_acceleration_discontinuity`).
    pub fn names(self) -> Vec<&'static str> {
        self.iter().map(RobotError::name).collect()
    }
}

impl FromIterator<RobotError> for RobotErrors {
    fn from_iter<I: IntoIterator<Item = RobotError>>(iter: I) -> Self {
        iter.into_iter().fold(RobotErrors::NONE, RobotErrors::with)
    }
}

/// As libfranka prints `Errors`: `["name", ...]`, `[]` when empty.
impl fmt::Display for RobotErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("[")?;
        for (i, e) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "\"{}\"", e.name())?;
        }
        f.write_str("]")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn there_are_41_errors_numbered_in_order() {
        assert_eq!(RobotError::ALL.len(), ERROR_COUNT);
        for (i, e) in RobotError::ALL.iter().enumerate() {
            assert_eq!(e.index(), i);
            assert_eq!(RobotError::from_wire(e.to_wire()), Some(*e));
        }
        assert_eq!(RobotError::from_wire(41), None);
    }

    #[test]
    fn names_match_libfranka() {
        assert_eq!(RobotError::JointPositionLimitsViolation.name(), "joint_position_limits_violation");
        assert_eq!(
            RobotError::JointMotionGeneratorAccelerationDiscontinuity.name(),
            "joint_motion_generator_acceleration_discontinuity"
        );
        assert_eq!(
            RobotError::from_wire(15),
            Some(RobotError::JointMotionGeneratorAccelerationDiscontinuity)
        );
        assert_eq!(RobotError::from_wire(25), Some(RobotError::CommunicationConstraintsViolation));
        assert_eq!(RobotError::TauJRangeViolation.name(), "tau_J_range_violation");
        assert_eq!(RobotError::BaseAccelerationInvalidReading.index(), 40);
    }

    #[test]
    fn a_set_names_its_members_in_order() {
        let set: RobotErrors = [
            RobotError::CommunicationConstraintsViolation,
            RobotError::JointMotionGeneratorAccelerationDiscontinuity,
        ]
        .into_iter()
        .collect();
        assert_eq!(
            set.names(),
            ["joint_motion_generator_acceleration_discontinuity", "communication_constraints_violation"]
        );
        assert_eq!(set.len(), 2);
        assert_eq!(
            set.to_string(),
            r#"["joint_motion_generator_acceleration_discontinuity", "communication_constraints_violation"]"#
        );
        assert_eq!(RobotErrors::NONE.to_string(), "[]");
        assert!(RobotErrors::NONE.is_empty());
    }

    #[test]
    fn flags_round_trip() {
        let mut flags = [false; ERROR_COUNT];
        flags[0] = true;
        flags[15] = true;
        flags[40] = true;
        let set = RobotErrors::from_flags(&flags);
        assert_eq!(set.bits(), 1 | (1 << 15) | (1 << 40));
        assert_eq!(set.to_flags(), flags);
        assert_eq!(RobotErrors::from_bits(u64::MAX).len(), ERROR_COUNT);
    }
}
