//! The payloads: `#[repr(C)]`, fixed size, no pointers, each starting with the schema version.
//!
//! Field order is chosen so that no padding is needed: 8-byte fields first, then 4-byte, then bytes.
//! docs/PROTOCOL.md lists the offsets, which the tests in this module check.

use iceoryx2::prelude::ZeroCopySend;

/// The schema version every payload carries in its first four bytes. Bumped on any layout change.
/// 2: `joint_state` carries the robot only (the board's pose moved to `sim_world`), the driver declares its
/// command interface and period; `joint_torque` became `joint_command`; `camera_image` added.
pub const SCHEMA_VERSION: u32 = 5;

/// Joints of the arm.
pub const JOINTS: usize = 6;
/// Image features (x, y of four marks).
pub const FEATURES: usize = 8;
/// Marks.
pub const MARKS: usize = 4;

/// The command interfaces a robot driver may take ([`JointStateMsg::command_mode`],
/// [`JointCommandMsg::mode`]).
pub mod command_mode {
    /// Joint torques (`torque_nm`): the rmrc runs the joint servo (the simulated dynamic PUMA 560).
    pub const TORQUE: u32 = 0;
    /// Joint velocities (`qd_ref_rad_s`, with `q_ref_rad` for drivers that correct drift): the interpolator's
    /// q̇ reference, velocity- and acceleration-limited.
    pub const VELOCITY: u32 = 1;
    /// Joint positions (`q_ref_rad`, with `qd_ref_rad_s` as feed-forward): the interpolator's q reference.
    pub const POSITION: u32 = 2;
}

/// Driver states of [`JointStateMsg::driver_status`].
pub mod driver_status {
    /// Following the commands it receives.
    pub const FOLLOWING: u32 = 0;
    /// Holding the arm at rest: no valid command came in time (or none yet).
    pub const HOLDING: u32 = 1;
    /// The driver or the arm is in fault (protective stop, drive error): it does not move.
    pub const FAULT: u32 = 2;
}

/// robot driver → rmrc, vision, vservod (every driver period): the arm's measured state. The robot only:
/// nothing here is known only to a simulation.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::JointState")]
#[repr(C)]
pub struct JointStateMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`fault_bits`].
    pub faults: u32,
    /// Driver periods since the driver started.
    pub tick: u64,
    /// CLOCK_MONOTONIC (ns) when `q` was measured.
    pub stamp_ns: u64,
    /// Changes each time the driver starts: a consumer that sees a new one re-synchronises.
    pub driver_epoch: u64,
    /// The driver's period (ns): a joint state comes this often.
    pub period_ns: u64,
    /// The [`command_mode`] the driver takes.
    pub command_mode: u32,
    /// [`driver_status`].
    pub driver_status: u32,
    /// Joint angles (rad).
    pub q_rad: [f64; JOINTS],
    /// Joint velocities (rad/s).
    pub qd_rad_s: [f64; JOINTS],
    /// Joint torques, measured or applied (N·m); NaN where the driver does not know them.
    pub torque_nm: [f64; JOINTS],
    /// The `answers_tick` of the joint command the driver applied over the period that ended with this
    /// state: `tick − 1` when the answer to the last state came in time, older when the driver kept an
    /// earlier command, `u64::MAX` when it applied none (holding the arm, or before the first command).
    pub applied_command_tick: u64,
}

/// Fault bits of [`JointStateMsg::faults`].
pub mod fault_bits {
    /// Shift of the per-joint position-limit bits.
    pub const POSITION_LIMIT_SHIFT: u32 = 0;
    /// Shift of the per-joint velocity-limit bits.
    pub const VELOCITY_LIMIT_SHIFT: u32 = 8;
    /// Shift of the per-joint torque-saturation bits.
    pub const TORQUE_SATURATED_SHIFT: u32 = 16;
    /// The driver failed (the simulated plant: its integration failed; the state was kept, stopped).
    pub const DRIVER_FAILED: u32 = 1 << 24;
}

