//! # vservo-runtime — the real-time shell
//!
//! This crate owns the four node loops of the real-time shell (docs/ARCHITECTURE.md): each runs one stage of
//! [`vservo_cell`] in its own process and talks to the others over iceoryx2 ([`vservo_protocol`]).
//!
//! - [`nodes::plant`] paces the 1 ms tick on absolute CLOCK_MONOTONIC deadlines, publishes `joint_state`
//!   and waits (on an iceoryx2 event) for the rmrc's answer; a late answer is counted and the previous
//!   command held, and after `hold_after_missed_ticks` the plant brakes the arm itself.
//! - [`nodes::rmrc`] wakes on the `joint_state` event and answers with `joint_command` in the driver's interface.
//! - [`nodes::vision`] with the simulated camera wakes on `joint_state` and takes an image every vision
//!   period of plant ticks; with an external camera it wakes on each `camera_image`. [`nodes::servo`] wakes
//!   on `features`.
//!
//! Every node publishes `telemetry` from a normal-priority thread ([`telemetry`]); the hot loops only push
//! timings into a bounded lock-free channel. Real-time settings come from the config's `[runtime]`
//! ([`realtime`]).

pub mod clock;
pub mod gains;
pub mod joint_history;
pub mod logging;
pub mod nodes;
pub mod notes;
pub mod realtime;
pub mod telemetry;
pub mod wire;

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use vservo_arm::JointVector;
use vservo_cell::Cell;

/// Why a node could not run.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// iceoryx2 refused a service, port or node.
    #[error(transparent)]
    Protocol(#[from] vservo_protocol::ProtocolError),
    /// A thread could not be started.
    #[error("thread: {0}")]
    Thread(String),
}

/// What a node needs to run.
#[derive(Debug, Clone)]
pub struct NodeContext {
    /// The cell, built from the configuration.
    pub cell: Cell,
    /// The instance name (service prefix).
    pub instance: String,
    /// Set by SIGTERM/SIGINT: the loop finishes its cycle and returns.
    pub stop: Arc<AtomicBool>,
    /// Set when the daemon is gone: servo and vision stop; the rmrc brings the reference to rest and stops;
    /// the plant holds the arm and stops once the rmrc is gone and the arm is at rest.
    pub orphaned: Arc<AtomicBool>,
    /// The run's key from the daemon: gains (servo) and object commands (plant) sealed with it are taken,
    /// others refused and counted. A node started without it takes none.
    pub seal_key: Option<vservo_protocol::seal::SealKey>,
    /// plant only: start at rest at these joints and this tick (a restart after a crash) instead of the
    /// scenario's start.
    pub resume: Option<(JointVector, u64)>,
    /// vision only: track the marks from these features (the last published before a restart).
    pub resume_features: Option<vservo_scene::FeatureVector>,
}

impl NodeContext {
    fn stopping(&self) -> bool {
        self.stop.load(std::sync::atomic::Ordering::Relaxed)
    }

    fn orphaned(&self) -> bool {
        self.orphaned.load(std::sync::atomic::Ordering::Relaxed)
    }
}

/// Below this joint speed (rad/s) the arm is at rest: a node that outlives the daemon stops there, and so does
/// the daemon's own safe stop (the rule is the protocol's, which clients share).
pub use vservo_protocol::AT_REST_RAD_S;
