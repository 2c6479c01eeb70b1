//! Unit tests of `convert`.

use super::*;
use approx::assert_relative_eq;
use nalgebra::{Point2, Rotation3, Translation3};

#[test]
fn ros_time_splits_seconds_and_nanoseconds() {
    assert_eq!(time_of_unix_ns(1_700_000_000_123_456_789), Time { sec: 1_700_000_000, nanosec: 123_456_789 });
    assert_eq!(time_of_unix_ns(-1), Time { sec: -1, nanosec: 999_999_999 });
    let clock = StampClock { realtime_minus_monotonic_ns: 1_700_000_000_000_000_000 };
    assert_eq!(clock.ros_time(2_500_000_000), Time { sec: 1_700_000_002, nanosec: 500_000_000 });
    assert_eq!(clock.ros_time(0), Time::default(), "no stamp stays no time");
}

#[test]
fn header_stamps_are_kept_unless_unusable() {
    let clock = StampClock { realtime_minus_monotonic_ns: 1_700_000_000_000_000_000 };
    let arrival_ns = 10_000_000_000;
    let stamp = clock.ros_time(arrival_ns - 3_000_000); // taken 3 ms before it arrived
    let taken = clock.arrival(&stamp, arrival_ns, 50_000_000);
    let on_time =
        Arrival { stamp_ns: arrival_ns - 3_000_000, restamped: false, late: false, age_ns: 3_000_000 };
    assert_eq!(taken, on_time);
    assert_eq!(clock.ros_time(taken.stamp_ns), stamp, "the way back");
    let old = clock.arrival(&clock.ros_time(arrival_ns - 60_000_000), arrival_ns, 50_000_000);
    assert_eq!((old.stamp_ns, old.restamped, old.late), (arrival_ns - 60_000_000, false, true), "kept, late");
    for (stamp, why) in [
        (Time::default(), "no stamp"),
        (clock.ros_time(arrival_ns + 60_000_000), "in the future"),
        (Time { sec: 12, nanosec: 0 }, "before this machine's boot (a clock that started at its own)"),
    ] {
        let taken = clock.arrival(&stamp, arrival_ns, 50_000_000);
        assert!(taken.restamped && !taken.late && taken.stamp_ns == arrival_ns, "{why}: {taken:?}");
    }
}

fn state(joint_count: u32, q: [f64; 7]) -> JointStateMsg {
    JointStateMsg {
        joint_count,
        q_rad: q,
        qd_rad_s: [0.1; 7],
        torque_nm: [2.0; 7],
        ..JointStateMsg::default()
    }
}

#[test]
fn joint_states_of_the_configured_arm_only() {
    let names = joint_names(&[], &vservo_arm::puma560::puma560());
    assert_eq!(names[0], "joint1");
    assert_eq!(names[5], "joint6");
    let q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.0];
    let message = joint_state(&state(6, q), &names, Time::default()).expect("six joints");
    assert_eq!(message.position, q[..6]);
    assert_eq!((message.velocity.len(), message.effort.len()), (6, 6));
    assert!(joint_state(&state(7, q), &names, Time::default()).is_none());
    let configured: Vec<String> = (0..6).map(|j| format!("shoulder_{j}")).collect();
    assert_eq!(joint_names(&configured, &vservo_arm::puma560::puma560()), configured);
}

/// An arm from a URDF is named in ROS as its URDF names it, unless `[ros2] joint_names` says otherwise.
#[test]
fn a_urdf_arms_joints_have_the_urdfs_names() {
    let config =
        vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/arms/ur5e.toml"))
            .expect("ur5e.toml loads");
    let names = joint_names(&[], &config.cell.arm);
    assert_eq!(names.len(), 6);
    assert_eq!((names[0].as_str(), names[5].as_str()), ("shoulder_pan_joint", "wrist_3_joint"));
}

fn pose_of(t: &Transform) -> IsometryMatrix3<f64> {
    let q = nalgebra::Quaternion::new(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z);
    IsometryMatrix3::from_parts(
        Translation3::new(t.translation.x, t.translation.y, t.translation.z),
        UnitQuaternion::from_quaternion(q).to_rotation_matrix(),
    )
}