/// rmrc → robot driver (in answer to each joint state): the command for the driver's next period, in the
/// interface the driver declared. Every field is filled whatever the mode (torque zero where not computed).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::JointCommand")]
#[repr(C)]
pub struct JointCommandMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// The [`command_mode`] this command is in (the one the driver declared).
    pub mode: u32,
    /// The `tick` of the joint state this answers.
    pub answers_tick: u64,
    /// The `driver_epoch` of that joint state.
    pub driver_epoch: u64,
    /// That joint state's `stamp_ns` (echoed, for the round trip).
    pub state_stamp_ns: u64,
    /// CLOCK_MONOTONIC (ns) when the command was published.
    pub stamp_ns: u64,
    /// Joint torques (N·m), TORQUE mode.
    pub torque_nm: [f64; JOINTS],
    /// q_d (rad) at the end of the next period.
    pub q_ref_rad: [f64; JOINTS],
    /// q̇_d (rad/s) over the next period.
    pub qd_ref_rad_s: [f64; JOINTS],
    /// The twist this command follows: the `capture_tick` of its `camera_twist` (`u64::MAX` before the
    /// first). `answers_tick − twist_capture_tick` is the camera-to-actuation latency in ticks.
    pub twist_capture_tick: u64,
    /// The joint-state tick at which the rmrc took that twist in (`u64::MAX` before the first).
    pub twist_applied_tick: u64,
    /// The joint-state tick from which the rmrc's reference runs: where it last started at rest from the
    /// measured joints (the first state, a new driver epoch, or a driver back after a gap).
    pub reference_since_tick: u64,
    /// The rmrc's seal under the run's key ([`crate::seal`]): the simulated driver applies sealed commands
    /// only; an external driver, which is not given the key, ignores it.
    pub seal: u64,
}

/// simulated plant → simulated camera (every tick; simulation only): what only a simulation knows.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::SimWorld")]
#[repr(C)]
pub struct SimWorldMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// Zero.
    pub reserved: u32,
    /// The plant tick (the `joint_state` of the same tick).
    pub tick: u64,
    /// The board's pose in the base frame, 3×4 [R | t] row-major (t in m).
    pub base_from_board: [f64; 12],
}

/// Pixel formats of [`CameraImageHeader::format`].
pub mod pixel_format {
    /// 8 bits per pixel, gray.
    pub const MONO8: u32 = 0;
}

/// The largest image `camera_image` carries (bytes): 1280 × 1024 pixels of 8 bits.
pub const MAX_IMAGE_BYTES: usize = 1280 * 1024;

/// camera driver → vision (each frame): the user header of a `camera_image` sample, whose payload is the
/// image as a slice of `u8`, rows top to bottom, `stride_bytes` apart.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("vservo::CameraImageHeader")]
#[repr(C)]
pub struct CameraImageHeader {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`pixel_format`].
    pub format: u32,
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Bytes from one row's start to the next (≥ width).
    pub stride_bytes: u32,
    /// Zero.
    pub reserved: u32,
    /// Counts the camera's frames from 0.
    pub frame: u64,
    /// CLOCK_MONOTONIC (ns) when the image was exposed.
    pub capture_stamp_ns: u64,
}

/// Per-mark status codes of [`FeaturesMsg::mark_status`].
pub mod mark_status {
    /// Found; its feature is valid.
    pub const VALID: u8 = 0;
    /// Its expected position is outside the image.
    pub const OUTSIDE_IMAGE: u8 = 1;
    /// Its blob touches the image border.
    pub const CUT_BY_BORDER: u8 = 2;
    /// Run together with another mark into one blob.
    pub const MERGED: u8 = 3;
    /// Its blob has the wrong shape.
    pub const IRREGULAR: u8 = 4;
    /// No blob where it should be.
    pub const NOT_FOUND: u8 = 5;
    /// The image itself is unusable.
    pub const BAD_IMAGE: u8 = 6;
}

