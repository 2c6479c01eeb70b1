//! The payloads: `#[repr(C)]`, fixed size, no pointers, each starting with the schema version.
//!
//! Field order is chosen so that no padding is needed: 8-byte fields first, then 4-byte, then bytes.
//! Each is declared once ([`wire_message!`](crate::declare)): docs/PROTOCOL.md's tables, the JSON view,
//! `Default`, the schema check and the seal's bytes all come from that declaration.

use crate::codes::*;
use crate::declare::wire_message;
use iceoryx2::prelude::ZeroCopySend;

/// The schema version every payload carries in its first four bytes. Bumped on any layout change.
/// 2: `joint_state` carries the robot only (the board's pose moved to `sim_world`), the driver declares its
/// command interface and period; `joint_torque` became `joint_command`; `camera_image` added.
/// 6: `features` and `camera_twist` carry the seal of the node that made them; `gains` and `object` a stamp.
/// 7: `joint_state` and `joint_command` carry up to seven joints and say how many (`joint_count`).
/// 9: `joint_state.driver_error` (was reserved) and `status.driver_error`: the robot's own reason for a driver fault.
/// 10: the fault `supervision_stalled` (11); `cell_mode` is also a heartbeat, at least every 100 ms, and announces
/// each node's process (`writers`), which `features` and `camera_twist` carry (`writer_pid`).
/// 12: `features` carries how each mark was measured (`refined_mask`, a tag's `edge_rms_px`, `decision_margin`,
/// `bits_corrected`); `camera_image`'s header the exposure and gain the camera reports; `cell_mode` and `status`
/// the dynamics override (`speed_scale`), which the command `speed` sets.
/// 13: `features` says which tags of the target gave the marks (`tags_used_mask`, where `bits_corrected` was a u32:
/// both are u16 now), for a target of several tags (a bundle).
/// 14: the collision guard: `joint_command.guard` (where `reserved` was), the fault `collision` (12), and
/// `status.clearance_m` and `clearance_between` at the end.
pub const SCHEMA_VERSION: u32 = 14;

/// Joints `joint_state` and `joint_command` have room for: the arm's joints come first, the slots past
/// `joint_count` are zero.
pub const MAX_JOINTS: usize = 7;
/// Image features (x, y of four marks).
pub const FEATURES: usize = 8;
/// Marks.
pub const MARKS: usize = 4;

wire_message! {
    /// robot driver → rmrc, vision, vservod (every driver period): the arm's measured state. The robot only:
    /// nothing here is known only to a simulation.
    payload JointStateMsg = "vservo::JointState" {
        /// schema version
        schema: u32,
        /// bits 0–6 position limit (joint 1–7), 8–14 velocity limit, 16–22 torque saturated, 24 driver failed
        faults: u32,
        /// driver periods since the driver started
        tick: u64,
        /// CLOCK_MONOTONIC when `q` was measured (ns)
        stamp_ns: u64,
        /// changes each time the driver starts: a consumer that sees a new one re-synchronises
        driver_epoch: u64,
        /// the driver's period (ns): a joint state comes this often
        period_ns: u64,
        /// the command the driver takes
        command_mode: u32 as CommandMode,
        /// the driver's state (holding: no valid command in time)
        driver_status: u32 as DriverStatus,
        /// the arm's joints (6 or 7): the first `joint_count` entries of the arrays below are theirs, from the base
        /// outwards; it must be the configured arm's
        joint_count: u32 = 6,
        /// with `driver_status` fault, why: the robot's own error where the driver knows it (`DriverError`: 0 none,
        /// 1 the period check, 1000 + i the Franka's error flag i; docs/PROTOCOL.md, "Driver errors")
        driver_error: u32,
        /// joint angles (rad)
        q_rad: [f64; MAX_JOINTS],
        /// joint velocities (rad/s)
        qd_rad_s: [f64; MAX_JOINTS],
        /// joint torques, measured or applied (N·m); NaN where unknown
        torque_nm: [f64; MAX_JOINTS],
        /// the `answers_tick` of the command applied over the period that ended here (`tick − 1` for a driver
        /// that applies each answer over the next period, older if it kept an earlier one or its arm answers
        /// later); 2⁶⁴−1 if none (holding)
        applied_command_tick: u64 = u64::MAX,
    }
}

