//! vservo's messages as ROS 2 messages.
//!
//! Pure functions, but [`StampClock::now`], which reads the clocks.
//!
//! Conventions at the ROS boundary (docs/ROS2.md):
//! - stamps are ROS time, the system clock's (CLOCK_REALTIME); vservo stamps with CLOCK_MONOTONIC, and
//!   [`StampClock`] carries the offset between the two;
//! - pixels are OpenCV's and ROS's (a pixel's centre at whole coordinates): vservo's pixel centre is at + ½
//!   (docs/ARCHITECTURE.md), so the principal point and the features are ½ px less here;
//! - frames: `base`, `link1` … `linkN` (each the parent of the next), `camera` (the optical frame: x right,
//!   y down, z along the axis, as ROS's `*_optical_frame`), `target` (the board as the camera sees it).

use nalgebra::{IsometryMatrix3, UnitQuaternion};
use vservo_client::StatusView;
use vservo_config::calibration::OPENCV_TO_VSERVO_PX;
use vservo_protocol::{CameraImageHeader, CameraTwistMsg, FeaturesMsg, JointStateMsg, MARKS, PixelFormat};
use vservo_scene::{Board, CameraIntrinsics};

use crate::msg::{
    CameraInfo, DiagnosticArray, DiagnosticStatus, Float64MultiArray, Header, Image, JointState, KeyValue,
    MultiArrayDimension, MultiArrayLayout, Quaternion, RegionOfInterest, Time, Transform, TransformStamped,
    Twist, TwistStamped, Vector3,
};

/// The robot's base frame.
pub const BASE_FRAME: &str = "base";
/// The camera's optical frame.
pub const CAMERA_FRAME: &str = "camera";
/// The board as the camera sees it.
pub const TARGET_FRAME: &str = "target";

/// CLOCK_MONOTONIC (vservo's stamps) to ROS time: the system clock's offset from the monotonic one, read by
/// the caller (it moves when the system clock is set or slewed: read it again now and then).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StampClock {
    /// CLOCK_REALTIME − CLOCK_MONOTONIC (ns).
    pub realtime_minus_monotonic_ns: i128,
}

impl StampClock {
    /// CLOCK_REALTIME − CLOCK_MONOTONIC, read now (0 if a clock cannot be read).
    pub fn now() -> Self {
        use nix::time::{ClockId, clock_gettime};
        let ns = |clock| {
            clock_gettime(clock)
                .map_or(0, |t| i128::from(t.tv_sec()) * 1_000_000_000 + i128::from(t.tv_nsec()))
        };
        let monotonic = ns(ClockId::CLOCK_MONOTONIC);
        let realtime = ns(ClockId::CLOCK_REALTIME);
        Self { realtime_minus_monotonic_ns: realtime - monotonic }
    }

    /// The ROS time of a CLOCK_MONOTONIC stamp; zero (ROS's "no time") for a stamp of 0 (none).
    pub fn ros_time(&self, monotonic_ns: u64) -> Time {
        if monotonic_ns == 0 {
            return Time::default();
        }
        let unix_ns = i128::from(monotonic_ns) + self.realtime_minus_monotonic_ns;
        time_of_unix_ns(unix_ns)
    }
}

/// A header stamp as CLOCK_MONOTONIC. A stamp of another host whose clock is not in step with this one's says
/// little of when the data was taken here: one in the future, or none, is replaced by the arrival; one older
/// than the tolerance is kept, flagged (late data, or a clock behind this one's: which, no stamp can say; kept,
/// it lets the vision node drop a stale image rather than take it for a fresh one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Arrival {
    /// The stamp to use (CLOCK_MONOTONIC ns): the header's, or the arrival's when the header has none usable.
    pub stamp_ns: u64,
    /// Whether the header's stamp was replaced by the arrival: zero, before this machine's boot, or more than
    /// the tolerance in the future.
    pub restamped: bool,
    /// Whether the header's stamp is kept though older than the tolerance at arrival.
    pub late: bool,
    /// The header stamp's distance before the arrival (ns; negative: after it).
    pub age_ns: i128,
}