/// vision → servo (every frame): the features of the frame leaving the image pipeline.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::Features")]
#[repr(C)]
pub struct FeaturesMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// Bit m set when mark m is valid.
    pub valid_mask: u32,
    /// Frame number of the image (counted by the vision node from its start).
    pub frame: u64,
    /// The plant tick of the joint state the image was taken at.
    pub capture_tick: u64,
    /// CLOCK_MONOTONIC (ns) when the image was taken.
    pub capture_stamp_ns: u64,
    /// CLOCK_MONOTONIC (ns) when the features were published (the pipeline delay later).
    pub stamp_ns: u64,
    /// ξ = [x₁ y₁ … x₄ y₄] (px, image origin top-left), NaN where a mark is not valid.
    pub features_px: [f64; FEATURES],
    /// Each mark's [`mark_status`] code.
    pub mark_status: [u8; MARKS],
    /// Zero.
    pub reserved: [u8; 4],
    /// The camera's pose in the robot's base frame when the image was taken (the simulated camera: from the
    /// joint state of `capture_tick`; an external camera: from the joint states around `capture_stamp_ns`,
    /// interpolated), the top 3 rows of the 4×4 transform, row-major; NaN when not known. The servo takes
    /// the camera's own motion from it (reacquiring lost marks, the target's motion).
    pub base_from_camera: [f64; 12],
}

/// Verdicts of [`CameraTwistMsg::verdict`].
pub mod verdict {
    /// No frame yet: zero twist.
    pub const WAITING: u32 = 0;
    /// The law's twist.
    pub const SERVOING: u32 = 1;
    /// Marks missing and no camera pose known where all four were seen: zero twist (`missing_mask` says which).
    pub const MARKS_MISSING: u32 = 2;
    /// The servo is stopping (shutdown): zero twist.
    pub const STOPPING: u32 = 3;
    /// The cell is in a safe stop ([`CellModeMsg`]): zero twist until the daemon resumes it.
    pub const SAFE_STOP: u32 = 4;
    /// One mark missing (`missing_mask`): the law's twist on the other three.
    pub const SERVOING_ON_THREE: u32 = 5;
    /// Two or more marks missing (`missing_mask`), or one and no design for the three seen (their desired
    /// images in a line): steering the camera back to where all were last seen.
    pub const REACQUIRING: u32 = 6;

    /// Whether a twist of this verdict is to be followed (the others mean: bring the arm to rest).
    pub fn moves(verdict: u32) -> bool {
        matches!(verdict, SERVOING | SERVOING_ON_THREE | REACQUIRING)
    }
}

/// servo → rmrc (every frame): the camera twist.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::CameraTwist")]
#[repr(C)]
pub struct CameraTwistMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`verdict`]; a twist to follow with the verdicts that move ([`verdict::moves`]), zero with the others.
    pub verdict: u32,
    /// The frame the twist was computed from.
    pub frame: u64,
    /// Its capture tick.
    pub capture_tick: u64,
    /// Version of the gains used (1 at start, +1 per accepted reload).
    pub gains_version: u64,
    /// CLOCK_MONOTONIC (ns) when published.
    pub stamp_ns: u64,
    /// u = [v_x v_y v_z ω_x ω_y ω_z] in the camera frame (m/s, rad/s).
    pub twist: [f64; 6],
    /// RMS of ξ − ξ_d over the valid features (px); NaN when none.
    pub feature_error_px: f64,
    /// Bit m set when mark m was missing.
    pub missing_mask: u32,
    /// What the law did beyond the law as designed ([`law_flag`] bits; zero unless the law computed the
    /// twist).
    pub law_flags: u32,
}

/// The bits of [`CameraTwistMsg::law_flags`].
pub mod law_flag {
    /// The border barrier (`controller.border_margin_px`) changed the twist to keep a mark inside.
    pub const BARRIER: u32 = 1;
    /// The frame's own design (a scheduled `controller.interaction`) failed on a degenerate image: the fixed
    /// gain for its marks was used.
    pub const FIXED_GAIN_FALLBACK: u32 = 2;
    /// The target's estimated image motion was fed forward (`controller.feedforward`, once the estimate has
    /// settled).
    pub const FEEDFORWARD: u32 = 4;
}

