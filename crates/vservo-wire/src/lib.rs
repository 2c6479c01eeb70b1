//! # vservo-wire — the schema
//!
//! What the messages between vservo's processes are, whatever carries them: the fixed-size `#[repr(C)]`
//! payloads with their schema version, the wire codes, the tables of docs/PROTOCOL.md, how a message of another
//! schema is refused, the seals, and the rules for which sealed message is fresh. The instance they travel in
//! (its directory, its iceoryx2 services and ports, one writer per stream, the safe-stop path) is
//! `vservo-protocol`'s, which re-exports all of this at the same paths.
//!
//! Modules:
//! - [`messages`]: the payloads, each declared once with `wire_message!` ([`declare`]): the struct,
//!   `Default`, the schema check ([`inbox::Payload`]), the field table of docs/PROTOCOL.md, the JSON view of
//!   `vservoctl echo` and the recordings ([`WireField::to_json`]) and the bytes a seal covers all come from that
//!   declaration; adding a field touches the declaration, its producer and its consumer.
//! - [`codes`]: the wire codes as `#[repr(u32)]` enums ([`Verdict`], [`Fault`], [`CommandKind`],
//!   [`NodeState`], [`DriverError`], …), each declared once with its numbers, names and the legend
//!   docs/PROTOCOL.md prints; a program turns a message's number into its enum once, where it takes the
//!   message in, `TryFrom` refusing an unknown one.
//! - [`inbox`]: [`TakeMessages`], the one place a message of another schema is refused.
//! - [`layout`]: the tables of docs/PROTOCOL.md, and the same as data (a system test checks the Python
//!   clients' ctypes structures and codes against them).
//! - [`seal`]: SipHash-2-4 seals under a per-run key (on the stack, no allocation) on the daemon's `gains`,
//!   `object` and `cell_mode`, the rmrc's `joint_command`, the vision node's `features` and the servo's
//!   `camera_twist`, so that each consumer takes them from their one maker only; [`seal::Sealed`]
//!   (`SealKey::sign`/`verifies`, `sign_with`/`sealed_by`) is the one way a message is sealed and checked;
//!   [`seal::keep_memory_private`] (not dumpable, no core dump) comes first in `main` of every process that
//!   holds the key; the key's text is wiped once parsed, the key on drop.
//! - [`freshness`]: the one rule for which sealed `cell_mode`, `gains` or `object` is newer (the daemon's
//!   stamp, then the counter modulo 2⁶⁴ within a window): no number locks the daemon out, a replay is refused;
//!   and [`freshness::stream_standing`], which sealed `features` or `camera_twist` is taken: from the writer's
//!   process the daemon announces, of its run now ([`freshness::Origin`]), and fresh (within a vision period,
//!   later than the last taken): a recording of sealed samples played again is refused. [`supervision`]: the
//!   daemon's heartbeat on `cell_mode`, and how long the nodes wait for it before they hold the arm.
//! - [`stream`]: [`stream::SealedStream::admit`], the one admission of a sealed stream's sample (schema, seal,
//!   announced writer, freshness in one call) the servo and the rmrc take their inputs through.
//! - [`clock`]: the clock every stamp of the protocol is on (CLOCK_MONOTONIC, ns; `vservo-time`'s).

pub mod clock;
pub mod codes;
pub mod declare;
pub mod freshness;
pub mod inbox;
pub mod layout;
pub mod messages;
pub mod seal;
pub mod stream;
pub mod supervision;

pub use codes::{
    CellMode, CommandKind, CommandMode, DaemonState, DriverError, DriverStatus, Fault, Interaction,
    MarkStatus, NodeState, PixelFormat, RobotState, ServoFeatures, UnknownCode, Verdict,
};
pub use declare::{FieldInfo, WireField, WireMessage};
pub use inbox::{Payload, Refused, TakeMessages};
pub use messages::*;
