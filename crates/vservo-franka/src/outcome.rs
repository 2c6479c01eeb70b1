//! Pure readings of a motion: what a state says ([`MotionPhase`]: running / ended / aborted with errors) and
//! how a Move ended ([`MotionOutcome`]). No I/O.

use std::fmt;

use crate::errors::RobotErrors;
use crate::wire::modes::{ControllerMode, MotionGeneratorMode, RobotMode};
use crate::wire::state::RobotState;
use crate::wire::tcp::MoveStatus;

/// What one state says about a joint-velocity motion (a pure reading of the state).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionPhase {
    /// The robot moves under the joint-velocity generator and joint impedance controller: answer the state.
    Running,
    /// The generator has stopped without errors (finished or stopped); the Move's response says which.
    Ended,
    /// A reflex or user stop ended the motion; `errors` are the active error flags.
    Aborted {
        /// The errors active in the state.
        errors: RobotErrors,
    },
}

impl MotionPhase {
    /// Reads `state`: aborted if errors are active or the robot is in reflex / user stop, running if the
    /// robot is in `kMove` with the joint-velocity generator and joint impedance controller, else ended.
    pub fn of(state: &RobotState) -> Self {
        if !state.errors.is_empty() || matches!(state.robot_mode, RobotMode::Reflex | RobotMode::UserStopped)
        {
            MotionPhase::Aborted { errors: state.errors }
        } else if state.robot_mode == RobotMode::Move
            && state.motion_generator_mode == MotionGeneratorMode::JointVelocity
            && state.controller_mode == ControllerMode::JointImpedance
        {
            MotionPhase::Running
        } else {
            MotionPhase::Ended
        }
    }
}

/// How a Move ended, from its final response and the last state's error flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionOutcome {
    /// Finished as commanded (`kSuccess`).
    Finished,
    /// Ended by StopMove, another Move or a safety function (`kPreempted…`).
    Preempted {
        /// The Move's final status.
        status: MoveStatus,
    },
    /// Aborted (`kReflexAborted`, `kEmergencyAborted`, …).
    Aborted {
        /// The Move's final status.
        status: MoveStatus,
        /// The errors active in the last state received.
        errors: RobotErrors,
        /// The last state's `reflex_reason` (franka-sim accumulates it over a connection).
        reflex_reason: RobotErrors,
    },
}

impl fmt::Display for MotionOutcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MotionOutcome::Finished => f.write_str("finished (kSuccess)"),
            MotionOutcome::Preempted { status } => write!(f, "preempted ({status})"),
            MotionOutcome::Aborted { status, errors, reflex_reason } => {
                write!(f, "aborted ({status}), errors {errors}, reflex_reason {reflex_reason}")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::errors::RobotError;

    fn state(
        robot_mode: RobotMode,
        generator: MotionGeneratorMode,
        controller: ControllerMode,
    ) -> RobotState {
        RobotState {
            robot_mode,
            motion_generator_mode: generator,
            controller_mode: controller,
            ..RobotState::idle(7)
        }
    }

    #[test]
    fn the_phase_is_read_from_robot_mode_generator_controller_and_errors() {
        use ControllerMode as C;
        use MotionGeneratorMode as G;
        let running = state(RobotMode::Move, G::JointVelocity, C::JointImpedance);
        assert_eq!(MotionPhase::of(&running), MotionPhase::Running);
        assert_eq!(MotionPhase::of(&state(RobotMode::Idle, G::Idle, C::Other)), MotionPhase::Ended);
        assert_eq!(
            MotionPhase::of(&state(RobotMode::Move, G::JointPosition, C::JointImpedance)),
            MotionPhase::Ended
        );
        let reflex = state(RobotMode::Reflex, G::Idle, C::Other);
        assert_eq!(MotionPhase::of(&reflex), MotionPhase::Aborted { errors: RobotErrors::NONE });
        let errors = RobotErrors::NONE.with(RobotError::CommunicationConstraintsViolation);
        let with_errors = RobotState { errors, ..running };
        assert_eq!(MotionPhase::of(&with_errors), MotionPhase::Aborted { errors });
    }

    #[test]
    fn outcomes_print_status_and_error_names() {
        let errors = RobotErrors::NONE.with(RobotError::JointMotionGeneratorAccelerationDiscontinuity);
        let aborted =
            MotionOutcome::Aborted { status: MoveStatus::ReflexAborted, errors, reflex_reason: errors };
        assert_eq!(
            aborted.to_string(),
            "aborted (kReflexAborted), errors [\"joint_motion_generator_acceleration_discontinuity\"], \
             reflex_reason [\"joint_motion_generator_acceleration_discontinuity\"]"
        );
        assert_eq!(MotionOutcome::Finished.to_string(), "finished (kSuccess)");
    }
}