/// The nodes, as numbered in [`TelemetryMsg::node`] and [`DaemonStatusMsg::nodes`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u32)]
pub enum NodeRole {
    /// The simulated arm and world: the simulated robot driver (not started for an external driver).
    Plant = 0,
    /// The camera and feature extractor.
    Vision = 1,
    /// The LQ visual-servo law.
    Servo = 2,
    /// The 1 ms interpolator and joint servo.
    Rmrc = 3,
}

impl NodeRole {
    /// All four, in start order.
    pub const ALL: [NodeRole; 4] = [NodeRole::Plant, NodeRole::Rmrc, NodeRole::Servo, NodeRole::Vision];

    /// The role's name.
    pub fn name(self) -> &'static str {
        match self {
            NodeRole::Plant => "plant",
            NodeRole::Vision => "vision",
            NodeRole::Servo => "servo",
            NodeRole::Rmrc => "rmrc",
        }
    }

    /// The role from its name.
    pub fn from_name(name: &str) -> Option<NodeRole> {
        Self::ALL.into_iter().find(|role| role.name() == name)
    }

    /// The role from its number.
    pub fn from_index(index: u32) -> Option<NodeRole> {
        Self::ALL.into_iter().find(|role| *role as u32 == index)
    }
}

/// Percentiles of one timing over a telemetry window (ns; zero when the window had no samples).
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("vservo::Timing")]
#[repr(C)]
pub struct TimingMsg {
    /// Samples in the window.
    pub count: u64,
    /// Median.
    pub p50_ns: u64,
    /// 99th percentile.
    pub p99_ns: u64,
    /// 99.9th percentile.
    pub p999_ns: u64,
    /// Largest.
    pub max_ns: u64,
}

/// every node → anyone (10 Hz): loop timing over the last window and counters since the node started.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::Telemetry")]
#[repr(C)]
pub struct TelemetryMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`NodeRole`] as a number.
    pub node: u32,
    /// CLOCK_MONOTONIC (ns) when published.
    pub stamp_ns: u64,
    /// Length of the window the timings cover (ns).
    pub window_ns: u64,
    /// Loop cycles since the node started.
    pub cycles: u64,
    /// Cycles that started more than one period late, since the node started.
    pub overruns: u64,
    /// Periods skipped after a stall (not replayed), since the node started.
    pub skipped_periods: u64,
    /// plant: ticks whose answer from the rmrc came late (the previous command was held).
    pub late_answers: u64,
    /// Input messages refused (wrong schema, epoch or tick), since the node started.
    pub rejected_messages: u64,
    /// Gains version in use (servo; zero for the other nodes).
    pub gains_version: u64,
    /// plant: the latest tick; vision/servo: the latest frame; rmrc: the latest tick answered.
    pub progress: u64,
    /// How late each cycle woke after its deadline (periodic nodes) or after its input was sent (event
    /// driven nodes).
    pub wake_latency: TimingMsg,
    /// Time from wake-up to the cycle's output.
    pub execution: TimingMsg,
    /// plant only: from publishing a joint state to the rmrc's answer arriving.
    pub round_trip: TimingMsg,
    /// vision only: between the capture stamps of successive images (the camera's frame period).
    pub frame_period: TimingMsg,
    /// servo only: from an image's capture to the twist computed from it.
    pub capture_latency: TimingMsg,
    /// servo: RMS feature error (px) of the latest frame; NaN otherwise.
    pub feature_error_px: f64,
    /// The node's process id.
    pub pid: u32,
    /// Node-specific state: plant 1 = holding the arm; servo = the last verdict; else 0.
    pub mode: u32,
}

/// Node states in [`NodeStatusMsg::state`].
pub mod node_state {
    /// Not started yet.
    pub const NOT_STARTED: u32 = 0;
    /// Running.
    pub const RUNNING: u32 = 1;
    /// Exited; waiting to be restarted.
    pub const BACKING_OFF: u32 = 2;
    /// Stopped on purpose.
    pub const STOPPED: u32 = 3;
    /// Hung (its loop made no progress for `runtime.hang_timeout_s`): being killed, then restarted.
    pub const HUNG: u32 = 4;
}

