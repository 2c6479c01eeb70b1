//! A joint-velocity motion: Move (joint impedance controller, joint-velocity generator), one command per
//! state, then `motion_generation_finished`; StopMove to cancel; AutomaticErrorRecovery after a reflex.
//!
//! The sequence is libfranka 0.20.4's (`Robot::Impl::startMotion`, `ControlLoop`, `finishMotion`,
//! `cancelMotion`): nothing is sent until the Move is answered `kMotionStarted` **and** a state shows the
//! requested modes; an abort shows first in the states (robot mode `kReflex`, modes idle, error flags),
//! then as the Move's final response (`kReflexAborted`).

use std::time::{Duration, Instant};

use crate::client::{ActiveMotion, Connection};
use crate::errors::RobotErrors;
use crate::outcome::{MotionOutcome, MotionPhase};
use crate::tcp_channel::TcpError;
use crate::udp_channel::{RecvStateError, SendCommandError};
use crate::wire::DecodeError;
use crate::wire::command::JointVelocityCommand;
use crate::wire::modes::{ControllerMode, MotionGeneratorMode, RobotMode};
use crate::wire::state::RobotState;
use crate::wire::tcp::{
    AutomaticErrorRecoveryStatus, Command, MoveRequest, MoveStatus, StopMoveStatus, decode_status,
    encode_empty_request,
};