impl JointStateMsg {
    /// The joint angles of an arm of `joint_count` joints: the first `joint_count` slots of `q_rad`, the others
    /// zero, if the state says it is of such an arm (`joint_count`); `None` for another arm's.
    pub fn arm_q_rad(&self, joint_count: usize) -> Option<[f64; MAX_JOINTS]> {
        (self.joint_count as usize == joint_count)
            .then(|| std::array::from_fn(|j| if j < joint_count { self.q_rad[j] } else { 0.0 }))
    }
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
    /// The per-joint bits of one kind, before their shift.
    pub const JOINT_MASK: u32 = (1 << super::MAX_JOINTS) - 1;

    /// The joints (bit j: joint j + 1) whose bit of the kind at `shift` is set in `faults`.
    pub fn joints(faults: u32, shift: u32) -> u32 {
        (faults >> shift) & JOINT_MASK
    }
}

wire_message! {
    /// rmrc → robot driver (in answer to each joint state): the command for the driver's next period, in the
    /// interface the driver declared. Every field is filled whatever the mode (torque zero where not computed).
    payload JointCommandMsg = "vservo::JointCommand" {
        /// schema version
        schema: u32,
        /// the driver's declared `command_mode`
        mode: u32 as CommandMode,
        /// the arm's joints (the configured arm's, as in the joint state answered)
        joint_count: u32 = 6,
        /// the collision guard (`[collision]`; 0 without one): bit 0 it slows the motion, bit 1 it holds the arm
        /// (a `collision` stop, until the cell resumes); bits 2–31 which distance (`guard_bits`)
        guard: u32,
        /// the `tick` of the joint state this answers
        answers_tick: u64,
        /// that joint state's `driver_epoch`
        driver_epoch: u64,
        /// that joint state's `stamp_ns`
        state_stamp_ns: u64,
        /// CLOCK_MONOTONIC as the command is sent (ns)
        stamp_ns: u64,
        /// joint torques (N·m); mode 0 only, else zero
        torque_nm: [f64; MAX_JOINTS],
        /// joint reference q_d at the end of the next period (rad)
        q_ref_rad: [f64; MAX_JOINTS],
        /// joint reference velocity q̇_d over the next period (rad/s)
        qd_ref_rad_s: [f64; MAX_JOINTS],
        /// the `capture_tick` of the `camera_twist` this command follows (2⁶⁴−1 before the first);
        /// `answers_tick − twist_capture_tick` is the camera-to-actuation latency in ticks
        twist_capture_tick: u64 = u64::MAX,
        /// the joint-state tick at which the rmrc took that twist in (2⁶⁴−1 before the first)
        twist_applied_tick: u64 = u64::MAX,
        /// the joint-state tick from which the rmrc's reference runs: where it last started at rest from the
        /// measured joints (the first state, a new driver epoch, a driver back after a gap)
        reference_since_tick: u64,
        /// the rmrc's seal under the run's key: the simulated driver applies sealed commands only; an
        /// external driver ignores it
        seal: u64,
    }
}

wire_message! {
    /// simulated plant → simulated camera (every tick; simulation only): what only a simulation knows.
    payload SimWorldMsg = "vservo::SimWorld" {
        /// schema version
        schema: u32,
        /// zero
        reserved: u32,
        /// the plant tick (as in `joint_state`)
        tick: u64,
        /// the board's pose in the base frame, 3×4 [R \| t] row-major (t in m)
        base_from_board: [f64; 12],
    }
}

/// The largest image `camera_image` carries (bytes): 1280 × 1024 pixels of 8 bits.
pub const MAX_IMAGE_BYTES: usize = 1280 * 1024;