impl StampClock {
    /// The stamp of a message whose header says `stamp` and which arrived at `arrival_ns` (CLOCK_MONOTONIC),
    /// judged with `tolerance_ns` ([`Arrival`]).
    pub fn arrival(&self, stamp: &Time, arrival_ns: u64, tolerance_ns: u64) -> Arrival {
        let unix_ns = i128::from(stamp.sec) * 1_000_000_000 + i128::from(stamp.nanosec);
        let monotonic_ns = unix_ns - self.realtime_minus_monotonic_ns;
        let age_ns = i128::from(arrival_ns) - monotonic_ns;
        let tolerance = i128::from(tolerance_ns);
        let usable = unix_ns != 0 && monotonic_ns > 0 && age_ns >= -tolerance;
        Arrival {
            stamp_ns: if usable { monotonic_ns as u64 } else { arrival_ns },
            restamped: !usable,
            late: usable && age_ns > tolerance,
            age_ns,
        }
    }
}

/// A time in ns since 1970 as seconds and nanoseconds (clamped to what `builtin_interfaces/Time` holds).
pub fn time_of_unix_ns(unix_ns: i128) -> Time {
    let sec = unix_ns.div_euclid(1_000_000_000).clamp(i128::from(i32::MIN), i128::from(i32::MAX));
    let nanosec = unix_ns.rem_euclid(1_000_000_000);
    Time { sec: sec as i32, nanosec: nanosec as u32 }
}

fn header(stamp: Time, frame_id: &str) -> Header {
    Header { stamp, frame_id: frame_id.to_string() }
}

/// The joint names ROS sees: the configured ones (`[ros2] joint_names`), else the URDF's (an arm from a URDF: the
/// names its robot description, robot_state_publisher and its controllers use), else `joint1` … `jointN`.
pub fn joint_names(configured: &[String], arm: &vservo_arm::SerialArm) -> Vec<String> {
    let joint_count = arm.joint_count();
    if configured.len() == joint_count {
        return configured.to_vec();
    }
    match &arm.geometry {
        vservo_arm::Geometry::Chain(chain) => chain.joints.iter().map(|joint| joint.name.clone()).collect(),
        vservo_arm::Geometry::Dh => (1..=joint_count).map(|j| format!("joint{j}")).collect(),
    }
}

/// A joint state; `None` from a state of another arm's joint count than `names` has.
pub fn joint_state(state: &JointStateMsg, names: &[String], stamp: Time) -> Option<JointState> {
    let n = names.len();
    if state.joint_count as usize != n || n > state.q_rad.len() {
        return None;
    }
    Some(JointState {
        header: header(stamp, ""),
        name: names.to_vec(),
        position: state.q_rad[..n].to_vec(),
        velocity: state.qd_rad_s[..n].to_vec(),
        effort: state.torque_nm[..n].to_vec(),
    })
}

/// `parent_from_child` as a ROS transform.
pub fn transform(
    stamp: Time,
    parent: &str,
    child: &str,
    parent_from_child: &IsometryMatrix3<f64>,
) -> TransformStamped {
    let t = parent_from_child.translation.vector;
    let q = UnitQuaternion::from_rotation_matrix(&parent_from_child.rotation);
    TransformStamped {
        header: header(stamp, parent),
        child_frame_id: child.to_string(),
        transform: Transform {
            translation: Vector3 { x: t.x, y: t.y, z: t.z },
            rotation: Quaternion { x: q.i, y: q.j, z: q.k, w: q.w },
        },
    }
}

/// The arm's links as a chain (`base` → `link1` → … → `linkN`) and the camera on the last (`linkN` →
/// `camera`), at a joint state; none from a state of another arm's joint count.
pub fn arm_transforms(
    arm: &vservo_arm::SerialArm,
    tool_from_camera: &IsometryMatrix3<f64>,
    state: &JointStateMsg,
    stamp: Time,
) -> Vec<TransformStamped> {
    let n = arm.joint_count();
    let Some(q) = state.arm_q_rad(n).map(vservo_arm::JointVector::from) else { return Vec::new() };
    let base_from_links = arm.link_frames(&q);
    let mut parent = BASE_FRAME.to_string();
    let mut base_from_parent = IsometryMatrix3::identity();
    let mut transforms = Vec::with_capacity(n + 1);
    for (i, base_from_link) in base_from_links.iter().take(n).enumerate() {
        let child = format!("link{}", i + 1);
        transforms.push(transform(stamp, &parent, &child, &(base_from_parent.inverse() * base_from_link)));
        parent = child;
        base_from_parent = *base_from_link;
    }
    // the camera rides on the last link, the tool
    transforms.push(transform(stamp, &parent, CAMERA_FRAME, tool_from_camera));
    transforms
}

