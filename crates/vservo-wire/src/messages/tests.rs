//! Unit tests of `messages`.

use super::*;
use std::mem::{offset_of, size_of};

#[test]
fn an_arms_joint_angles_are_taken_only_from_a_state_of_its_joint_count() {
    let state = JointStateMsg { q_rad: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 9.0], ..JointStateMsg::default() };
    assert_eq!(state.arm_q_rad(6), Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.0]), "a stray seventh slot ignored");
    assert_eq!(state.arm_q_rad(7), None);
    let seven = JointStateMsg { joint_count: 7, ..state };
    assert_eq!(seven.arm_q_rad(6), None);
    assert_eq!(seven.arm_q_rad(7), Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 9.0]));
}

// the layout docs/PROTOCOL.md documents; a change here must change the document and SCHEMA_VERSION
#[test]
fn layouts_are_the_documented_ones() {
    assert_eq!(size_of::<JointStateMsg>(), 56 + 3 * 56 + 8);
    assert_eq!(offset_of!(JointStateMsg, tick), 8);
    assert_eq!(offset_of!(JointStateMsg, joint_count), 48);
    assert_eq!(offset_of!(JointStateMsg, q_rad), 56);
    assert_eq!(offset_of!(JointStateMsg, applied_command_tick), 224);
    assert_eq!(size_of::<JointCommandMsg>(), 48 + 3 * 56 + 24 + 8);
    assert_eq!(offset_of!(JointCommandMsg, joint_count), 8);
    assert_eq!(offset_of!(JointCommandMsg, torque_nm), 48);
    assert_eq!(offset_of!(JointCommandMsg, twist_capture_tick), 216);
    assert_eq!(offset_of!(JointCommandMsg, seal), 240);
    assert_eq!(size_of::<SimWorldMsg>(), 16 + 96);
    assert_eq!(size_of::<CameraImageHeader>(), 56);
    assert_eq!(offset_of!(CameraImageHeader, exposure_us), 40);
    assert_eq!(size_of::<FeaturesMsg>(), 40 + 64 + 8 + 96 + 32 + 8 + 8 + 8);
    assert_eq!(offset_of!(FeaturesMsg, edge_rms_px), 208);
    assert_eq!(offset_of!(FeaturesMsg, refined_mask), 248);
    assert_eq!(offset_of!(FeaturesMsg, bits_corrected), 252);
    assert_eq!(offset_of!(FeaturesMsg, tags_used_mask), 254);
    assert_eq!(offset_of!(FeaturesMsg, seal), 256);
    assert_eq!(offset_of!(FeaturesMsg, features_px), 40);
    assert_eq!(offset_of!(FeaturesMsg, mark_status), 104);
    assert_eq!(size_of::<CameraTwistMsg>(), 40 + 48 + 8 + 8 + 8 + 8);
    assert_eq!(offset_of!(CameraTwistMsg, writer_pid), 104);
    assert_eq!(offset_of!(CameraTwistMsg, seal), 112);
    assert_eq!(offset_of!(FeaturesMsg, writer_pid), 108);
    assert_eq!(offset_of!(CameraTwistMsg, twist), 40);
    assert_eq!(offset_of!(CameraTwistMsg, feature_error_px), 88);
    assert_eq!(size_of::<TimingMsg>(), 40);
    assert_eq!(offset_of!(TelemetryMsg, wake_latency), 80);
    assert_eq!(offset_of!(TelemetryMsg, feature_error_px), 280);
    assert_eq!(size_of::<TelemetryMsg>(), 296);
    assert_eq!(size_of::<NodeStatusMsg>(), 32);
    assert_eq!(offset_of!(DaemonStatusMsg, nodes), 32);
    assert_eq!(offset_of!(DaemonStatusMsg, tick_rate_hz), 160);
    assert_eq!(size_of::<DaemonStatusMsg>(), 32 + 4 * 32 + 16 + 8 + 24 + 8 + 8 + 8 + 64);
    assert_eq!(offset_of!(DaemonStatusMsg, clearance_m), 224);
    assert_eq!(offset_of!(JointCommandMsg, guard), 12);
    assert_eq!(offset_of!(DaemonStatusMsg, driver_error), 208);
    assert_eq!(offset_of!(DaemonStatusMsg, speed_scale), 216);
    assert_eq!(size_of::<CellModeMsg>(), 32 + 8 + 56 + 16 + 16);
    assert_eq!(offset_of!(CellModeMsg, speed_scale), 32);
    assert_eq!(offset_of!(CellModeMsg, writers), 96);
    assert_eq!(offset_of!(CellModeMsg, goal_rad), 40);
    assert_eq!(size_of::<CommandMsg>(), 16 + 64 + 48 + 16 + 8 + 56 + 8);
    assert_eq!(offset_of!(CommandMsg, joints_rad), 152);
    assert_eq!(size_of::<CommandReplyMsg>(), 24 + 64 + REASON_BYTES);
    assert_eq!(offset_of!(GainsMsg, feature_gain), 16);
    assert_eq!(size_of::<ObjectMsg>(), 16 + 24 + 16 + 8 + 8);
    assert_eq!(offset_of!(ObjectMsg, stamp_ns), 56);
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
