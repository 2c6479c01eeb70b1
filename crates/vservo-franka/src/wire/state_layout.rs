//! Byte layout of a v10 `RobotState` datagram (`rbk_types.h` @ d96c221): 1377 bytes, packed, little endian,
//! `float` arrays (4×4 matrices column-major), `uint64_t` message id, `uint8_t` enums, 41-bool error arrays.

use super::FieldLayout;
use super::WireType::{Bool, F32, U8, U64};

/// Bytes in a v10 `RobotState`.
pub const ROBOT_STATE_SIZE: usize = 1377;

/// `message_id`: 1 × u64 at byte 0.
pub const MESSAGE_ID: FieldLayout = FieldLayout::new("message_id", U64, 1, 0);
/// `O_T_EE`: 16 × f32 at byte 8.
pub const O_T_EE: FieldLayout = FieldLayout::new("O_T_EE", F32, 16, 8);
/// `O_T_EE_d`: 16 × f32 at byte 72.
pub const O_T_EE_D: FieldLayout = FieldLayout::new("O_T_EE_d", F32, 16, 72);
/// `F_T_EE`: 16 × f32 at byte 136.
pub const F_T_EE: FieldLayout = FieldLayout::new("F_T_EE", F32, 16, 136);
/// `EE_T_K`: 16 × f32 at byte 200.
pub const EE_T_K: FieldLayout = FieldLayout::new("EE_T_K", F32, 16, 200);
/// `F_T_NE`: 16 × f32 at byte 264.
pub const F_T_NE: FieldLayout = FieldLayout::new("F_T_NE", F32, 16, 264);
/// `NE_T_EE`: 16 × f32 at byte 328.
pub const NE_T_EE: FieldLayout = FieldLayout::new("NE_T_EE", F32, 16, 328);
/// `m_ee`: 1 × f32 at byte 392.
pub const M_EE: FieldLayout = FieldLayout::new("m_ee", F32, 1, 392);
/// `I_ee`: 9 × f32 at byte 396.
pub const I_EE: FieldLayout = FieldLayout::new("I_ee", F32, 9, 396);
/// `F_x_Cee`: 3 × f32 at byte 432.
pub const F_X_CEE: FieldLayout = FieldLayout::new("F_x_Cee", F32, 3, 432);
/// `m_load`: 1 × f32 at byte 444.
pub const M_LOAD: FieldLayout = FieldLayout::new("m_load", F32, 1, 444);
/// `I_load`: 9 × f32 at byte 448.
pub const I_LOAD: FieldLayout = FieldLayout::new("I_load", F32, 9, 448);
/// `F_x_Cload`: 3 × f32 at byte 484.
pub const F_X_CLOAD: FieldLayout = FieldLayout::new("F_x_Cload", F32, 3, 484);
/// `elbow`: 2 × f32 at byte 496.
pub const ELBOW: FieldLayout = FieldLayout::new("elbow", F32, 2, 496);
/// `elbow_d`: 2 × f32 at byte 504.
pub const ELBOW_D: FieldLayout = FieldLayout::new("elbow_d", F32, 2, 504);
/// `tau_J`: 7 × f32 at byte 512.
pub const TAU_J: FieldLayout = FieldLayout::new("tau_J", F32, 7, 512);
/// `tau_J_d`: 7 × f32 at byte 540.
pub const TAU_J_D: FieldLayout = FieldLayout::new("tau_J_d", F32, 7, 540);
/// `dtau_J`: 7 × f32 at byte 568.
pub const DTAU_J: FieldLayout = FieldLayout::new("dtau_J", F32, 7, 568);
/// `q`: 7 × f32 at byte 596.
pub const Q: FieldLayout = FieldLayout::new("q", F32, 7, 596);
/// `q_d`: 7 × f32 at byte 624.
pub const Q_D: FieldLayout = FieldLayout::new("q_d", F32, 7, 624);
/// `dq`: 7 × f32 at byte 652.
pub const DQ: FieldLayout = FieldLayout::new("dq", F32, 7, 652);
/// `dq_d`: 7 × f32 at byte 680.
pub const DQ_D: FieldLayout = FieldLayout::new("dq_d", F32, 7, 680);
/// `ddq_d`: 7 × f32 at byte 708.
pub const DDQ_D: FieldLayout = FieldLayout::new("ddq_d", F32, 7, 708);
/// `joint_contact`: 7 × f32 at byte 736.
pub const JOINT_CONTACT: FieldLayout = FieldLayout::new("joint_contact", F32, 7, 736);
/// `cartesian_contact`: 6 × f32 at byte 764.
pub const CARTESIAN_CONTACT: FieldLayout = FieldLayout::new("cartesian_contact", F32, 6, 764);
/// `joint_collision`: 7 × f32 at byte 788.
pub const JOINT_COLLISION: FieldLayout = FieldLayout::new("joint_collision", F32, 7, 788);
/// `cartesian_collision`: 6 × f32 at byte 816.
pub const CARTESIAN_COLLISION: FieldLayout = FieldLayout::new("cartesian_collision", F32, 6, 816);
/// `tau_ext_hat_filtered`: 7 × f32 at byte 840.
pub const TAU_EXT_HAT_FILTERED: FieldLayout = FieldLayout::new("tau_ext_hat_filtered", F32, 7, 840);
/// `O_F_ext_hat_K`: 6 × f32 at byte 868.
pub const O_F_EXT_HAT_K: FieldLayout = FieldLayout::new("O_F_ext_hat_K", F32, 6, 868);
/// `K_F_ext_hat_K`: 6 × f32 at byte 892.
pub const K_F_EXT_HAT_K: FieldLayout = FieldLayout::new("K_F_ext_hat_K", F32, 6, 892);
/// `O_dP_EE_d`: 6 × f32 at byte 916.
pub const O_DP_EE_D: FieldLayout = FieldLayout::new("O_dP_EE_d", F32, 6, 916);
/// `O_ddP_O`: 3 × f32 at byte 940.
pub const O_DDP_O: FieldLayout = FieldLayout::new("O_ddP_O", F32, 3, 940);
/// `elbow_c`: 2 × f32 at byte 952.
pub const ELBOW_C: FieldLayout = FieldLayout::new("elbow_c", F32, 2, 952);
/// `delbow_c`: 2 × f32 at byte 960.
pub const DELBOW_C: FieldLayout = FieldLayout::new("delbow_c", F32, 2, 960);
/// `ddelbow_c`: 2 × f32 at byte 968.
pub const DDELBOW_C: FieldLayout = FieldLayout::new("ddelbow_c", F32, 2, 968);
/// `O_T_EE_c`: 16 × f32 at byte 976.
pub const O_T_EE_C: FieldLayout = FieldLayout::new("O_T_EE_c", F32, 16, 976);
/// `O_dP_EE_c`: 6 × f32 at byte 1040.
pub const O_DP_EE_C: FieldLayout = FieldLayout::new("O_dP_EE_c", F32, 6, 1040);
/// `O_ddP_EE_c`: 6 × f32 at byte 1064.
pub const O_DDP_EE_C: FieldLayout = FieldLayout::new("O_ddP_EE_c", F32, 6, 1064);
/// `theta`: 7 × f32 at byte 1088.
pub const THETA: FieldLayout = FieldLayout::new("theta", F32, 7, 1088);
/// `dtheta`: 7 × f32 at byte 1116.
pub const DTHETA: FieldLayout = FieldLayout::new("dtheta", F32, 7, 1116);
/// `accelerometer_top`: 18 × f32 at byte 1144.
pub const ACCELEROMETER_TOP: FieldLayout = FieldLayout::new("accelerometer_top", F32, 18, 1144);
/// `accelerometer_bottom`: 18 × f32 at byte 1216.
pub const ACCELEROMETER_BOTTOM: FieldLayout = FieldLayout::new("accelerometer_bottom", F32, 18, 1216);
/// `motion_generator_mode`: 1 × u8 at byte 1288.
pub const MOTION_GENERATOR_MODE: FieldLayout = FieldLayout::new("motion_generator_mode", U8, 1, 1288);
/// `controller_mode`: 1 × u8 at byte 1289.
pub const CONTROLLER_MODE: FieldLayout = FieldLayout::new("controller_mode", U8, 1, 1289);
/// `errors`: 41 × bool at byte 1290.
pub const ERRORS: FieldLayout = FieldLayout::new("errors", Bool, 41, 1290);
/// `reflex_reason`: 41 × bool at byte 1331.
pub const REFLEX_REASON: FieldLayout = FieldLayout::new("reflex_reason", Bool, 41, 1331);
/// `robot_mode`: 1 × u8 at byte 1372.
pub const ROBOT_MODE: FieldLayout = FieldLayout::new("robot_mode", U8, 1, 1372);
/// `control_command_success_rate`: 1 × f32 at byte 1373.
pub const CONTROL_COMMAND_SUCCESS_RATE: FieldLayout =
    FieldLayout::new("control_command_success_rate", F32, 1, 1373);