/// The board as the camera sees it (`camera` → `target`) from a frame's features, at the capture; `None`
/// unless all four marks are valid and a pose explains them.
pub fn target_transform(
    camera: &CameraIntrinsics,
    board: &Board,
    features: &FeaturesMsg,
    stamp: Time,
) -> Option<TransformStamped> {
    if features.valid_mask & 0b1111 != 0b1111 {
        return None;
    }
    let xi = vservo_scene::FeatureVector::from(features.features_px);
    let camera_from_board = camera.board_pose_from_features(board, &xi)?;
    Some(transform(stamp, CAMERA_FRAME, TARGET_FRAME, &camera_from_board))
}

/// A camera image (8-bit gray) as `mono8`, stamped with its exposure; `None` for another pixel format or
/// fewer bytes than its header says.
pub fn image(header_in: &CameraImageHeader, pixels: &[u8], stamp: Time) -> Option<Image> {
    let bytes = header_in.stride_bytes as usize * header_in.height as usize;
    if PixelFormat::try_from(header_in.format) != Ok(PixelFormat::Mono8)
        || header_in.stride_bytes < header_in.width
        || pixels.len() < bytes
    {
        return None;
    }
    Some(Image {
        header: header(stamp, CAMERA_FRAME),
        height: header_in.height,
        width: header_in.width,
        encoding: "mono8".to_string(),
        is_bigendian: 0,
        step: header_in.stride_bytes,
        data: pixels[..bytes].to_vec(),
    })
}

/// The camera's intrinsics and lens (OpenCV's `plumb_bob`) as `camera_info`, in OpenCV's pixels.
pub fn camera_info(camera: &CameraIntrinsics, stamp: Time) -> CameraInfo {
    let (fx, fy) = (camera.fx_px(), camera.fy_px());
    let principal = camera.principal_point_px();
    let (cx, cy) = (principal.x - OPENCV_TO_VSERVO_PX, principal.y - OPENCV_TO_VSERVO_PX);
    CameraInfo {
        header: header(stamp, CAMERA_FRAME),
        height: camera.height_px(),
        width: camera.width_px(),
        distortion_model: "plumb_bob".to_string(),
        d: camera.distortion().coefficients().to_vec(),
        k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        binning_x: 0,
        binning_y: 0,
        roi: RegionOfInterest::default(),
    }
}

/// A frame's features ξ = [x₁ y₁ … x₄ y₄] in OpenCV's pixels (the lens's distortion taken out), NaN where a
/// mark is not valid, laid out as 4 marks × 2.
pub fn features(features_msg: &FeaturesMsg) -> Float64MultiArray {
    let data =
        features_msg
            .features_px
            .iter()
            .enumerate()
            .map(|(i, &px)| {
                if features_msg.valid_mask & (1 << (i / 2)) != 0 {
                    px - OPENCV_TO_VSERVO_PX
                } else {
                    f64::NAN
                }
            })
            .collect();
    let dimension = |label: &str, size: usize, stride: usize| MultiArrayDimension {
        label: label.to_string(),
        size: size as u32,
        stride: stride as u32,
    };
    Float64MultiArray {
        layout: MultiArrayLayout {
            dim: vec![dimension("marks", MARKS, 2 * MARKS), dimension("xy_px", 2, 2)],
            data_offset: 0,
        },
        data,
    }
}

/// The servo's twist of the camera, in the camera frame.
pub fn twist(message: &CameraTwistMsg, stamp: Time) -> TwistStamped {
    let u = message.twist;
    TwistStamped {
        header: header(stamp, CAMERA_FRAME),
        twist: Twist {
            linear: Vector3 { x: u[0], y: u[1], z: u[2] },
            angular: Vector3 { x: u[3], y: u[4], z: u[5] },
        },
    }
}