/// The frames on `tf` and `/tf_static` from `base` to the camera, composed: each the parent of the next.
fn composed(
    frames: &crate::frames::ArmFrames,
    arm: &vservo_arm::SerialArm,
    q: [f64; 7],
    tool_from_camera: &IsometryMatrix3<f64>,
) -> (Vec<String>, IsometryMatrix3<f64>) {
    let joint_count = arm.joint_count() as u32;
    let chain: Vec<TransformStamped> =
        frames
            .moving(arm, &state(joint_count, q), Time::default())
            .into_iter()
            .chain(frames.fixed(
                &vservo_scene::CameraMount::Hand { tool_from_camera: *tool_from_camera },
                Time::default(),
            ))
            .collect();
    let mut names = vec![frames.base.clone()];
    let mut base_from_child = IsometryMatrix3::identity();
    for t in &chain {
        assert_eq!(&t.header.frame_id, names.last().expect("a parent"), "each frame the parent of the next");
        base_from_child *= pose_of(&t.transform);
        names.push(t.child_frame_id.clone());
    }
    (names, base_from_child)
}

#[test]
fn the_tf_chain_composes_to_the_camera_pose() {
    let arm = vservo_arm::puma560::puma560();
    let tool_from_camera = IsometryMatrix3::from_parts(
        Translation3::new(0.0, 0.05, 0.1),
        Rotation3::from_euler_angles(0.1, -0.2, 0.3),
    );
    let q = [0.3, -0.7, 0.9, 0.2, -0.4, 1.1, 0.0];
    let frames = crate::frames::ArmFrames::of(&arm);
    let (names, base_from_camera) = composed(&frames, &arm, q, &tool_from_camera);
    assert_eq!(names, ["base", "link1", "link2", "link3", "link4", "link5", "link6", CAMERA_FRAME]);
    let expected = arm.base_from_tool(&vservo_arm::JointVector::from(q)) * tool_from_camera;
    assert_relative_eq!(base_from_camera.to_homogeneous(), expected.to_homogeneous(), epsilon = 1e-12);
    assert!(frames.moving(&arm, &state(7, q), Time::default()).is_empty());
}

/// A URDF arm's frames are its links: the base link, the link each joint moves, the tip link on the last (on
/// `/tf_static`, with the camera), composing to the same camera pose.
#[test]
fn a_urdf_arms_frames_have_the_urdfs_link_names() {
    let config =
        vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/arms/ur5e.toml"))
            .expect("ur5e.toml loads");
    let q = [0.3, -0.7, 0.9, 0.2, -0.4, 1.1, 0.0];
    let frames = crate::frames::ArmFrames::of(&config.cell.arm);
    let (names, base_from_camera) = composed(&frames, &config.cell.arm, q, &config.cell.tool_from_camera);
    assert_eq!(
        names,
        [
            "base_link",
            "shoulder_link",
            "upper_arm_link",
            "forearm_link",
            "wrist_1_link",
            "wrist_2_link",
            "wrist_3_link",
            "flange",
            CAMERA_FRAME
        ]
    );
    assert_eq!(frames.fixed(&config.cell.mount(), Time::default()).len(), 2, "flange and camera are fixed");
    let expected =
        config.cell.arm.base_from_tool(&vservo_arm::JointVector::from(q)) * config.cell.tool_from_camera;
    assert_relative_eq!(base_from_camera.to_homogeneous(), expected.to_homogeneous(), epsilon = 1e-12);
}

#[test]
fn the_target_is_the_pose_that_images_the_marks() {
    let camera = CameraIntrinsics::paper();
    let board = Board::paper();
    let camera_from_board = IsometryMatrix3::from_parts(
        Translation3::new(0.02, -0.01, 0.45),
        Rotation3::from_euler_angles(0.15, -0.1, 0.4),
    );
    let mut message = FeaturesMsg { valid_mask: 0b1111, ..FeaturesMsg::default() };
    for (m, mark) in board.marks_in_board.iter().enumerate() {
        let p = camera.project(&(camera_from_board * mark)).expect("in front");
        message.features_px[2 * m] = p.x;
        message.features_px[2 * m + 1] = p.y;
    }
    let seen = target_transform(&camera, &board, &message, Time::default()).expect("a pose");
    assert_eq!((seen.header.frame_id.as_str(), seen.child_frame_id.as_str()), (CAMERA_FRAME, TARGET_FRAME));
    assert_relative_eq!(
        pose_of(&seen.transform).to_homogeneous(),
        camera_from_board.to_homogeneous(),
        epsilon = 1e-9
    );
    message.valid_mask = 0b0111;
    assert!(target_transform(&camera, &board, &message, Time::default()).is_none(), "three marks: no pose");
}

