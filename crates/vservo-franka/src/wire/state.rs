//! `RobotState`: the datagram the robot sends every 1 ms cycle, decoded from its 1377 v10 bytes.

#![allow(non_snake_case)] // libfranka's field names (O_T_EE, tau_J, …), so the tables and docs map 1:1.

use super::modes::{ControllerMode, MotionGeneratorMode, RobotMode};
use super::state_layout as L;
use super::{DecodeError, Reader, Writer};
use crate::errors::{ERROR_COUNT, RobotErrors};

pub use super::state_layout::ROBOT_STATE_SIZE;

/// One robot state (protocol v10). Field names are libfranka's; lengths in m, angles in rad, masses in kg,
/// torques in N·m, forces in N, time derivatives per s. Poses are 4×4 homogeneous transforms, column-major.
///
/// The wire carries `float` (f32) values; they are widened to `f64` exactly, so decoding then encoding gives
/// back the same bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotState {
    /// Id of this state; a command answering it echoes it. On a real robot a millisecond clock, in
    /// franka-sim a per-connection counter from 1.
    pub message_id: u64,
    /// Measured end-effector pose in the base frame.
    pub O_T_EE: [f64; 16],
    /// Last desired end-effector pose in the base frame.
    pub O_T_EE_d: [f64; 16],
    /// End-effector frame in the flange frame.
    pub F_T_EE: [f64; 16],
    /// Stiffness frame in the end-effector frame.
    pub EE_T_K: [f64; 16],
    /// Nominal end-effector frame in the flange frame.
    pub F_T_NE: [f64; 16],
    /// End-effector frame in the nominal end-effector frame.
    pub NE_T_EE: [f64; 16],
    /// Configured end-effector mass, kg.
    pub m_ee: f64,
    /// Configured end-effector inertia about its centre of mass, kg·m², column-major 3×3.
    pub I_ee: [f64; 9],
    /// Configured end-effector centre of mass in the flange frame, m.
    pub F_x_Cee: [f64; 3],
    /// Configured load mass, kg.
    pub m_load: f64,
    /// Configured load inertia about its centre of mass, kg·m², column-major 3×3.
    pub I_load: [f64; 9],
    /// Configured load centre of mass in the flange frame, m.
    pub F_x_Cload: [f64; 3],
    /// Measured elbow configuration (joint 3 position, rad; joint 4 flip sign).
    pub elbow: [f64; 2],
    /// Desired elbow configuration.
    pub elbow_d: [f64; 2],
    /// Measured link-side joint torques, N·m.
    pub tau_J: [f64; 7],
    /// Desired link-side joint torques without gravity, N·m.
    pub tau_J_d: [f64; 7],
    /// Derivative of the measured joint torques, N·m/s.
    pub dtau_J: [f64; 7],
    /// Measured joint positions, rad.
    pub q: [f64; 7],
    /// Desired joint positions (the motion generator's reference), rad.
    pub q_d: [f64; 7],
    /// Measured joint velocities, rad/s.
    pub dq: [f64; 7],
    /// Desired joint velocities, rad/s.
    pub dq_d: [f64; 7],
    /// Desired joint accelerations, rad/s².
    pub ddq_d: [f64; 7],
    /// Joint contact flags (1.0 = contact threshold exceeded).
    pub joint_contact: [f64; 7],
    /// Cartesian contact flags (x, y, z, R, P, Y).
    pub cartesian_contact: [f64; 6],
    /// Joint collision flags.
    pub joint_collision: [f64; 7],
    /// Cartesian collision flags.
    pub cartesian_collision: [f64; 6],
    /// Filtered external torque estimate, N·m.
    pub tau_ext_hat_filtered: [f64; 7],
    /// External wrench estimate on the stiffness frame, in the base frame (N, N·m).
    pub O_F_ext_hat_K: [f64; 6],
    /// External wrench estimate on the stiffness frame, in the stiffness frame (N, N·m).
    pub K_F_ext_hat_K: [f64; 6],
    /// Desired end-effector twist in the base frame (m/s, rad/s).
    pub O_dP_EE_d: [f64; 6],
    /// Linear acceleration of the base (gravity direction), m/s².
    pub O_ddP_O: [f64; 3],
    /// Commanded elbow configuration.
    pub elbow_c: [f64; 2],
    /// Commanded elbow velocity.
    pub delbow_c: [f64; 2],
    /// Commanded elbow acceleration.
    pub ddelbow_c: [f64; 2],
    /// Last commanded end-effector pose in the base frame.
    pub O_T_EE_c: [f64; 16],
    /// Last commanded end-effector twist in the base frame (m/s, rad/s).
    pub O_dP_EE_c: [f64; 6],
    /// Last commanded end-effector acceleration in the base frame (m/s², rad/s²).
    pub O_ddP_EE_c: [f64; 6],
    /// Motor positions (scaled to the link side), rad.
    pub theta: [f64; 7],
    /// Motor velocities (scaled to the link side), rad/s.
    pub dtheta: [f64; 7],
    /// Top accelerometer readings (new in v10; 18 values, meaning not documented by libfranka).
    pub accelerometer_top: [f64; 18],
    /// Bottom accelerometer readings (new in v10; 18 values, meaning not documented by libfranka).
    pub accelerometer_bottom: [f64; 18],
    /// The running motion generator.
    pub motion_generator_mode: MotionGeneratorMode,
    /// The running controller.
    pub controller_mode: ControllerMode,
    /// Errors active now (libfranka `current_errors`).
    pub errors: RobotErrors,
    /// Errors that aborted the last motion (libfranka `last_motion_errors`).
    pub reflex_reason: RobotErrors,
    /// What the robot as a whole is doing.
    pub robot_mode: RobotMode,
    /// Fraction (0..=1) of the last 100 commands that arrived in time; 0 when no motion runs.
    pub control_command_success_rate: f64,
}