/// Starting a motion failed or was refused.
#[derive(Debug, thiserror::Error)]
pub enum StartMotionError {
    /// This connection already runs a motion.
    #[error("refused to start a joint-velocity motion: a motion is already running")]
    AlreadyRunning,
    /// The last state shows a motion generator or external controller running.
    #[error(
        "refused to start a joint-velocity motion: the robot runs generator {generator}, controller {controller}"
    )]
    RobotBusy {
        /// The state's motion generator.
        generator: MotionGeneratorMode,
        /// The state's controller.
        controller: ControllerMode,
    },
    /// The robot answered the Move with a refusal.
    #[error("the robot refused the joint-velocity Move: {status} (robot mode {robot_mode}, errors {errors})")]
    Rejected {
        /// The Move's status.
        status: MoveStatus,
        /// The robot mode in the last state.
        robot_mode: RobotMode,
        /// The errors active in the last state.
        errors: RobotErrors,
    },
    /// The modes did not switch in time.
    #[error("the joint-velocity motion did not start within {waited:?} (state: generator {generator})")]
    Timeout {
        /// How long it was waited for.
        waited: Duration,
        /// The generator in the last state.
        generator: MotionGeneratorMode,
    },
    /// The Move exchange failed on the TCP channel.
    #[error("Move: {0}")]
    Tcp(#[from] TcpError),
    /// The Move response could not be decoded.
    #[error("Move response: {0}")]
    Malformed(#[from] DecodeError),
    /// No state arrived while waiting for the motion to start.
    #[error("waiting for the motion to start: {0}")]
    Recv(#[from] RecvStateError),
}

/// Reading how the running Move ended failed.
#[derive(Debug, thiserror::Error)]
pub enum MotionResultError {
    /// No Move is waiting for its final response.
    #[error("no motion is running: there is no Move response to wait for")]
    NoActiveMotion,
    /// The TCP channel failed (includes a timeout).
    #[error("Move final response: {0}")]
    Tcp(#[from] TcpError),
    /// The response could not be decoded.
    #[error("Move final response: {0}")]
    Malformed(#[from] DecodeError),
}

/// Finishing the motion failed, or the motion ended otherwise.
#[derive(Debug, thiserror::Error)]
pub enum FinishMotionError {
    /// No motion is running.
    #[error("refused to finish: no motion is running")]
    NoActiveMotion,
    /// The motion ended, but not as finished (aborted before or while finishing, or preempted).
    #[error("the motion did not finish: {outcome}")]
    NotFinished {
        /// How it ended.
        outcome: MotionOutcome,
    },
    /// The generator did not stop in time.
    #[error("the robot still ran the joint-velocity generator {waited:?} after motion_generation_finished")]
    Timeout {
        /// How long finishing commands were sent.
        waited: Duration,
    },
    /// Sending a finishing command failed.
    #[error("sending motion_generation_finished: {0}")]
    Send(#[from] SendCommandError),
    /// Receiving a state while finishing failed.
    #[error("receiving states while finishing: {0}")]
    Recv(#[from] RecvStateError),
    /// Reading the Move's final response failed.
    #[error("{0}")]
    Result(#[from] MotionResultError),
}

/// StopMove failed or was refused.
#[derive(Debug, thiserror::Error)]
pub enum StopMotionError {
    /// The robot refused the StopMove.
    #[error("the robot refused StopMove: {status}")]
    Rejected {
        /// StopMove's status.
        status: StopMoveStatus,
    },
    /// The generator did not stop in time.
    #[error("the robot still ran the joint-velocity generator {waited:?} after StopMove")]
    Timeout {
        /// How long it was waited for.
        waited: Duration,
    },
    /// The StopMove exchange failed on the TCP channel.
    #[error("StopMove: {0}")]
    Tcp(#[from] TcpError),
    /// The StopMove response could not be decoded.
    #[error("StopMove response: {0}")]
    Malformed(#[from] DecodeError),
    /// Receiving a state while stopping failed.
    #[error("receiving states while stopping: {0}")]
    Recv(#[from] RecvStateError),
    /// Reading the stopped Move's final response failed.
    #[error("{0}")]
    Result(#[from] MotionResultError),
}

/// AutomaticErrorRecovery failed or was refused.
#[derive(Debug, thiserror::Error)]
pub enum RecoveryError {
    /// A motion of this connection still waits for its final response (read it or stop it first).
    #[error("refused to run automatic error recovery: a motion is still running")]
    MotionActive,
    /// The robot refused or aborted the recovery.
    #[error("automatic error recovery: {status} (errors {errors})")]
    Rejected {
        /// The recovery's status.
        status: AutomaticErrorRecoveryStatus,
        /// The errors active in the last state.
        errors: RobotErrors,
    },
    /// The exchange failed on the TCP channel.
    #[error("AutomaticErrorRecovery: {0}")]
    Tcp(#[from] TcpError),
    /// The response could not be decoded.
    #[error("AutomaticErrorRecovery response: {0}")]
    Malformed(#[from] DecodeError),
}

impl Connection {
    /// Starts a joint-velocity motion under the joint impedance controller (libfranka's
    /// `Robot::control(JointVelocities)` Move) and returns the first state that shows it running. Answer that
    /// state and every later one with [`Connection::send_command`]; the first velocity must be within the
    /// robot's tolerance of the state's `dq_d` (start from it, normally zero).
    pub fn start_joint_velocity_motion(&mut self, timeout: Duration) -> Result<RobotState, StartMotionError> {
        if self.motion.is_some() {
            return Err(StartMotionError::AlreadyRunning);
        }
        let (generator, controller) = (self.last.motion_generator_mode, self.last.controller_mode);
        if generator != MotionGeneratorMode::Idle || controller == ControllerMode::ExternalController {
            return Err(StartMotionError::RobotBusy { generator, controller });
        }
        let id = self.tcp.take_command_id();
        self.tcp.send(&MoveRequest::joint_velocity().encode(id))?;
        self.motion = Some(ActiveMotion { move_command_id: id });
        let deadline = crate::client::deadline_after(timeout);
        let mut started = false;
        loop {
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Err(StartMotionError::Timeout {
                    waited: timeout,
                    generator: self.last.motion_generator_mode,
                });
            }
            let state = self.recv_state(remaining)?;
            // Polled after each state, so a response that came with (or after) the switching state counts.
            if !started && let Some(body) = self.tcp.poll(Command::Move, id)? {
                let status = decode_status(&body, "Move response", MoveStatus::from_wire)?;
                if status != MoveStatus::MotionStarted {
                    self.motion = None;
                    let (robot_mode, errors) = (self.last.robot_mode, self.last.errors);
                    return Err(StartMotionError::Rejected { status, robot_mode, errors });
                }
                started = true;
            }
            if started
                && state.motion_generator_mode == MotionGeneratorMode::JointVelocity
                && state.controller_mode == ControllerMode::JointImpedance
            {
                return Ok(state);
            }
        }
    }

    /// Waits up to `timeout` for the running Move's final response and ends the motion on this connection.
    /// Call it after a state shows [`MotionPhase::Aborted`] or [`MotionPhase::Ended`].
    pub fn motion_result(&mut self, timeout: Duration) -> Result<MotionOutcome, MotionResultError> {
        let Some(motion) = self.motion else { return Err(MotionResultError::NoActiveMotion) };
        let deadline = crate::client::deadline_after(timeout);
        let status = loop {
            let remaining = deadline.saturating_duration_since(Instant::now());
            let body = self.tcp.wait(Command::Move, motion.move_command_id, remaining)?;
            let status = decode_status(&body, "Move response", MoveStatus::from_wire)?;
            if status != MoveStatus::MotionStarted {
                break status;
            }
        };
        self.motion = None;
        Ok(match status {
            MoveStatus::Success => MotionOutcome::Finished,
            MoveStatus::Preempted | MoveStatus::PreemptedDueToActivatedSafetyFunctions => {
                MotionOutcome::Preempted { status }
            }
            _ => MotionOutcome::Aborted {
                status,
                errors: self.last.errors,
                reflex_reason: self.last.reflex_reason,
            },
        })
    }

    /// Finishes the motion: answers `state` (the newest) and each following state with `dq_c` (rad/s,
    /// normally zero) and `motion_generation_finished`, until the robot leaves the joint-velocity
    /// generator, then reads the Move's final response. Returns the first state after the motion.
    pub fn finish_motion(
        &mut self,
        state: &RobotState,
        dq_c: [f64; 7],
        timeout: Duration,
    ) -> Result<RobotState, FinishMotionError> {
        if self.motion.is_none() {
            return Err(FinishMotionError::NoActiveMotion);
        }
        let command = JointVelocityCommand::finish(dq_c);
        let deadline = crate::client::deadline_after(timeout);
        let mut state = state.clone();
        while MotionPhase::of(&state) == MotionPhase::Running {
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Err(FinishMotionError::Timeout { waited: timeout });
            }
            self.send_unchecked(&state, &command)?;
            state = self.recv_state(remaining)?;
        }
        let remaining = deadline.saturating_duration_since(Instant::now()).max(Duration::from_millis(100));
        match self.motion_result(remaining)? {
            MotionOutcome::Finished => Ok(state),
            outcome => Err(FinishMotionError::NotFinished { outcome }),
        }
    }

    /// Sends StopMove (libfranka `Robot::stop`). If this connection runs a motion, then receives states
    /// until the generator stops and returns how the Move ended (normally `kPreempted`).
    pub fn stop_motion(&mut self, timeout: Duration) -> Result<Option<MotionOutcome>, StopMotionError> {
        let deadline = crate::client::deadline_after(timeout);
        let id = self.tcp.take_command_id();
        self.tcp.send(&encode_empty_request(Command::StopMove, id))?;
        let body = self.tcp.wait(Command::StopMove, id, timeout)?;
        let status = decode_status(&body, "StopMove response", StopMoveStatus::from_wire)?;
        if status != StopMoveStatus::Success {
            return Err(StopMotionError::Rejected { status });
        }
        if self.motion.is_none() {
            return Ok(None);
        }
        while self.last.motion_generator_mode == MotionGeneratorMode::JointVelocity {
            let remaining = deadline.saturating_duration_since(Instant::now());
            if remaining.is_zero() {
                return Err(StopMotionError::Timeout { waited: timeout });
            }
            self.recv_state(remaining)?;
        }
        let remaining = deadline.saturating_duration_since(Instant::now()).max(Duration::from_millis(100));
        Ok(Some(self.motion_result(remaining)?))
    }

    /// Runs AutomaticErrorRecovery (clears a reflex; the robot returns to `kIdle`), waiting up to `timeout`
    /// for its response. Refused while a motion of this connection awaits its final response.
    pub fn automatic_error_recovery(&mut self, timeout: Duration) -> Result<(), RecoveryError> {
        if self.motion.is_some() {
            return Err(RecoveryError::MotionActive);
        }
        let id = self.tcp.take_command_id();
        self.tcp.send(&encode_empty_request(Command::AutomaticErrorRecovery, id))?;
        let body = self.tcp.wait(Command::AutomaticErrorRecovery, id, timeout)?;
        let status =
            decode_status(&body, "AutomaticErrorRecovery response", AutomaticErrorRecoveryStatus::from_wire)?;
        if status != AutomaticErrorRecoveryStatus::Success {
            return Err(RecoveryError::Rejected { status, errors: self.last.errors });
        }
        Ok(())
    }

    /// Sends AutomaticErrorRecovery and returns at once: [`Connection::recovery_done`] then says when the robot
    /// answered, so that a driver goes on with its own cycle (the recovery can take a good part of a second, with
    /// no robot state meanwhile). Refused while a motion of this connection awaits its final response.
    pub fn begin_automatic_error_recovery(&mut self) -> Result<RecoveryUnderWay, RecoveryError> {
        if self.motion.is_some() {
            return Err(RecoveryError::MotionActive);
        }
        let id = self.tcp.take_command_id();
        self.tcp.send(&encode_empty_request(Command::AutomaticErrorRecovery, id))?;
        Ok(RecoveryUnderWay { command_id: id })
    }

    /// Whether the recovery `under_way` has been answered: `None` not yet; `Some(Ok)` the robot recovered.
    pub fn recovery_done(&mut self, under_way: &RecoveryUnderWay) -> Option<Result<(), RecoveryError>> {
        let body = match self.tcp.poll(Command::AutomaticErrorRecovery, under_way.command_id) {
            Ok(None) => return None,
            Ok(Some(body)) => body,
            Err(error) => return Some(Err(error.into())),
        };
        let status =
            decode_status(&body, "AutomaticErrorRecovery response", AutomaticErrorRecoveryStatus::from_wire);
        Some(match status {
            Ok(AutomaticErrorRecoveryStatus::Success) => Ok(()),
            Ok(status) => Err(RecoveryError::Rejected { status, errors: self.last.errors }),
            Err(error) => Err(error.into()),
        })
    }
}

/// An AutomaticErrorRecovery sent and not yet answered ([`Connection::begin_automatic_error_recovery`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RecoveryUnderWay {
    command_id: u32,
}