/// One node as the daemon sees it.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("vservo::NodeStatus")]
#[repr(C)]
pub struct NodeStatusMsg {
    /// Restarts since the daemon started.
    pub restarts: u64,
    /// CLOCK_MONOTONIC (ns) of the node's latest telemetry (0 if none yet).
    pub last_telemetry_ns: u64,
    /// [`node_state`].
    pub state: u32,
    /// Process id (0 when not running).
    pub pid: u32,
    /// Exit status of the last run (signal number negated; 0 if none).
    pub last_exit: i32,
    /// 1 when the node's telemetry is fresh (within 0.5 s).
    pub healthy: u32,
}

/// Daemon states in [`DaemonStatusMsg::state`].
pub mod daemon_state {
    /// Starting the nodes.
    pub const STARTING: u32 = 0;
    /// Every node running and healthy.
    pub const RUNNING: u32 = 1;
    /// A node is down or not healthy.
    pub const DEGRADED: u32 = 2;
    /// Stopping.
    pub const STOPPING: u32 = 3;
    /// A fault stopped the cell ([`DaemonStatusMsg::fault`] says which, `fault_since_ns` since when): the
    /// arm is brought to rest and held until the cell is resumed.
    pub const SAFE_STOP: u32 = 4;
}

/// vservod → anyone (10 Hz): the nodes as the supervisor sees them.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::DaemonStatus")]
#[repr(C)]
pub struct DaemonStatusMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`daemon_state`].
    pub state: u32,
    /// CLOCK_MONOTONIC (ns) when published.
    pub stamp_ns: u64,
    /// Since the daemon started (ns).
    pub uptime_ns: u64,
    /// Gains version in use.
    pub gains_version: u64,
    /// Indexed by [`NodeRole`] number.
    pub nodes: [NodeStatusMsg; 4],
    /// Joint states per second of wall time over the last second (the driver's rate when on time).
    pub tick_rate_hz: f64,
    /// The servo's latest RMS feature error (px); NaN before the first frame.
    pub feature_error_px: f64,
    /// The daemon's process id.
    pub pid: u32,
    /// [`robot_state`]: whether the robot driver's joint states arrive.
    pub robot: u32,
    /// The [`fault`] that holds the cell in a safe stop, or the last one (0: none since the start).
    pub fault: u32,
    /// The joints the fault concerns (bit j: joint j + 1), or 0.
    pub fault_joints: u32,
    /// CLOCK_MONOTONIC (ns) when the fault was found; 0 when none.
    pub fault_since_ns: u64,
    /// Safe stops since the daemon started.
    pub safe_stops: u64,
}

/// Faults that end in a safe stop ([`DaemonStatusMsg::fault`], [`CellModeMsg::fault`]).
pub mod fault {
    /// None.
    pub const NONE: u32 = 0;
    /// A joint beyond its position range (`fault_joints` says which).
    pub const POSITION_LIMIT: u32 = 1;
    /// A joint faster than its velocity limit.
    pub const VELOCITY_LIMIT: u32 = 2;
    /// A joint's torque cut to its limit for longer than `faults.saturation_s`.
    pub const TORQUE_SATURATED: u32 = 3;
    /// The robot driver reports a fault (`driver_status` FAULT, or the driver-failed bit).
    pub const DRIVER_FAULT: u32 = 4;
    /// Marks missing (the servo could not servo) for longer than `faults.target_lost_s`.
    pub const TARGET_LOST: u32 = 5;
    /// An external robot driver's joint states stopped for longer than its deadline.
    pub const ROBOT_STALLED: u32 = 6;
    /// A safe stop asked for by a client (`vservoctl safe-stop`).
    pub const REQUESTED: u32 = 7;