impl RobotState {
    /// Time of this state in s, libfranka's `RobotState::time` (`message_id` read as milliseconds).
    pub fn time_s(&self) -> f64 {
        // Exact below 2^53 ms (285 000 years).
        #[allow(clippy::cast_precision_loss)]
        let ms = self.message_id as f64;
        ms * 1e-3
    }

    /// Decodes a v10 datagram; anything but exactly [`ROBOT_STATE_SIZE`] bytes, a bool byte other than 0/1
    /// or an undefined mode value is refused with an error naming it.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let r = Reader::exact(bytes, "RobotState", ROBOT_STATE_SIZE)?;
        Ok(RobotState {
            message_id: r.u64(&L::MESSAGE_ID)?,
            O_T_EE: r.f32s(&L::O_T_EE)?,
            O_T_EE_d: r.f32s(&L::O_T_EE_D)?,
            F_T_EE: r.f32s(&L::F_T_EE)?,
            EE_T_K: r.f32s(&L::EE_T_K)?,
            F_T_NE: r.f32s(&L::F_T_NE)?,
            NE_T_EE: r.f32s(&L::NE_T_EE)?,
            m_ee: r.f32(&L::M_EE)?,
            I_ee: r.f32s(&L::I_EE)?,
            F_x_Cee: r.f32s(&L::F_X_CEE)?,
            m_load: r.f32(&L::M_LOAD)?,
            I_load: r.f32s(&L::I_LOAD)?,
            F_x_Cload: r.f32s(&L::F_X_CLOAD)?,
            elbow: r.f32s(&L::ELBOW)?,
            elbow_d: r.f32s(&L::ELBOW_D)?,
            tau_J: r.f32s(&L::TAU_J)?,
            tau_J_d: r.f32s(&L::TAU_J_D)?,
            dtau_J: r.f32s(&L::DTAU_J)?,
            q: r.f32s(&L::Q)?,
            q_d: r.f32s(&L::Q_D)?,
            dq: r.f32s(&L::DQ)?,
            dq_d: r.f32s(&L::DQ_D)?,
            ddq_d: r.f32s(&L::DDQ_D)?,
            joint_contact: r.f32s(&L::JOINT_CONTACT)?,
            cartesian_contact: r.f32s(&L::CARTESIAN_CONTACT)?,
            joint_collision: r.f32s(&L::JOINT_COLLISION)?,
            cartesian_collision: r.f32s(&L::CARTESIAN_COLLISION)?,
            tau_ext_hat_filtered: r.f32s(&L::TAU_EXT_HAT_FILTERED)?,
            O_F_ext_hat_K: r.f32s(&L::O_F_EXT_HAT_K)?,
            K_F_ext_hat_K: r.f32s(&L::K_F_EXT_HAT_K)?,
            O_dP_EE_d: r.f32s(&L::O_DP_EE_D)?,
            O_ddP_O: r.f32s(&L::O_DDP_O)?,
            elbow_c: r.f32s(&L::ELBOW_C)?,
            delbow_c: r.f32s(&L::DELBOW_C)?,
            ddelbow_c: r.f32s(&L::DDELBOW_C)?,
            O_T_EE_c: r.f32s(&L::O_T_EE_C)?,
            O_dP_EE_c: r.f32s(&L::O_DP_EE_C)?,
            O_ddP_EE_c: r.f32s(&L::O_DDP_EE_C)?,
            theta: r.f32s(&L::THETA)?,
            dtheta: r.f32s(&L::DTHETA)?,
            accelerometer_top: r.f32s(&L::ACCELEROMETER_TOP)?,
            accelerometer_bottom: r.f32s(&L::ACCELEROMETER_BOTTOM)?,
            motion_generator_mode: r.enum_u8(&L::MOTION_GENERATOR_MODE, MotionGeneratorMode::from_wire)?,
            controller_mode: r.enum_u8(&L::CONTROLLER_MODE, ControllerMode::from_wire)?,
            errors: error_flags(&r, &L::ERRORS)?,
            reflex_reason: error_flags(&r, &L::REFLEX_REASON)?,
            robot_mode: r.enum_u8(&L::ROBOT_MODE, RobotMode::from_wire)?,
            control_command_success_rate: r.f32(&L::CONTROL_COMMAND_SUCCESS_RATE)?,
        })
    }

    /// Encodes the state as the robot would send it (values narrowed to f32): for simulators and tests.
    pub fn encode(&self) -> [u8; ROBOT_STATE_SIZE] {
        let mut buf = [0u8; ROBOT_STATE_SIZE];
        let mut w = Writer::new(&mut buf);
        w.u64(&L::MESSAGE_ID, self.message_id);
        w.f32s(&L::O_T_EE, &self.O_T_EE);
        w.f32s(&L::O_T_EE_D, &self.O_T_EE_d);
        w.f32s(&L::F_T_EE, &self.F_T_EE);
        w.f32s(&L::EE_T_K, &self.EE_T_K);
        w.f32s(&L::F_T_NE, &self.F_T_NE);
        w.f32s(&L::NE_T_EE, &self.NE_T_EE);
        w.f32s(&L::M_EE, &[self.m_ee]);
        w.f32s(&L::I_EE, &self.I_ee);
        w.f32s(&L::F_X_CEE, &self.F_x_Cee);
        w.f32s(&L::M_LOAD, &[self.m_load]);
        w.f32s(&L::I_LOAD, &self.I_load);
        w.f32s(&L::F_X_CLOAD, &self.F_x_Cload);
        w.f32s(&L::ELBOW, &self.elbow);
        w.f32s(&L::ELBOW_D, &self.elbow_d);
        w.f32s(&L::TAU_J, &self.tau_J);
        w.f32s(&L::TAU_J_D, &self.tau_J_d);
        w.f32s(&L::DTAU_J, &self.dtau_J);
        w.f32s(&L::Q, &self.q);
        w.f32s(&L::Q_D, &self.q_d);
        w.f32s(&L::DQ, &self.dq);
        w.f32s(&L::DQ_D, &self.dq_d);
        w.f32s(&L::DDQ_D, &self.ddq_d);
        w.f32s(&L::JOINT_CONTACT, &self.joint_contact);
        w.f32s(&L::CARTESIAN_CONTACT, &self.cartesian_contact);
        w.f32s(&L::JOINT_COLLISION, &self.joint_collision);
        w.f32s(&L::CARTESIAN_COLLISION, &self.cartesian_collision);
        w.f32s(&L::TAU_EXT_HAT_FILTERED, &self.tau_ext_hat_filtered);
        w.f32s(&L::O_F_EXT_HAT_K, &self.O_F_ext_hat_K);
        w.f32s(&L::K_F_EXT_HAT_K, &self.K_F_ext_hat_K);
        w.f32s(&L::O_DP_EE_D, &self.O_dP_EE_d);
        w.f32s(&L::O_DDP_O, &self.O_ddP_O);
        w.f32s(&L::ELBOW_C, &self.elbow_c);
        w.f32s(&L::DELBOW_C, &self.delbow_c);
        w.f32s(&L::DDELBOW_C, &self.ddelbow_c);
        w.f32s(&L::O_T_EE_C, &self.O_T_EE_c);
        w.f32s(&L::O_DP_EE_C, &self.O_dP_EE_c);
        w.f32s(&L::O_DDP_EE_C, &self.O_ddP_EE_c);
        w.f32s(&L::THETA, &self.theta);
        w.f32s(&L::DTHETA, &self.dtheta);
        w.f32s(&L::ACCELEROMETER_TOP, &self.accelerometer_top);
        w.f32s(&L::ACCELEROMETER_BOTTOM, &self.accelerometer_bottom);
        w.u8(&L::MOTION_GENERATOR_MODE, self.motion_generator_mode.to_wire());
        w.u8(&L::CONTROLLER_MODE, self.controller_mode.to_wire());
        put_error_flags(&mut w, &L::ERRORS, self.errors);
        put_error_flags(&mut w, &L::REFLEX_REASON, self.reflex_reason);
        w.u8(&L::ROBOT_MODE, self.robot_mode.to_wire());
        w.f32s(&L::CONTROL_COMMAND_SUCCESS_RATE, &[self.control_command_success_rate]);
        buf
    }

    /// A state with every number 0, modes idle (`kIdle`/`kOther`, robot `kIdle`) and no errors.
    pub fn idle(message_id: u64) -> Self {
        RobotState {
            message_id,
            O_T_EE: [0.0; 16],
            O_T_EE_d: [0.0; 16],
            F_T_EE: [0.0; 16],
            EE_T_K: [0.0; 16],
            F_T_NE: [0.0; 16],
            NE_T_EE: [0.0; 16],
            m_ee: 0.0,
            I_ee: [0.0; 9],
            F_x_Cee: [0.0; 3],
            m_load: 0.0,
            I_load: [0.0; 9],
            F_x_Cload: [0.0; 3],
            elbow: [0.0; 2],
            elbow_d: [0.0; 2],
            tau_J: [0.0; 7],
            tau_J_d: [0.0; 7],
            dtau_J: [0.0; 7],
            q: [0.0; 7],
            q_d: [0.0; 7],
            dq: [0.0; 7],
            dq_d: [0.0; 7],
            ddq_d: [0.0; 7],
            joint_contact: [0.0; 7],
            cartesian_contact: [0.0; 6],
            joint_collision: [0.0; 7],
            cartesian_collision: [0.0; 6],
            tau_ext_hat_filtered: [0.0; 7],
            O_F_ext_hat_K: [0.0; 6],
            K_F_ext_hat_K: [0.0; 6],
            O_dP_EE_d: [0.0; 6],
            O_ddP_O: [0.0; 3],
            elbow_c: [0.0; 2],
            delbow_c: [0.0; 2],
            ddelbow_c: [0.0; 2],
            O_T_EE_c: [0.0; 16],
            O_dP_EE_c: [0.0; 6],
            O_ddP_EE_c: [0.0; 6],
            theta: [0.0; 7],
            dtheta: [0.0; 7],
            accelerometer_top: [0.0; 18],
            accelerometer_bottom: [0.0; 18],
            motion_generator_mode: MotionGeneratorMode::Idle,
            controller_mode: ControllerMode::Other,
            errors: RobotErrors::NONE,
            reflex_reason: RobotErrors::NONE,
            robot_mode: RobotMode::Idle,
            control_command_success_rate: 0.0,
        }
    }
}

fn error_flags(r: &Reader<'_>, f: &super::FieldLayout) -> Result<RobotErrors, DecodeError> {
    let mut flags = [false; ERROR_COUNT];
    for (i, flag) in flags.iter_mut().enumerate() {
        *flag = r.bool_at(f.name, f.offset + i)?;
    }
    Ok(RobotErrors::from_flags(&flags))
}

fn put_error_flags(w: &mut Writer<'_>, f: &super::FieldLayout, errors: RobotErrors) {
    for (i, flag) in errors.to_flags().iter().enumerate() {
        w.put_at(f.offset + i, &[u8::from(*flag)]);
    }
}