wire_message! {
    /// camera driver → vision (each frame): the user header of a `camera_image` sample, whose payload is the
    /// image as a slice of `u8`, rows top to bottom, `stride_bytes` apart.
    payload CameraImageHeader = "vservo::CameraImageHeader" {
        /// schema version
        schema: u32,
        /// the pixel format
        format: u32 as PixelFormat,
        /// pixels per row
        width: u32,
        /// rows
        height: u32,
        /// bytes from one row's start to the next (≥ width); the payload holds height × stride bytes
        stride_bytes: u32,
        /// zero
        reserved: u32,
        /// the camera's frame counter, from 0
        frame: u64,
        /// CLOCK_MONOTONIC when the image was exposed (ns)
        capture_stamp_ns: u64,
        /// how long the shutter was open, as the camera reports it (µs); NaN when it does not say
        exposure_us: f64 = f64::NAN,
        /// the sensor's gain, as the camera reports it (dB); NaN when it does not say
        gain_db: f64 = f64::NAN,
    }
}

wire_message! {
    /// vision → servo (every frame): the features of the frame leaving the image pipeline.
    payload FeaturesMsg = "vservo::Features" {
        /// schema version
        schema: u32,
        /// bit m set when mark m is valid
        valid_mask: u32,
        /// frame number (counted by the vision node from its start)
        frame: u64,
        /// tick of the latest joint state when the image was taken
        capture_tick: u64,
        /// CLOCK_MONOTONIC when the image was taken (ns)
        capture_stamp_ns: u64,
        /// CLOCK_MONOTONIC at publication, the pipeline delay later (ns)
        stamp_ns: u64,
        /// ξ = [x₁ y₁ … x₄ y₄] (px, origin top-left), NaN where a mark is not valid
        features_px: [f64; FEATURES] = [f64::NAN; FEATURES],
        /// per mark
        mark_status: [u8; MARKS] as MarkStatus,
        /// the vision node's process id: its run, which the daemon announces in `cell_mode.writers` (sealed: a
        /// feature vector of an earlier run of the node is refused)
        writer_pid: u32,
        /// the camera's pose in the robot's base frame at capture (the joint state of `capture_tick`; for an
        /// external camera the joint states around `capture_stamp_ns`, interpolated); a camera fixed in the world
        /// (`camera.mount = "world"`): in the tool frame, which holds the board still: the top 3 rows of the
        /// 4×4 transform, row-major; NaN when not known
        base_from_camera: [f64; 12] = [f64::NAN; 12],
        /// an AprilTag target: per edge k of the tag (corner k to corner k + 1), the RMS of its fit (px), NaN
        /// where the edge could not be measured (its corners are then the decoder's); NaN for disc marks
        edge_rms_px: [f64; MARKS] = [f64::NAN; MARKS],
        /// an AprilTag target: the decoder's decision margin (larger is surer); NaN for disc marks or no tag
        decision_margin: f64 = f64::NAN,
        /// bit m set when mark m's position is vservo's own sub-pixel measurement (a disc's centre, a tag
        /// corner refined on both its edges); clear where it is the tag decoder's corner, or not valid
        refined_mask: u32,
        /// an AprilTag target: the bits of the code the decoder corrected (a bundle: the most of any of its tags
        /// used); 0 for disc marks
        bits_corrected: u16,
        /// the tags that gave the marks: a bundle's, bit k for its tag k (the others hidden, out of view or
        /// refused); 1 for a single tag found; 0 for disc marks or no tag
        tags_used_mask: u16,
        /// the vision node's seal under the run's key: the servo (and the daemon) take sealed features only
        seal: u64,
    }
}