    /// The fault's name, as the status and the logs write it.
    pub fn name(code: u32) -> &'static str {
        match code {
            NONE => "none",
            POSITION_LIMIT => "position_limit",
            VELOCITY_LIMIT => "velocity_limit",
            TORQUE_SATURATED => "torque_saturated",
            DRIVER_FAULT => "driver_fault",
            TARGET_LOST => "target_lost",
            ROBOT_STALLED => "robot_stalled",
            REQUESTED => "requested",
            _ => "unknown",
        }
    }
}

/// Modes of [`CellModeMsg::mode`].
pub mod cell_mode {
    /// The servo's twists move the arm.
    pub const SERVOING: u32 = 0;
    /// Safe stop: the servo sends zero twists, the rmrc ramps the reference to rest at its acceleration
    /// limits and holds it there, whatever twist arrives.
    pub const SAFE_STOP: u32 = 1;
}

/// vservod → rmrc, servo (history 1, on each change): whether the cell servos or is held in a safe stop.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::CellMode")]
#[repr(C)]
pub struct CellModeMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`cell_mode`].
    pub mode: u32,
    /// Counts the changes (1 for the first, at the daemon's start); a node takes only a newer one.
    pub sequence: u64,
    /// SAFE_STOP: the [`fault`] that caused it.
    pub fault: u32,
    /// SAFE_STOP: the joints concerned (bit j: joint j + 1).
    pub fault_joints: u32,
    /// CLOCK_MONOTONIC (ns) when the mode was decided.
    pub stamp_ns: u64,
    /// The daemon's seal ([`crate::seal`]): the nodes take a mode with a valid seal only.
    pub seal: u64,
}

/// States of the robot driver as the daemon sees it ([`DaemonStatusMsg::robot`]).
pub mod robot_state {
    /// No joint state yet.
    pub const WAITING: u32 = 0;
    /// Joint states arrive within their deadline.
    pub const RUNNING: u32 = 1;
    /// No joint state for longer than the deadline: the driver stalled or is gone; no motion is commanded.
    pub const STALLED: u32 = 2;
}

/// Kinds of [`CommandMsg::kind`].
pub mod command_kind {
    /// A new target: `features_px` becomes ξ_d.
    pub const TARGET_FEATURES: u32 = 1;
    /// A new target: the camera's desired pose relative to the board (`translation_m`, `rotation_rpy_rad`
    /// give camera_from_board); ξ_d and the depths follow from it.
    pub const TARGET_POSE: u32 = 2;
    /// A new target: the features and pose the camera has now.
    pub const TARGET_TEACH: u32 = 3;
    /// The simulated board stops where it is.
    pub const OBJECT_HOLD: u32 = 4;
    /// The simulated board jumps by `translation_m` (desired camera frame) now.
    pub const OBJECT_STEP: u32 = 5;
    /// The simulated board moves on a circle of `radius_m` at `rev_per_min` in the desired camera frame's y–z
    /// plane, starting where it is.
    pub const OBJECT_CIRCLE: u32 = 6;
    /// Reload the configuration file (as SIGHUP does).
    pub const RELOAD: u32 = 7;
    /// Resume servoing after a safe stop (refused, saying why, while the fault's cause is still there).
    pub const RESUME: u32 = 8;
    /// Bring the arm to rest and hold it: a safe stop asked for by the client (fault `requested`).
    pub const SAFE_STOP: u32 = 9;
}

/// client → vservod (request-response service `command`): one command.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::Command")]
#[repr(C)]
pub struct CommandMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`command_kind`].
    pub kind: u32,
    /// Chosen by the client; the reply carries it back.
    pub id: u64,
    /// TARGET_FEATURES: ξ_d (px).
    pub features_px: [f64; FEATURES],
    /// TARGET_POSE: the board's position in the desired camera frame (m); OBJECT_STEP: the jump (m).
    pub translation_m: [f64; 3],
    /// TARGET_POSE: the board's orientation in the desired camera frame, roll–pitch–yaw (rad),
    /// R = Rz(yaw)·Ry(pitch)·Rx(roll).
    pub rotation_rpy_rad: [f64; 3],
    /// OBJECT_CIRCLE: radius (m).
    pub radius_m: f64,
    /// OBJECT_CIRCLE: speed (revolutions per minute).
    pub rev_per_min: f64,
}

