//! The TCP command channel's messages (`service_types.h` @ d96c221): a 12-byte header, then the request or
//! response body, packed little endian.
//!
//! A response echoes its request's `command` and `command_id`; its header's `size` is the whole frame's
//! length, which may exceed the v10 body (franka-sim sends Move/StopMove/AutomaticErrorRecovery responses
//! as 16 bytes where libfranka's struct has 13): read `size` bytes, use the known prefix, ignore the rest.

use super::{DecodeError, PROTOCOL_VERSION, Reader, Writer};

/// Bytes in the header: `command` u32 @0, `command_id` u32 @4, `size` u32 @8 (whole frame).
pub const HEADER_SIZE: usize = 12;

/// The largest response frame accepted (GetRobotModel's URDF is ~15 kB); larger is a protocol error.
pub const MAX_FRAME_SIZE: usize = 16 * 1024 * 1024;

/// Bytes in a Connect request: header, `version` u16 @12, `udp_port` u16 @14.
pub const CONNECT_REQUEST_SIZE: usize = 16;

/// Bytes in a Move request: header, then controller mode u32 @12, motion generator mode u32 @16, maximum
/// path deviation 3×f64 @20, maximum goal pose deviation 3×f64 @44, `use_async_motion_generator` bool @68,
/// `maximum_velocity` 7×f64 @69.
pub const MOVE_REQUEST_SIZE: usize = 125;

wire_enum! {
    /// `research_interface::robot::Command` (u32), v10 numbering.
    pub enum Command: u32 {
        /// Connect: version handshake and UDP port.
        Connect = 0 => "kConnect",
        /// Move: start a motion.
        Move = 1 => "kMove",
        /// StopMove: stop the running motion.
        StopMove = 2 => "kStopMove",
        /// SetCollisionBehavior.
        SetCollisionBehavior = 3 => "kSetCollisionBehavior",
        /// SetJointImpedance.
        SetJointImpedance = 4 => "kSetJointImpedance",
        /// SetCartesianImpedance.
        SetCartesianImpedance = 5 => "kSetCartesianImpedance",
        /// SetGuidingMode.
        SetGuidingMode = 6 => "kSetGuidingMode",
        /// SetEEToK.
        SetEEToK = 7 => "kSetEEToK",
        /// SetNEToEE.
        SetNEToEE = 8 => "kSetNEToEE",
        /// SetLoad.
        SetLoad = 9 => "kSetLoad",
        /// AutomaticErrorRecovery: clear a reflex.
        AutomaticErrorRecovery = 10 => "kAutomaticErrorRecovery",
        /// GetRobotModel: the URDF.
        GetRobotModel = 11 => "kGetRobotModel",
    }
}

wire_enum! {
    /// `Connect::Status` (u8).
    pub enum ConnectStatus: u8 {
        /// The server accepts the client's version.
        Success = 0 => "kSuccess",
        /// The server speaks another version (named in the response).
        IncompatibleLibraryVersion = 1 => "kIncompatibleLibraryVersion",
    }
}

wire_enum! {
    /// `Move::ControllerMode` (u32) of a Move request.
    pub enum MoveControllerMode: u32 {
        /// The robot's joint impedance controller (what joint-velocity motions use).
        JointImpedance = 0 => "kJointImpedance",
        /// The robot's Cartesian impedance controller.
        CartesianImpedance = 1 => "kCartesianImpedance",
        /// Torques from the client.
        ExternalController = 2 => "kExternalController",
    }
}

wire_enum! {
    /// `Move::MotionGeneratorMode` (u32) of a Move request (numbered without `kIdle`, unlike the state's).
    pub enum MoveMotionGeneratorMode: u32 {
        /// Joint positions.
        JointPosition = 0 => "kJointPosition",
        /// Joint velocities.
        JointVelocity = 1 => "kJointVelocity",
        /// Cartesian pose.
        CartesianPosition = 2 => "kCartesianPosition",
        /// Cartesian velocity.
        CartesianVelocity = 3 => "kCartesianVelocity",
        /// No motion generator (torque control only).
        None = 4 => "kNone",
    }
}

wire_enum! {
    /// `Move::Status` (u8), v10 numbering.
    pub enum MoveStatus: u8 {
        /// The motion ended as commanded (after `motion_generation_finished`).
        Success = 0 => "kSuccess",
        /// The motion started (the first response to a Move).
        MotionStarted = 1 => "kMotionStarted",
        /// Another Move or a StopMove ended it.
        Preempted = 2 => "kPreempted",
        /// A safety function ended it.
        PreemptedDueToActivatedSafetyFunctions = 3 => "kPreemptedDueToActivatedSafetyFunctions",
        /// Refused: a safety function is active.
        CommandRejectedDueToActivatedSafetyFunctions = 4 => "kCommandRejectedDueToActivatedSafetyFunctions",
        /// Refused: not possible in the current mode (e.g. Reflex).
        CommandNotPossibleRejected = 5 => "kCommandNotPossibleRejected",
        /// Refused: the start pose is singular.
        StartAtSingularPoseRejected = 6 => "kStartAtSingularPoseRejected",
        /// Refused: invalid argument.
        InvalidArgumentRejected = 7 => "kInvalidArgumentRejected",
        /// A reflex ended it (the state's errors say why).
        ReflexAborted = 8 => "kReflexAborted",
        /// The emergency stop ended it.
        EmergencyAborted = 9 => "kEmergencyAborted",
        /// Invalid input ended it.
        InputErrorAborted = 10 => "kInputErrorAborted",
        /// Ended for another reason.
        Aborted = 11 => "kAborted",
    }
}

