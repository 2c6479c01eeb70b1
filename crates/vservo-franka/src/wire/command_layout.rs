//! Byte layout of a v10 `RobotCommand` datagram (`rbk_types.h` @ d96c221): 371 bytes, packed, little endian,
//! `double` arrays: `MotionGeneratorCommand` (q_c … motion_generation_finished) then `ControllerCommand`
//! (tau_J_d, torque_command_finished).

use super::FieldLayout;
use super::WireType::{Bool, F64, U64};

/// Bytes in a v10 `RobotCommand`.
pub const ROBOT_COMMAND_SIZE: usize = 371;

/// `message_id`: 1 × u64 at byte 0.
pub const MESSAGE_ID: FieldLayout = FieldLayout::new("message_id", U64, 1, 0);
/// `q_c`: 7 × f64 at byte 8.
pub const Q_C: FieldLayout = FieldLayout::new("q_c", F64, 7, 8);
/// `dq_c`: 7 × f64 at byte 64.
pub const DQ_C: FieldLayout = FieldLayout::new("dq_c", F64, 7, 64);
/// `O_T_EE_c`: 16 × f64 at byte 120.
pub const O_T_EE_C: FieldLayout = FieldLayout::new("O_T_EE_c", F64, 16, 120);
/// `O_dP_EE_c`: 6 × f64 at byte 248.
pub const O_DP_EE_C: FieldLayout = FieldLayout::new("O_dP_EE_c", F64, 6, 248);
/// `elbow_c`: 2 × f64 at byte 296.
pub const ELBOW_C: FieldLayout = FieldLayout::new("elbow_c", F64, 2, 296);
/// `valid_elbow`: 1 × bool at byte 312.
pub const VALID_ELBOW: FieldLayout = FieldLayout::new("valid_elbow", Bool, 1, 312);
/// `motion_generation_finished`: 1 × bool at byte 313.
pub const MOTION_GENERATION_FINISHED: FieldLayout =
    FieldLayout::new("motion_generation_finished", Bool, 1, 313);
/// `tau_J_d`: 7 × f64 at byte 314.
pub const TAU_J_D: FieldLayout = FieldLayout::new("tau_J_d", F64, 7, 314);
/// `torque_command_finished`: 1 × bool at byte 370.
pub const TORQUE_COMMAND_FINISHED: FieldLayout = FieldLayout::new("torque_command_finished", Bool, 1, 370);

/// Every field of `RobotCommand`, in wire order.
pub const FIELDS: [FieldLayout; 10] = [
    MESSAGE_ID,
    Q_C,
    DQ_C,
    O_T_EE_C,
    O_DP_EE_C,
    ELBOW_C,
    VALID_ELBOW,
    MOTION_GENERATION_FINISHED,
    TAU_J_D,
    TORQUE_COMMAND_FINISHED,
];

const _: () = assert!(
    super::tiles_exactly(&FIELDS, ROBOT_COMMAND_SIZE),
    "the RobotCommand layout must tile its 371 bytes"
);