wire_message! {
    /// servo → rmrc (every frame): the camera twist.
    payload CameraTwistMsg = "vservo::CameraTwist" {
        /// schema version
        schema: u32,
        /// what the servo did (waiting: no frame yet; marks missing: nowhere to go back to; safe stop: held by
        /// the daemon; reacquiring: steering back to where all marks were last seen); servoing, servoing on
        /// three marks and reacquiring come with a twist to follow, the others with a zero twist
        verdict: u32 as Verdict,
        /// the frame the twist was computed from
        frame: u64,
        /// its capture tick
        capture_tick: u64,
        /// version of the gains used (1 at start)
        gains_version: u64,
        /// CLOCK_MONOTONIC at publication (ns)
        stamp_ns: u64,
        /// u = [v_x v_y v_z ω_x ω_y ω_z] in the camera frame (m/s, rad/s)
        twist: [f64; 6],
        /// RMS of ξ − ξ_d over the valid features (px); NaN when none
        feature_error_px: f64 = f64::NAN,
        /// bit m set when mark m was missing
        missing_mask: u32,
        /// what the law did beyond its design: 1 the border barrier changed the twist, 2 the frame's own
        /// design failed and the fixed gain was used, 4 the target's motion was fed forward, 8 the twist's
        /// change was cut to what the arm follows within the frame; 0 unless the law computed the twist
        law_flags: u32,
        /// the servo's process id: its run, which the daemon announces in `cell_mode.writers` (sealed: a twist
        /// of an earlier run of the servo is refused)
        writer_pid: u32,
        /// zero
        reserved: u32,
        /// the servo's seal under the run's key: the rmrc (and the daemon) take sealed twists only
        seal: u64,
    }
}

/// The bits of [`CameraTwistMsg::law_flags`].
pub mod law_flag {
    /// The border barrier (`controller.border_margin_px`) changed the twist to keep a mark inside.
    pub const BARRIER: u32 = 1;
    /// The frame's own design (a scheduled `controller.interaction`) failed, or a pose-based law found no pose,
    /// on a degenerate image: the fixed gain for its marks was used.
    pub const FIXED_GAIN_FALLBACK: u32 = 2;
    /// The target's estimated image motion was fed forward (`controller.feedforward`, once the estimate has
    /// settled).
    pub const FEEDFORWARD: u32 = 4;
    /// The twist's change was cut to what the arm's reference follows within the frame (an arm with jerk
    /// limits), or the twist slowed so that the arm can still stop before the goal.
    pub const RATE_LIMITED: u32 = 8;
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

    /// The legend docs/PROTOCOL.md prints: "0 plant, 1 vision, …".
    pub fn legend() -> String {
        let mut roles = Self::ALL;
        roles.sort();
        roles.iter().map(|role| format!("{} {}", *role as u32, role.name())).collect::<Vec<_>>().join(", ")
    }
}

wire_message! {
    /// Percentiles of one timing over a telemetry window (ns; zero when the window had no samples).
    part TimingMsg = "vservo::Timing" {
        /// samples in the window
        count: u64,
        /// median (ns)
        p50_ns: u64,
        /// 99th percentile (ns)
        p99_ns: u64,
        /// 99.9th percentile (ns)
        p999_ns: u64,
        /// largest (ns)
        max_ns: u64,
    }
}

wire_message! {
    /// every node → anyone (10 Hz): loop timing over the last window and counters since the node started.
    payload TelemetryMsg = "vservo::Telemetry" {
        /// schema version
        schema: u32,
        /// the node
        node: u32 as NodeRole,
        /// CLOCK_MONOTONIC at publication (ns)
        stamp_ns: u64,
        /// length of the window the timings cover (ns)
        window_ns: u64,
        /// loop cycles since the node started
        cycles: u64,
        /// cycles a period or more late (event-driven nodes: answer later than one period)
        overruns: u64,
        /// periods skipped after stalls (not replayed)
        skipped_periods: u64,
        /// plant: ticks whose rmrc answer came late (previous command's reference followed)
        late_answers: u64,
        /// input messages refused (schema, epoch, tick, not finite; the vision node counts its images and the
        /// joint states it reads for the camera's pose)
        rejected_messages: u64,
        /// servo: gains version in use; else 0
        gains_version: u64,
        /// plant: tick; vision, servo: frame; rmrc: tick answered
        progress: u64,
        /// wake-up after the deadline (periodic nodes) or after the input was sent (event-driven)
        wake_latency: TimingMsg,
        /// wake-up to output
        execution: TimingMsg,
        /// plant: joint state published → the rmrc's answer in the plant's queue
        round_trip: TimingMsg,
        /// vision: between the capture stamps of successive images
        frame_period: TimingMsg,
        /// servo: an image's capture → the twist computed from it
        capture_latency: TimingMsg,
        /// servo: RMS feature error of the latest frame (px); else NaN
        feature_error_px: f64 = f64::NAN,
        /// process id
        pid: u32,
        /// plant: 1 while holding the arm; servo: the last verdict; else 0
        mode: u32,
    }
}