wire_enum! {
    /// `StopMove::Status` (u8), v10 numbering.
    pub enum StopMoveStatus: u8 {
        /// Stopped.
        Success = 0 => "kSuccess",
        /// Refused: not possible in the current mode.
        CommandNotPossibleRejected = 1 => "kCommandNotPossibleRejected",
        /// Refused: a safety function is active.
        CommandRejectedDueToActivatedSafetyFunctions = 2 => "kCommandRejectedDueToActivatedSafetyFunctions",
        /// The emergency stop intervened.
        EmergencyAborted = 3 => "kEmergencyAborted",
        /// A reflex intervened.
        ReflexAborted = 4 => "kReflexAborted",
        /// Aborted for another reason.
        Aborted = 5 => "kAborted",
    }
}

wire_enum! {
    /// `AutomaticErrorRecovery::Status` (u8), v10 numbering.
    pub enum AutomaticErrorRecoveryStatus: u8 {
        /// Errors cleared; the robot is idle.
        Success = 0 => "kSuccess",
        /// Refused: not possible in the current mode.
        CommandNotPossibleRejected = 1 => "kCommandNotPossibleRejected",
        /// Refused: a safety function is active.
        CommandRejectedDueToActivatedSafetyFunctions = 2 => "kCommandRejectedDueToActivatedSafetyFunctions",
        /// Refused: the error needs a manual recovery (Desk).
        ManualErrorRecoveryRequiredRejected = 3 => "kManualErrorRecoveryRequiredRejected",
        /// A reflex intervened.
        ReflexAborted = 4 => "kReflexAborted",
        /// The emergency stop intervened.
        EmergencyAborted = 5 => "kEmergencyAborted",
        /// Aborted for another reason.
        Aborted = 6 => "kAborted",
    }
}

/// A frame header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// The command (a [`Command`] value; kept raw so an unknown one can be reported).
    pub command: u32,
    /// The request's id, echoed by its response(s).
    pub command_id: u32,
    /// Bytes in the whole frame, header included.
    pub size: u32,
}

impl Header {
    /// The header's 12 bytes.
    pub fn encode(&self) -> [u8; HEADER_SIZE] {
        let mut buf = [0u8; HEADER_SIZE];
        let mut w = Writer::new(&mut buf);
        w.put_at(0, &self.command.to_le_bytes());
        w.put_at(4, &self.command_id.to_le_bytes());
        w.put_at(8, &self.size.to_le_bytes());
        buf
    }

    /// Reads the header at the start of `bytes`; `Ok(None)` if fewer than 12 bytes are there yet, an error
    /// if its size is below 12 or above [`MAX_FRAME_SIZE`].
    pub fn peek(bytes: &[u8]) -> Result<Option<Header>, DecodeError> {
        if bytes.len() < HEADER_SIZE {
            return Ok(None);
        }
        let r = Reader::new(bytes, "TCP frame header");
        let header = Header {
            command: r.u32_at("command", 0)?,
            command_id: r.u32_at("command_id", 4)?,
            size: r.u32_at("size", 8)?,
        };
        let size = usize::try_from(header.size).unwrap_or(usize::MAX);
        if !(HEADER_SIZE..=MAX_FRAME_SIZE).contains(&size) {
            return Err(DecodeError::InvalidFrameSize {
                what: "TCP frame header",
                size: header.size,
                min: HEADER_SIZE,
                max: MAX_FRAME_SIZE,
            });
        }
        Ok(Some(header))
    }
}

/// A header-only request (StopMove, AutomaticErrorRecovery, GetRobotModel).
pub fn encode_empty_request(command: Command, command_id: u32) -> [u8; HEADER_SIZE] {
    Header { command: command.to_wire(), command_id, size: HEADER_SIZE as u32 }.encode()
}

/// The Connect request announcing [`PROTOCOL_VERSION`] and the client's UDP port.
pub fn encode_connect_request(command_id: u32, udp_port: u16) -> [u8; CONNECT_REQUEST_SIZE] {
    let mut buf = [0u8; CONNECT_REQUEST_SIZE];
    let header =
        Header { command: Command::Connect.to_wire(), command_id, size: CONNECT_REQUEST_SIZE as u32 };
    let mut w = Writer::new(&mut buf);
    w.put_at(0, &header.encode());
    w.put_at(12, &PROTOCOL_VERSION.to_le_bytes());
    w.put_at(14, &udp_port.to_le_bytes());
    buf
}

