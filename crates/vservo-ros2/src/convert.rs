//! vservo's messages as ROS 2 messages.
//!
//! Pure functions, but [`StampClock::now`], which reads the clocks.
//!
//! Conventions at the ROS boundary (docs/ROS2.md):
//! - stamps are ROS time, the system clock's (CLOCK_REALTIME); vservo stamps with CLOCK_MONOTONIC, and
//!   [`StampClock`] carries the offset between the two;
//! - pixels are OpenCV's and ROS's (a pixel's centre at whole coordinates): vservo's pixel centre is at + ½
//!   (docs/ARCHITECTURE.md), so the principal point and the features are ½ px less here;
//! - frames: the arm's by its robot description's names (crate::frames), `camera_optical_frame` (x right, y
//!   down, z along the axis, ROS's optical convention), `target` (the board as the camera sees it).

use nalgebra::{IsometryMatrix3, UnitQuaternion};
use vservo_client::StatusView;
use vservo_protocol::{CameraImageHeader, CameraTwistMsg, FeaturesMsg, JointStateMsg, MARKS, PixelFormat};
use vservo_scene::OPENCV_TO_VSERVO_PX;
use vservo_scene::{Board, CameraIntrinsics};

use crate::msg::{
    CameraInfo, DiagnosticArray, DiagnosticStatus, Float64MultiArray, Header, Image, JointState, KeyValue,
    MultiArrayDimension, MultiArrayLayout, Quaternion, RegionOfInterest, Time, Transform, TransformStamped,
    Twist, TwistStamped, Vector3,
};

/// The camera's optical frame (x right, y down, z along the axis), as ROS names such a frame.
pub const CAMERA_FRAME: &str = "camera_optical_frame";
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
                .map_or(0, |t| vservo_time::join_signed(i128::from(t.tv_sec()), t.tv_nsec() as u32))
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
        let unix_ns = vservo_time::join_signed(i128::from(stamp.sec), stamp.nanosec);
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
    let (sec, nanosec) = vservo_time::split_signed(unix_ns);
    Time { sec: sec.clamp(i128::from(i32::MIN), i128::from(i32::MAX)) as i32, nanosec }
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

/// The board as the camera sees it (`camera_optical_frame` → `target`) from a frame's features, at the capture; `None`
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
mod tests;