#[test]
fn camera_info_in_opencv_pixels_with_the_lens() {
    let distortion = vservo_scene::Distortion::new([-0.2, 0.05, 0.001, -0.002, 0.0]).expect("a lens");
    let camera = CameraIntrinsics::with_lens([600.0, 610.0], Point2::new(320.0, 240.0), 640, 480, distortion)
        .expect("intrinsics");
    let info = camera_info(&camera, Time::default());
    assert_eq!(info.k, [600.0, 0.0, 319.5, 0.0, 610.0, 239.5, 0.0, 0.0, 1.0]);
    assert_eq!(info.p, [600.0, 0.0, 319.5, 0.0, 0.0, 610.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0]);
    assert_eq!(info.d, [-0.2, 0.05, 0.001, -0.002, 0.0]);
    assert_eq!((info.width, info.height, info.distortion_model.as_str()), (640, 480, "plumb_bob"));
}

#[test]
fn features_in_opencv_pixels_nan_where_a_mark_is_missing() {
    let message = FeaturesMsg {
        valid_mask: 0b1011,
        features_px: [10.5, 20.5, 30.5, 40.5, 50.5, 60.5, 70.5, 80.5],
        ..FeaturesMsg::default()
    };
    let array = features(&message);
    assert_eq!(array.data[..4], [10.0, 20.0, 30.0, 40.0]);
    assert!(array.data[4].is_nan() && array.data[5].is_nan());
    assert_eq!(array.data[6..], [70.0, 80.0]);
    assert_eq!(array.layout.dim.iter().map(|d| d.size).product::<u32>(), 8);
}

#[test]
fn images_of_another_format_or_short_are_refused() {
    let header = CameraImageHeader {
        format: PixelFormat::Mono8.code(),
        width: 4,
        height: 2,
        stride_bytes: 5,
        ..CameraImageHeader::default()
    };
    let pixels = [7u8; 10];
    let converted = image(&header, &pixels, Time::default()).expect("mono8");
    assert_eq!((converted.step, converted.data.len(), converted.encoding.as_str()), (5, 10, "mono8"));
    assert!(image(&header, &pixels[..9], Time::default()).is_none(), "short");
    let narrow = CameraImageHeader { stride_bytes: 3, ..header };
    assert!(image(&narrow, &pixels, Time::default()).is_none(), "stride below the width");
    let other = CameraImageHeader { format: PixelFormat::Mono8.code() + 1, ..header };
    assert!(image(&other, &pixels, Time::default()).is_none(), "another format");
}

fn view(state: &'static str) -> StatusView {
    StatusView {
        instance: "cell".into(),
        state,
        fault: None,
        safe_stops: 0,
        uptime_s: 1.0,
        daemon_pid: 1,
        nodes: std::collections::BTreeMap::new(),
        supervised_nodes: 4,
        robot: "running",
        tick_rate_hz: 1000.0,
        feature_error_px: Some(0.5),
        gains_version: 1,
        overruns: std::collections::BTreeMap::new(),
        speed_scale: 1.0,
        clearance: None,
    }
}

#[test]
fn a_safe_stop_is_an_error_and_a_degraded_cell_a_warning() {
    let level = |state| diagnostics(&view(state), Time::default()).status[0].level;
    assert_eq!(level("running"), DiagnosticStatus::OK);
    assert_eq!(level("moving"), DiagnosticStatus::OK);
    assert_eq!(level("degraded"), DiagnosticStatus::WARN);
    assert_eq!(level("safe-stop"), DiagnosticStatus::ERROR);
    let refused = BridgeCounts { requests_refused: 1, ..BridgeCounts::default() };
    assert_eq!(bridge_status("cell", &refused).level, DiagnosticStatus::WARN);
    assert_eq!(bridge_status("cell", &BridgeCounts::default()).level, DiagnosticStatus::OK);
}