/// A Connect response body: status u8 @0, server version u16 @1 (after the header).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConnectResponse {
    /// Whether the server accepts the client's version.
    pub status: ConnectStatus,
    /// The server's protocol version.
    pub version: u16,
}

impl ConnectResponse {
    /// Decodes the body (the bytes after the header); extra trailing bytes are ignored.
    pub fn decode(body: &[u8]) -> Result<Self, DecodeError> {
        if body.len() < 3 {
            return Err(DecodeError::TooShort { what: "Connect response body", got: body.len(), needed: 3 });
        }
        let r = Reader::new(body, "Connect response body");
        let raw = r.u8_at("status", 0)?;
        let status = ConnectStatus::from_wire(raw).ok_or(DecodeError::UnknownValue {
            what: "Connect response body",
            field: "status",
            offset: HEADER_SIZE,
            value: u64::from(raw),
        })?;
        Ok(ConnectResponse { status, version: r.u16_at("version", 1)? })
    }
}

/// Decodes the leading status byte of a response body with `from_wire`; `what` names the response.
pub fn decode_status<T>(
    body: &[u8],
    what: &'static str,
    from_wire: fn(u8) -> Option<T>,
) -> Result<T, DecodeError> {
    let raw = Reader::new(body, what).u8_at("status", 0).map_err(|_| DecodeError::TooShort {
        what,
        got: body.len(),
        needed: 1,
    })?;
    from_wire(raw).ok_or(DecodeError::UnknownValue {
        what,
        field: "status",
        offset: HEADER_SIZE,
        value: u64::from(raw),
    })
}

/// Maximum deviations a Move allows (`Move::Deviation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    /// Translation, m.
    pub translation_m: f64,
    /// Rotation, rad.
    pub rotation_rad: f64,
    /// Elbow, rad.
    pub elbow_rad: f64,
}

impl Deviation {
    /// libfranka's `ControlLoop::kDefaultDeviation`: {10 m, 3.12 rad, 2π rad}.
    pub const LIBFRANKA_DEFAULT: Deviation =
        Deviation { translation_m: 10.0, rotation_rad: 3.12, elbow_rad: 2.0 * std::f64::consts::PI };
}

/// A Move request (`Move::Request`, 113 bytes after the header).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveRequest {
    /// The controller to run.
    pub controller_mode: MoveControllerMode,
    /// The motion generator to run.
    pub motion_generator_mode: MoveMotionGeneratorMode,
    /// Maximum path deviation.
    pub maximum_path_deviation: Deviation,
    /// Maximum goal pose deviation.
    pub maximum_goal_pose_deviation: Deviation,
    /// Use the robot's asynchronous motion generator (then `maximum_velocity_rad_per_s` applies).
    pub use_async_motion_generator: bool,
    /// Per-joint velocity bounds of the asynchronous generator, rad/s (zeros otherwise).
    pub maximum_velocity_rad_per_s: [f64; 7],
}

impl MoveRequest {
    /// What libfranka's `Robot::control(JointVelocities)` sends: joint impedance controller, joint-velocity
    /// generator, default deviations, no asynchronous generator.
    pub const fn joint_velocity() -> Self {
        MoveRequest {
            controller_mode: MoveControllerMode::JointImpedance,
            motion_generator_mode: MoveMotionGeneratorMode::JointVelocity,
            maximum_path_deviation: Deviation::LIBFRANKA_DEFAULT,
            maximum_goal_pose_deviation: Deviation::LIBFRANKA_DEFAULT,
            use_async_motion_generator: false,
            maximum_velocity_rad_per_s: [0.0; 7],
        }
    }

    /// The whole request frame (header included).
    pub fn encode(&self, command_id: u32) -> [u8; MOVE_REQUEST_SIZE] {
        let mut buf = [0u8; MOVE_REQUEST_SIZE];
        let header = Header { command: Command::Move.to_wire(), command_id, size: MOVE_REQUEST_SIZE as u32 };
        let mut w = Writer::new(&mut buf);
        w.put_at(0, &header.encode());
        w.put_at(12, &self.controller_mode.to_wire().to_le_bytes());
        w.put_at(16, &self.motion_generator_mode.to_wire().to_le_bytes());
        for (offset, d) in [(20, &self.maximum_path_deviation), (44, &self.maximum_goal_pose_deviation)] {
            w.put_at(offset, &d.translation_m.to_le_bytes());
            w.put_at(offset + 8, &d.rotation_rad.to_le_bytes());
            w.put_at(offset + 16, &d.elbow_rad.to_le_bytes());
        }
        w.put_at(68, &[u8::from(self.use_async_motion_generator)]);
        for (i, v) in self.maximum_velocity_rad_per_s.iter().enumerate() {
            w.put_at(69 + 8 * i, &v.to_le_bytes());
        }
        buf
    }
}