impl CommandMsg {
    /// A command of `kind` with every parameter zero.
    pub fn new(kind: u32, id: u64) -> Self {
        Self {
            schema: SCHEMA_VERSION,
            kind,
            id,
            features_px: [0.0; FEATURES],
            translation_m: [0.0; 3],
            rotation_rpy_rad: [0.0; 3],
            radius_m: 0.0,
            rev_per_min: 0.0,
        }
    }
}

/// Room for the reason text of a reply (bytes).
pub const REASON_BYTES: usize = 256;

/// vservod → client: the answer to a [`CommandMsg`].
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::CommandReply")]
#[repr(C)]
pub struct CommandReplyMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// 1 accepted, 0 refused.
    pub accepted: u32,
    /// The command's `id`.
    pub id: u64,
    /// The gains version in force after the command.
    pub gains_version: u64,
    /// ξ_d in force after the command (px).
    pub target_features_px: [f64; FEATURES],
    /// Why it was refused, or what was done: UTF-8, zero-padded.
    pub reason: [u8; REASON_BYTES],
}

impl CommandReplyMsg {
    /// A reply with `reason` (cut at a character boundary to fit).
    pub fn new(id: u64, accepted: bool, gains_version: u64, target: [f64; FEATURES], reason: &str) -> Self {
        let mut bytes = [0u8; REASON_BYTES];
        let mut end = reason.len().min(REASON_BYTES);
        while !reason.is_char_boundary(end) {
            end -= 1;
        }
        bytes[..end].copy_from_slice(&reason.as_bytes()[..end]);
        Self {
            schema: SCHEMA_VERSION,
            accepted: u32::from(accepted),
            id,
            gains_version,
            target_features_px: target,
            reason: bytes,
        }
    }

    /// The reason as text (up to the first zero byte; invalid UTF-8 replaced).
    pub fn reason(&self) -> String {
        let end = self.reason.iter().position(|b| *b == 0).unwrap_or(REASON_BYTES);
        String::from_utf8_lossy(&self.reason[..end]).into_owned()
    }
}

/// Most past-command gains a [`GainsMsg`] carries.
pub const MAX_PAST_GAINS: usize = 4;

/// vservod → servo (history 1): the gains to swap in at the next frame, designed off the hot path.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::Gains")]
#[repr(C)]
pub struct GainsMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// How many of `past_input_gains` the law uses.
    pub used_past_gains: u32,
    /// The version (1 at start, +1 per accepted reload or target).
    pub version: u64,
    /// K_ξ, 6×8 row-major (m/s and rad/s per px).
    pub feature_gain: [f64; 48],
    /// K_j on the command sent j + 1 frames ago, each 6×6 row-major.
    pub past_input_gains: [f64; 36 * MAX_PAST_GAINS],
    /// ξ_d (px).
    pub desired_features_px: [f64; FEATURES],
    /// Z_d, the marks' depths at the desired pose (m).
    pub desired_depths_m: [f64; MARKS],
    /// Q, 8×8 row-major: the servo designs the gains on three marks and a scheduled gain from it.
    pub q: [f64; FEATURES * FEATURES],
    /// R in SI units, 6×6 row-major.
    pub r_si: [f64; 36],
    /// `controller.interaction`: 0 desired, 1 mean, 2 current.
    pub interaction: u32,
    /// `controller.feedforward`: 1 on, 0 off.
    pub feedforward: u32,
    /// `controller.border_margin_px` (0: no barrier).
    pub border_margin_px: f64,
    /// The daemon's seal ([`crate::seal`]): a servo takes gains with a valid seal only.
    pub seal: u64,
}

