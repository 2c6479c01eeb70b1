//! # vservo-runtime — the real-time shell
//!
//! This crate owns the four node loops of the real-time shell (docs/ARCHITECTURE.md): each runs one stage of
//! [`vservo_cell`] in its own process and talks to the others over iceoryx2 ([`vservo_protocol`]).
//!
//! - [`nodes::plant`], the simulated robot driver, paces the 1 ms tick on absolute CLOCK_MONOTONIC deadlines,
//!   publishes `joint_state`, wakes the rmrc with an iceoryx2 event and reads its answer at the next deadline
//!   (never waiting for it: a timed wait on a listener overshoots by milliseconds); an answer not there then is
//!   counted late and the previous command's reference followed by the drive's own servo (never its torque
//!   again), and after `hold_after_missed_ticks` the plant brakes the arm to rest itself.
//! - [`nodes::rmrc`] wakes on the `joint_state` event and answers with `joint_command` in the driver's
//!   interface, saying which twist each command follows and, in `reference_since_tick`, where its reference
//!   restarted. The catch-up over ticks it woke too late for and the restart at rest on a new driver epoch,
//!   after a stall or while the driver holds the arm are the rmrc stage's decisions
//!   (`vservo_cell::RmrcStage::follow`), counted here. The cell mode is applied each tick: a safe stop, or the
//!   daemon gone, a zero twist; a joint move `RmrcStage::move_joints_to`.
//! - [`nodes::vision`] with the simulated camera wakes on `joint_state` and takes an image every vision
//!   period of plant ticks (85 by default), publishing each frame on `camera_image`; with an external camera
//!   it wakes on each `camera_image`, works on the frame as it arrives and drops a stale one, and stamps the
//!   features with the capture time and the camera's pose at it, interpolated in the joint states of the last
//!   two vision periods ([`joint_history`]). It says when the extractor finds more blobs of a mark's size than
//!   it considers (a note).
//! - [`nodes::servo`] wakes on `features`: the gains and the cell mode it takes (held in a safe stop or a joint
//!   move, saying `moving` in the latter), the wire codes; the refusal of marks outside the image is the servo
//!   stage's, counted here.
//!
//! Every node publishes `telemetry` from a normal-priority thread ([`telemetry`], incl. the frame period and
//! the capture → twist latency); the hot loops only push timings into a bounded lock-free channel. The loops'
//! notes for people (e.g. the servo's verdict changes) go through a second bounded channel, and that thread
//! writes them, at most 4 lines a telemetry period, a count of the rest and the newest ([`notes`]).
//! [`clock`] is the absolute-deadline timer that skips missed periods; [`realtime`] sets SCHED_FIFO, CPU
//! affinity, mlockall and timer slack from the config's `[runtime]`; [`gains`] carries the daemon's design on
//! the wire.
//!
//! ## Timing
//!
//! The plant's tick k: sleep to the deadline, take the rmrc's answer to state k−1 (late: the previous
//! command's reference, followed by the drive's servo, counted), integrate, publish `sim_world` and state k
//! and notify. The vision node with the simulated camera, at the start of each period, publishes the frame
//! whose processing finished (so the processing time does not add to the d-frame delay), then captures the
//! next. A late tick still advances 1 ms of simulated
//! time; missed periods are skipped and counted, never replayed. A real-time run replayed in lockstep at its
//! own answer ticks agrees with it to rounding (`vservo_lockstep::Lockstep::run_replaying`).
//!
//! ## External drivers
//!
//! A robot driver runs at its own period; the rmrc answers each of its joint states in its interface and
//! commands nothing while none come; on a new driver epoch, or after a gap longer than
//! `state_timeout_periods`, it restarts its reference at rest from the measured joints. An external camera
//! paces the vision node: each frame is extracted as it arrives and its features published at once, stamped
//! with the capture time, with no modelled pipeline delay (the camera's is real); a frame that arrives more
//! than one vision period after its capture is dropped and counted.

pub mod clock;
pub mod gains;
pub mod joint_history;
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
    /// `[runtime]`: how this shell runs the node (thread settings, telemetry, holding and stop times); the
    /// cell's own part of the configuration is in `cell`.
    pub runtime: vservo_config::Runtime,
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