/// The instance's status as diagnostics: the cell (its state, fault, robot driver, error) and each node (its
/// state, restarts, overruns and loop timing). A safe stop is an error, a degraded or starting cell a
/// warning.
pub fn diagnostics(view: &StatusView, stamp: Time) -> DiagnosticArray {
    let mut status = vec![cell_status(view)];
    status.extend(view.nodes.iter().map(|(name, node)| node_status(&view.instance, name, node)));
    DiagnosticArray { header: header(stamp, ""), status }
}

fn key_value(key: &str, value: impl ToString) -> KeyValue {
    KeyValue { key: key.to_string(), value: value.to_string() }
}

fn counters(pairs: &[(&str, u64)]) -> Vec<KeyValue> {
    pairs.iter().map(|(key, value)| key_value(key, value)).collect()
}

fn cell_status(view: &StatusView) -> DiagnosticStatus {
    let level = match view.state {
        "running" | "moving" => DiagnosticStatus::OK,
        "safe-stop" => DiagnosticStatus::ERROR,
        _ => DiagnosticStatus::WARN,
    };
    let fault = view.fault.as_ref();
    let message = match fault.filter(|f| f.active) {
        Some(f) => format!("{}: {}", view.state, f.name),
        None => view.state.to_string(),
    };
    let mut values = vec![
        key_value("state", view.state),
        key_value("robot", view.robot),
        key_value("fault", fault.map_or("none", |f| f.name)),
        key_value("fault_active", fault.is_some_and(|f| f.active)),
        key_value(
            "fault_joints",
            fault
                .map_or(String::new(), |f| f.joints.iter().map(u32::to_string).collect::<Vec<_>>().join(",")),
        ),
        key_value("safe_stops", view.safe_stops),
        key_value("uptime_s", format!("{:.3}", view.uptime_s)),
        key_value("tick_rate_hz", format!("{:.1}", view.tick_rate_hz)),
        key_value("gains_version", view.gains_version),
    ];
    if let Some(error_px) = view.feature_error_px {
        values.push(key_value("feature_error_px", format!("{error_px:.4}")));
    }
    DiagnosticStatus {
        level,
        name: format!("vservo/{}: cell", view.instance),
        message,
        hardware_id: view.instance.clone(),
        values,
    }
}

fn node_status(instance: &str, name: &str, node: &vservo_client::NodeView) -> DiagnosticStatus {
    let level = if node.running && node.healthy { DiagnosticStatus::OK } else { DiagnosticStatus::WARN };
    let mut values = vec![key_value("state", node.state)];
    values.extend(counters(&[
        ("pid", u64::from(node.pid)),
        ("restarts", node.restarts),
        ("cycles", node.cycles),
        ("overruns", node.overruns),
        ("skipped_periods", node.skipped_periods),
        ("late_answers", node.late_answers),
        ("rejected_messages", node.rejected_messages),
    ]));
    let timings = [
        ("wake_latency", node.wake_latency_us),
        ("execution", node.execution_us),
        ("round_trip", node.round_trip_us),
        ("frame_period", node.frame_period_us),
        ("capture_to_twist", node.capture_latency_us),
    ];
    for (what, timing) in timings {
        if let Some(t) = timing {
            values.push(key_value(&format!("{what}_p50_us"), format!("{:.1}", t.p50)));
            values.push(key_value(&format!("{what}_p99_us"), format!("{:.1}", t.p99)));
            values.push(key_value(&format!("{what}_max_us"), format!("{:.1}", t.max)));
        }
    }
    DiagnosticStatus {
        level,
        name: format!("vservo/{instance}: {name}"),
        message: node.state.to_string(),
        hardware_id: instance.to_string(),
        values,
    }
}