wire_message! {
    /// One node as the daemon sees it.
    part NodeStatusMsg = "vservo::NodeStatus" {
        /// restarts since the daemon started
        restarts: u64,
        /// CLOCK_MONOTONIC of the node's latest telemetry (0: none yet)
        last_telemetry_ns: u64,
        /// the node's state (backing off: restart pending; hung: being killed, then restarted)
        state: u32 as NodeState,
        /// process id (0 when not running)
        pid: u32,
        /// exit status of the last run; a signal as its negated number
        last_exit: i32,
        /// 1 when the node's telemetry is fresh (under 0.5 s old)
        healthy: u32,
    }
}

wire_message! {
    /// vservod → anyone (10 Hz): the nodes as the supervisor sees them.
    payload DaemonStatusMsg = "vservo::DaemonStatus" {
        /// schema version
        schema: u32,
        /// the daemon's state (safe-stop: a fault holds the arm at rest)
        state: u32 as DaemonState,
        /// CLOCK_MONOTONIC at publication (ns)
        stamp_ns: u64,
        /// since the daemon started (ns)
        uptime_ns: u64,
        /// gains version in use
        gains_version: u64,
        /// indexed by node number (0 plant, 1 vision, 2 servo, 3 rmrc)
        nodes: [NodeStatusMsg; 4],
        /// joint states per wall-clock second over the last second
        tick_rate_hz: f64,
        /// the servo's latest RMS feature error (px); NaN before the first frame
        feature_error_px: f64 = f64::NAN,
        /// the daemon's process id
        pid: u32,
        /// the robot driver (running: joint states on time; stalled: none within the deadline)
        robot: u32 as RobotState,
        /// the fault holding the cell (state safe-stop), or the last one
        fault: u32 as Fault,
        /// bit j: the fault concerns joint j + 1
        fault_joints: u32,
        /// CLOCK_MONOTONIC when the fault was found (ns); 0 when none
        fault_since_ns: u64,
        /// safe stops since the daemon started
        safe_stops: u64,
        /// with `fault` driver_fault: the driver's reason (`DriverError`, as in `joint_state.driver_error`)
        driver_error: u32,
        /// zero
        reserved: u32,
        /// the dynamics override in force (0–1]: the share of the joints' speed, acceleration and jerk limits
        /// and of the tool's caps the reference keeps
        speed_scale: f64 = 1.0,
        /// the collision guard: the nearest checked distance, the rmrc's reference as it stands (m; negative:
        /// an overlap); NaN without a guard or with nothing within 1 m
        clearance_m: f64 = f64::NAN,
        /// between what: the two names (a link, `camera`, an obstacle, `workspace`) joined by " – ", UTF-8,
        /// zero-padded
        clearance_between: [u8; CLEARANCE_NAME_BYTES],
    }
}

/// How long `status.clearance_between` is (bytes).
pub const CLEARANCE_NAME_BYTES: usize = 64;

pub mod guard_bits;