/// vservod → plant (history 1): how the simulated board moves from now on.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("vservo::Object")]
#[repr(C)]
pub struct ObjectMsg {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    /// [`command_kind`]: OBJECT_HOLD, OBJECT_STEP or OBJECT_CIRCLE.
    pub kind: u32,
    /// Counts the commands (1 for the first).
    pub sequence: u64,
    /// OBJECT_STEP: the jump in the desired camera frame (m).
    pub translation_m: [f64; 3],
    /// OBJECT_CIRCLE: radius (m).
    pub radius_m: f64,
    /// OBJECT_CIRCLE: speed (rev/min).
    pub rev_per_min: f64,
    /// The daemon's seal ([`crate::seal`]): the plant takes object commands with a valid seal only.
    pub seal: u64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    // the layout docs/PROTOCOL.md documents; a change here must change the document and SCHEMA_VERSION
    #[test]
    fn layouts_are_the_documented_ones() {
        assert_eq!(size_of::<JointStateMsg>(), 48 + 3 * 48 + 8);
        assert_eq!(offset_of!(JointStateMsg, tick), 8);
        assert_eq!(offset_of!(JointStateMsg, q_rad), 48);
        assert_eq!(offset_of!(JointStateMsg, applied_command_tick), 192);
        assert_eq!(size_of::<JointCommandMsg>(), 40 + 3 * 48 + 24 + 8);
        assert_eq!(offset_of!(JointCommandMsg, torque_nm), 40);
        assert_eq!(offset_of!(JointCommandMsg, twist_capture_tick), 184);
        assert_eq!(offset_of!(JointCommandMsg, seal), 208);
        assert_eq!(size_of::<SimWorldMsg>(), 16 + 96);
        assert_eq!(size_of::<CameraImageHeader>(), 40);
        assert_eq!(size_of::<FeaturesMsg>(), 40 + 64 + 8 + 96);
        assert_eq!(offset_of!(FeaturesMsg, features_px), 40);
        assert_eq!(offset_of!(FeaturesMsg, mark_status), 104);
        assert_eq!(size_of::<CameraTwistMsg>(), 40 + 48 + 8 + 8);
        assert_eq!(offset_of!(CameraTwistMsg, twist), 40);
        assert_eq!(offset_of!(CameraTwistMsg, feature_error_px), 88);
        assert_eq!(size_of::<TimingMsg>(), 40);
        assert_eq!(offset_of!(TelemetryMsg, wake_latency), 80);
        assert_eq!(offset_of!(TelemetryMsg, feature_error_px), 280);
        assert_eq!(size_of::<TelemetryMsg>(), 296);
        assert_eq!(size_of::<NodeStatusMsg>(), 32);
        assert_eq!(offset_of!(DaemonStatusMsg, nodes), 32);
        assert_eq!(offset_of!(DaemonStatusMsg, tick_rate_hz), 160);
        assert_eq!(size_of::<DaemonStatusMsg>(), 32 + 4 * 32 + 16 + 8 + 24);
        assert_eq!(size_of::<CellModeMsg>(), 40);
        assert_eq!(size_of::<CommandMsg>(), 16 + 64 + 48 + 16);
        assert_eq!(size_of::<CommandReplyMsg>(), 24 + 64 + REASON_BYTES);
        assert_eq!(offset_of!(GainsMsg, feature_gain), 16);
        assert_eq!(size_of::<ObjectMsg>(), 16 + 24 + 16 + 8);
    }

    #[test]
    fn a_reason_is_cut_at_a_character_boundary_and_read_back() {
        let long = "é".repeat(REASON_BYTES);
        let reply = CommandReplyMsg::new(7, false, 1, [0.0; FEATURES], &long);
        assert_eq!(reply.reason(), "é".repeat(REASON_BYTES / 2));
        assert_eq!(CommandReplyMsg::new(7, true, 1, [0.0; FEATURES], "ok").reason(), "ok");
    }

    #[test]
    fn roles_round_trip_through_names_and_numbers() {
        for role in NodeRole::ALL {
            assert_eq!(NodeRole::from_name(role.name()), Some(role));
            assert_eq!(NodeRole::from_index(role as u32), Some(role));
        }
        assert_eq!(NodeRole::from_name("camera"), None);
    }
}