/// What the bridge has done since it started.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BridgeCounts {
    /// ROS 2 messages published.
    pub published: u64,
    /// Messages DDS refused (a reliable window full) or that could not be made.
    pub failed: u64,
    /// The instance's messages of another schema, refused.
    pub refused_messages: u64,
    /// Service requests done.
    pub requests_done: u64,
    /// Service requests refused (by the bridge: motion not allowed; or by the daemon).
    pub requests_refused: u64,
    /// Service requests that could not be read or answered.
    pub requests_bad: u64,
    /// Whether the ROS graph may move the arm.
    pub allow_motion: bool,
}

/// The bridge's own diagnostics: a warning once a request was refused or unreadable, or a message lost.
pub fn bridge_status(instance: &str, counts: &BridgeCounts) -> DiagnosticStatus {
    let troubled =
        counts.requests_refused + counts.requests_bad + counts.failed + counts.refused_messages > 0;
    DiagnosticStatus {
        level: if troubled { DiagnosticStatus::WARN } else { DiagnosticStatus::OK },
        name: format!("vservo/{instance}: ros2 bridge"),
        message: if counts.allow_motion { "motion commands on" } else { "motion commands off" }.to_string(),
        hardware_id: instance.to_string(),
        values: counters(&[
            ("published", counts.published),
            ("failed", counts.failed),
            ("refused_messages", counts.refused_messages),
            ("requests_done", counts.requests_done),
            ("requests_refused", counts.requests_refused),
            ("requests_bad", counts.requests_bad),
        ])
        .into_iter()
        .chain([key_value("allow_motion", counts.allow_motion)])
        .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::{Point2, Rotation3, Translation3};

    #[test]
    fn ros_time_splits_seconds_and_nanoseconds() {
        assert_eq!(
            time_of_unix_ns(1_700_000_000_123_456_789),
            Time { sec: 1_700_000_000, nanosec: 123_456_789 }
        );
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
        assert_eq!(
            (old.stamp_ns, old.restamped, old.late),
            (arrival_ns - 60_000_000, false, true),
            "kept, late"
        );
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
        let names = joint_names(&[], &config.arm);
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

    #[test]
    fn the_tf_chain_composes_to_the_camera_pose() {
        let arm = vservo_arm::puma560::puma560();
        let tool_from_camera = IsometryMatrix3::from_parts(
            Translation3::new(0.0, 0.05, 0.1),
            Rotation3::from_euler_angles(0.1, -0.2, 0.3),
        );
        let q = [0.3, -0.7, 0.9, 0.2, -0.4, 1.1, 0.0];
        let transforms = arm_transforms(&arm, &tool_from_camera, &state(6, q), Time::default());
        assert_eq!(transforms.len(), 7);
        let mut parent = BASE_FRAME.to_string();
        let mut base_from_child = IsometryMatrix3::identity();
        for t in &transforms {
            assert_eq!(t.header.frame_id, parent, "each frame the parent of the next");
            base_from_child *= pose_of(&t.transform);
            parent = t.child_frame_id.clone();
        }
        assert_eq!(parent, CAMERA_FRAME);
        let expected = arm.link_frames(&vservo_arm::JointVector::from(q))[5] * tool_from_camera;
        assert_relative_eq!(base_from_child.to_homogeneous(), expected.to_homogeneous(), epsilon = 1e-12);
        assert!(arm_transforms(&arm, &tool_from_camera, &state(7, q), Time::default()).is_empty());
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
        assert_eq!(
            (seen.header.frame_id.as_str(), seen.child_frame_id.as_str()),
            (CAMERA_FRAME, TARGET_FRAME)
        );
        assert_relative_eq!(
            pose_of(&seen.transform).to_homogeneous(),
            camera_from_board.to_homogeneous(),
            epsilon = 1e-9
        );
        message.valid_mask = 0b0111;
        assert!(
            target_transform(&camera, &board, &message, Time::default()).is_none(),
            "three marks: no pose"
        );
    }

    #[test]
    fn camera_info_in_opencv_pixels_with_the_lens() {
        let distortion = vservo_scene::Distortion::new([-0.2, 0.05, 0.001, -0.002, 0.0]).expect("a lens");
        let camera =
            CameraIntrinsics::with_lens([600.0, 610.0], Point2::new(320.0, 240.0), 640, 480, distortion)
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
}