wire_message! {
    /// vservod → rmrc, servo (history 1, on each change): whether the cell servos or is held in a safe stop.
    payload CellModeMsg = "vservo::CellMode" {
        /// schema version
        schema: u32,
        /// whether the cell servos (in a safe stop the rmrc ramps the reference to rest and holds it, and the
        /// servo sends zero twists)
        mode: u32 as CellMode,
        /// counts the changes (1 at the daemon's start); only a newer one is taken
        sequence: u64,
        /// safe stop: the fault that caused it (as in `status`)
        fault: u32 as Fault,
        /// safe stop: bit j, joint j + 1 concerned
        fault_joints: u32,
        /// moving: the share of each joint's speed limit it may move at (0–1]
        speed_fraction: f64,
        /// the dynamics override in force, in every mode (0–1]: the rmrc keeps this share of the joints' speed,
        /// acceleration and jerk limits and of the tool's caps on every path
        speed_scale: f64 = 1.0,
        /// moving: the joints' goal (rad; the slots past the arm's joints zero)
        goal_rad: [f64; MAX_JOINTS],
        /// the process id of each node the daemon started, by role (plant, vision, servo, rmrc; 0 while none
        /// runs): the writer whose sealed messages a consumer takes, and the run they must carry
        writers: [u32; 4],
        /// CLOCK_MONOTONIC when decided (ns)
        stamp_ns: u64,
        /// the daemon's seal (SipHash-2-4 of the fields under the run's key): other modes are refused
        seal: u64,
    }
}

wire_message! {
    /// client → vservod (request-response service `command`): one command.
    payload CommandMsg = "vservo::Command" {
        /// schema version
        schema: u32,
        /// what the client asks
        kind: u32 as CommandKind,
        /// chosen by the client; the reply carries it back
        id: u64,
        /// target features: ξ_d (px)
        features_px: [f64; FEATURES],
        /// target pose: the board's position in the desired camera frame (m); object step: the jump (m)
        translation_m: [f64; 3],
        /// target pose: the board's orientation in the desired camera frame, roll, pitch, yaw (rad),
        /// R = Rz·Ry·Rx
        rotation_rpy_rad: [f64; 3],
        /// object circle: radius (m)
        radius_m: f64,
        /// object circle: speed (rev/min)
        rev_per_min: f64,
        /// move joints: how many of `joints_rad` are given (the arm's joint count)
        joint_count: u32,
        /// speed: bit 0 raises the dynamics override while the cell moves (refused without it unless held);
        /// move joints: bit 1 ends a cell held by the user (`start_held`, `requested`) into the move
        flags: u32,
        /// move joints: the goal (rad; the slots past `joint_count` zero)
        joints_rad: [f64; MAX_JOINTS],
        /// move joints: the share of each joint's speed limit it may move at (0–1]; speed: the new dynamics
        /// override (0–1]
        speed_fraction: f64,
    }
}

/// `command.flags` of a `speed` command: raise the dynamics override while the cell moves.
pub const SPEED_WHILE_MOVING: u32 = 1;
/// `command.flags` of a `move_joints` command: a cell held by the user (`start_held`, `requested`) leaves its
/// stop into the move (the user's own first motion: a held cell's calibration).
pub const MOVE_OUT_OF_HOLD: u32 = 2;

impl CommandMsg {
    /// A command of `kind` with every parameter zero.
    pub fn new(kind: CommandKind, id: u64) -> Self {
        Self { kind: kind.into(), id, ..Self::default() }
    }
}

/// Room for the reason text of a reply (bytes).
pub const REASON_BYTES: usize = 256;

wire_message! {
    /// vservod → client: the answer to a [`CommandMsg`].
    payload CommandReplyMsg = "vservo::CommandReply" {
        /// schema version
        schema: u32,
        /// 1 accepted, 0 refused
        accepted: u32,
        /// the request's `id`
        id: u64,
        /// the gains version in force after the command
        gains_version: u64,
        /// ξ_d in force after the command (px)
        target_features_px: [f64; FEATURES],
        /// why it was refused, or what was done: UTF-8, zero-padded
        reason: [u8; REASON_BYTES],
    }
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
            accepted: u32::from(accepted),
            id,
            gains_version,
            target_features_px: target,
            reason: bytes,
            ..Self::default()
        }
    }

    /// The reason as text (up to the first zero byte; invalid UTF-8 replaced).
    pub fn reason(&self) -> String {
        let end = self.reason.iter().position(|b| *b == 0).unwrap_or(REASON_BYTES);
        String::from_utf8_lossy(&self.reason[..end]).into_owned()
    }
}

mod from_daemon;
pub use from_daemon::*;

#[cfg(test)]
mod tests;