/// Every field of `RobotState`, in wire order.
pub const FIELDS: [FieldLayout; 48] = [
    MESSAGE_ID,
    O_T_EE,
    O_T_EE_D,
    F_T_EE,
    EE_T_K,
    F_T_NE,
    NE_T_EE,
    M_EE,
    I_EE,
    F_X_CEE,
    M_LOAD,
    I_LOAD,
    F_X_CLOAD,
    ELBOW,
    ELBOW_D,
    TAU_J,
    TAU_J_D,
    DTAU_J,
    Q,
    Q_D,
    DQ,
    DQ_D,
    DDQ_D,
    JOINT_CONTACT,
    CARTESIAN_CONTACT,
    JOINT_COLLISION,
    CARTESIAN_COLLISION,
    TAU_EXT_HAT_FILTERED,
    O_F_EXT_HAT_K,
    K_F_EXT_HAT_K,
    O_DP_EE_D,
    O_DDP_O,
    ELBOW_C,
    DELBOW_C,
    DDELBOW_C,
    O_T_EE_C,
    O_DP_EE_C,
    O_DDP_EE_C,
    THETA,
    DTHETA,
    ACCELEROMETER_TOP,
    ACCELEROMETER_BOTTOM,
    MOTION_GENERATOR_MODE,
    CONTROLLER_MODE,
    ERRORS,
    REFLEX_REASON,
    ROBOT_MODE,
    CONTROL_COMMAND_SUCCESS_RATE,
];

const _: () = assert!(
    super::tiles_exactly(&FIELDS, ROBOT_STATE_SIZE),
    "the RobotState layout must tile its 1377 bytes"
);
