//! A pure-Rust client of Franka's FCI network protocol ("research interface"), **server protocol version 10**
//! — the version of FR3 system ≥ 5.9.0 and libfranka 0.18.0–0.20.4 (libfranka-common @ d96c221).
//!
//! It speaks the protocol on the wire, without libfranka: a TCP command channel (port [`FCI_PORT`]: Connect,
//! Move, StopMove, AutomaticErrorRecovery; responses matched by `command_id` and framed by their header's
//! size) and a UDP state/command stream (one 1377-byte [`RobotState`] per 1 ms cycle from the robot, one
//! 371-byte `RobotCommand` back, echoing the state's `message_id` within the cycle). It drives one kind of
//! motion, the one a velocity-level visual servo needs: **joint velocities under the robot's joint
//! impedance controller**, finished with `motion_generation_finished`, stopped with StopMove, and recovered
//! from reflexes with AutomaticErrorRecovery.
//!
//! ```no_run
//! use std::time::Duration;
//! use vservo_franka::{Connection, JointVelocityCommand, MotionPhase};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let timeout = Duration::from_secs(1);
//! let mut robot = Connection::connect("172.16.0.2:1337".parse()?, timeout)?;
//! let mut state = robot.start_joint_velocity_motion(timeout)?;
//! let start = state.message_id;
//! while state.message_id - start < 1000 {
//!     if let MotionPhase::Aborted { errors } = MotionPhase::of(&state) {
//!         return Err(format!("aborted: {errors}").into());
//!     }
//!     robot.send_command(&state, &JointVelocityCommand::new([0.0; 7]))?;
//!     state = robot.recv_state(timeout)?;
//! }
//! robot.finish_motion(&state, [0.0; 7], timeout)?;
//! # Ok(())
//! # }
//! ```
//!
//! It does not filter or rate-limit commands (libfranka's `Robot::control` low-passes `dq_c` at 100 Hz by
//! default): the caller must send a velocity profile within the robot's limits (|ddq| ≤ 10 rad/s²,
//! |dddq| ≤ 5000 rad/s³, starting at the state's `dq_d`).
//!
//! Modules: [`wire`] (layouts, encode/decode), [`admission`] (which datagrams are the robot's states), [`errors`] (the 41 robot error flags), [`client`]
//! (connection, states, commands), [`motion`] (start, finish, stop, recover), [`outcome`] (running / ended /
//! aborted), [`profile`] (a smooth velocity profile), [`stats`] (latency percentiles).
//!
//! The 41 robot errors have their names ([`RobotError`]); the packed little-endian layouts are by byte offset,
//! checked against fixtures from libfranka's headers. Depends on `thiserror` only; tested against a fake robot
//! and against franka-sim. Its user is the Franka driver, `vservo-franka-driver`.

#[macro_use]
mod macros;

pub mod admission;
pub mod client;
pub mod errors;
pub mod motion;
pub mod outcome;
pub mod profile;
pub mod stats;
mod tcp_channel;
mod udp_channel;
pub mod wire;

pub use admission::{Dropped, DroppedCounts};
pub use client::{ConnectError, Connection, FCI_PORT};
pub use errors::{RobotError, RobotErrors};
pub use motion::{
    FinishMotionError, MotionResultError, RecoveryError, RecoveryUnderWay, StartMotionError, StopMotionError,
};
pub use outcome::{MotionOutcome, MotionPhase};
pub use profile::SmoothVelocityProfile;
pub use stats::LatencySummary;
pub use tcp_channel::TcpError;
pub use udp_channel::{RecvStateError, SendCommandError};
pub use wire::command::{JointVelocityCommand, RobotCommand};
pub use wire::modes::{ControllerMode, MotionGeneratorMode, RobotMode};
pub use wire::state::RobotState;
pub use wire::tcp::{AutomaticErrorRecoveryStatus, MoveStatus, StopMoveStatus};
pub use wire::{DecodeError, PROTOCOL_VERSION};
