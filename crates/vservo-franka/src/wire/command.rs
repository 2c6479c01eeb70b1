//! `RobotCommand`: the datagram the client answers each state with (371 v10 bytes, f64 values).

#![allow(non_snake_case)] // libfranka's field names (O_T_EE_c, tau_J_d, …).

use super::command_layout as L;
use super::{DecodeError, Reader, Writer};

pub use super::command_layout::ROBOT_COMMAND_SIZE;

/// A whole v10 `RobotCommand` (`MotionGeneratorCommand` + `ControllerCommand`), every field libfranka has.
///
/// libfranka zero-fills it and sets only the fields of the running motion type; [`JointVelocityCommand`]
/// builds that for a joint-velocity motion.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotCommand {
    /// The `message_id` of the state this command answers.
    pub message_id: u64,
    /// Commanded joint positions, rad (joint-position motions).
    pub q_c: [f64; 7],
    /// Commanded joint velocities, rad/s (joint-velocity motions).
    pub dq_c: [f64; 7],
    /// Commanded end-effector pose, column-major 4×4 (Cartesian-pose motions).
    pub O_T_EE_c: [f64; 16],
    /// Commanded end-effector twist, m/s and rad/s (Cartesian-velocity motions).
    pub O_dP_EE_c: [f64; 6],
    /// Commanded elbow (Cartesian motions, if `valid_elbow`).
    pub elbow_c: [f64; 2],
    /// Whether `elbow_c` is meant.
    pub valid_elbow: bool,
    /// True to end the motion (sent until the robot's generator mode leaves the motion).
    pub motion_generation_finished: bool,
    /// Commanded joint torques, N·m (external controller).
    pub tau_J_d: [f64; 7],
    /// True to end a pure torque control (no motion generator).
    pub torque_command_finished: bool,
}

impl RobotCommand {
    /// A command answering `message_id` with every other field zero/false.
    pub fn zeroed(message_id: u64) -> Self {
        RobotCommand {
            message_id,
            q_c: [0.0; 7],
            dq_c: [0.0; 7],
            O_T_EE_c: [0.0; 16],
            O_dP_EE_c: [0.0; 6],
            elbow_c: [0.0; 2],
            valid_elbow: false,
            motion_generation_finished: false,
            tau_J_d: [0.0; 7],
            torque_command_finished: false,
        }
    }

    /// The 371 bytes to send.
    pub fn encode(&self) -> [u8; ROBOT_COMMAND_SIZE] {
        let mut buf = [0u8; ROBOT_COMMAND_SIZE];
        let mut w = Writer::new(&mut buf);
        w.u64(&L::MESSAGE_ID, self.message_id);
        w.f64s(&L::Q_C, &self.q_c);
        w.f64s(&L::DQ_C, &self.dq_c);
        w.f64s(&L::O_T_EE_C, &self.O_T_EE_c);
        w.f64s(&L::O_DP_EE_C, &self.O_dP_EE_c);
        w.f64s(&L::ELBOW_C, &self.elbow_c);
        w.bool(&L::VALID_ELBOW, self.valid_elbow);
        w.bool(&L::MOTION_GENERATION_FINISHED, self.motion_generation_finished);
        w.f64s(&L::TAU_J_D, &self.tau_J_d);
        w.bool(&L::TORQUE_COMMAND_FINISHED, self.torque_command_finished);
        buf
    }

    /// Decodes a v10 command (as a robot or simulator would); refuses any size but
    /// [`ROBOT_COMMAND_SIZE`] and bool bytes other than 0/1.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let r = Reader::exact(bytes, "RobotCommand", ROBOT_COMMAND_SIZE)?;
        Ok(RobotCommand {
            message_id: r.u64(&L::MESSAGE_ID)?,
            q_c: r.f64s(&L::Q_C)?,
            dq_c: r.f64s(&L::DQ_C)?,
            O_T_EE_c: r.f64s(&L::O_T_EE_C)?,
            O_dP_EE_c: r.f64s(&L::O_DP_EE_C)?,
            elbow_c: r.f64s(&L::ELBOW_C)?,
            valid_elbow: r.bool(&L::VALID_ELBOW)?,
            motion_generation_finished: r.bool(&L::MOTION_GENERATION_FINISHED)?,
            tau_J_d: r.f64s(&L::TAU_J_D)?,
            torque_command_finished: r.bool(&L::TORQUE_COMMAND_FINISHED)?,
        })
    }
}

/// One cycle's command of a joint-velocity motion: what libfranka sends for `JointVelocities`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointVelocityCommand {
    /// Commanded joint velocities, rad/s.
    pub dq_c: [f64; 7],
    /// True to end the motion; the robot then stops the generator (end the profile at zero velocity).
    pub motion_generation_finished: bool,
}

impl JointVelocityCommand {
    /// A command for velocities `dq_c` (rad/s) that keeps the motion running.
    pub const fn new(dq_c: [f64; 7]) -> Self {
        JointVelocityCommand { dq_c, motion_generation_finished: false }
    }

    /// The command that ends the motion at velocities `dq_c` (normally zero).
    pub const fn finish(dq_c: [f64; 7]) -> Self {
        JointVelocityCommand { dq_c, motion_generation_finished: true }
    }

    /// The index of the first joint whose velocity is NaN or infinite, if any.
    pub fn first_non_finite(&self) -> Option<usize> {
        self.dq_c.iter().position(|v| !v.is_finite())
    }

    /// The whole `RobotCommand` answering `message_id`: `dq_c` and the finished flag set, all else zero.
    pub fn to_robot_command(&self, message_id: u64) -> RobotCommand {
        RobotCommand {
            dq_c: self.dq_c,
            motion_generation_finished: self.motion_generation_finished,
            ..RobotCommand::zeroed(message_id)
        }
    }

    /// The 371 bytes answering the state `message_id`.
    pub fn encode(&self, message_id: u64) -> [u8; ROBOT_COMMAND_SIZE] {
        let mut buf = [0u8; ROBOT_COMMAND_SIZE];
        let mut w = Writer::new(&mut buf);
        w.u64(&L::MESSAGE_ID, message_id);
        w.f64s(&L::DQ_C, &self.dq_c);
        w.bool(&L::MOTION_GENERATION_FINISHED, self.motion_generation_finished);
        buf
    }
}
