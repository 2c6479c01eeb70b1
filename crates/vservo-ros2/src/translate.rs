//! What the instance published, as the ROS 2 messages of the configured topics: joint states at most at the
//! configured rate with the arm's tf, each frame's features and the target as seen, each twist, each image
//! with its camera info, the diagnostics on request. The bridge publishes them over DDS, `vservoctl record
//! --ros2` writes them to MCAP, both a look at a time ([`Translator::look`], [`Looks`]).

use vservo_config::{Config, Ros2Topic};
use vservo_protocol::{
    CameraImageHeader, CameraTwistMsg, DaemonStatusMsg, FeaturesMsg, JointStateMsg, TelemetryMsg,
};

use std::time::{Duration, Instant};

use vservo_client::ClientError;

use crate::cell::{Arrived, Cell};
use crate::convert::{self, StampClock};
use crate::frames::ArmFrames;
use crate::msg::{
    CameraInfo, DiagnosticArray, DiagnosticStatus, Float64MultiArray, Image, JointState, MarkerArray,
    TfMessage, Time, TwistStamped,
};

/// A ROS 2 message of one of the bridge's topics.
#[derive(Debug, Clone, PartialEq)]
pub enum RosMessage {
    /// `joint_states`.
    JointState(JointState),
    /// `tf`.
    Tf(TfMessage),
    /// `tf_static`.
    TfStatic(TfMessage),
    /// `camera/image_raw`.
    Image(Image),
    /// `camera/camera_info`.
    CameraInfo(Box<CameraInfo>),
    /// `vservo/features`.
    Features(Float64MultiArray),
    /// `vservo/camera_twist`.
    CameraTwist(TwistStamped),
    /// `diagnostics`.
    Diagnostics(DiagnosticArray),
    /// `vservo/obstacles`.
    Obstacles(MarkerArray),
}

impl RosMessage {
    /// Its CDR as ROS 2 writes it to a bag ([`crate::schema::cdr`]).
    pub fn cdr(&self) -> Result<Vec<u8>, cdr_encoding::Error> {
        use crate::schema::cdr;
        match self {
            RosMessage::JointState(m) => cdr(m),
            RosMessage::Tf(m) | RosMessage::TfStatic(m) => cdr(m),
            RosMessage::Image(m) => cdr(m),
            RosMessage::CameraInfo(m) => cdr(m.as_ref()),
            RosMessage::Features(m) => cdr(m),
            RosMessage::CameraTwist(m) => cdr(m),
            RosMessage::Diagnostics(m) => cdr(m),
            RosMessage::Obstacles(m) => cdr(m),
        }
    }

    /// Its stamp (a tf message's first transform's), if it has one.
    pub fn stamp(&self) -> Option<Time> {
        match self {
            RosMessage::JointState(m) => Some(m.header.stamp),
            RosMessage::Tf(m) | RosMessage::TfStatic(m) => m.transforms.first().map(|t| t.header.stamp),
            RosMessage::Image(m) => Some(m.header.stamp),
            RosMessage::CameraInfo(m) => Some(m.header.stamp),
            RosMessage::Features(_) => None,
            RosMessage::CameraTwist(m) => Some(m.header.stamp),
            RosMessage::Diagnostics(m) => Some(m.header.stamp),
            RosMessage::Obstacles(m) => m.markers.first().map(|marker| marker.header.stamp),
        }
    }

    /// Its topic.
    pub fn topic(&self) -> Ros2Topic {
        match self {
            RosMessage::JointState(_) => Ros2Topic::JointStates,
            RosMessage::Tf(_) => Ros2Topic::Tf,
            RosMessage::TfStatic(_) => Ros2Topic::TfStatic,
            RosMessage::Image(_) => Ros2Topic::Image,
            RosMessage::CameraInfo(_) => Ros2Topic::CameraInfo,
            RosMessage::Features(_) => Ros2Topic::Features,
            RosMessage::CameraTwist(_) => Ros2Topic::CameraTwist,
            RosMessage::Diagnostics(_) => Ros2Topic::Diagnostics,
            RosMessage::Obstacles(_) => Ros2Topic::Obstacles,
        }
    }
}

/// Which topics, how often.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// The topics made.
    pub topics: Vec<Ros2Topic>,
    /// Every n-th camera image (the camera info comes with every frame).
    pub image_every: u64,
    /// Joint states (and the arm's tf) at most this often (Hz).
    pub joint_state_rate_hz: f64,
}

impl Selection {
    /// As `[ros2]` configures it.
    pub fn configured(config: &Config) -> Self {
        Self {
            topics: config.ros2.publish.clone(),
            image_every: u64::from(config.ros2.image_every),
            joint_state_rate_hz: config.ros2.joint_state_rate_hz,
        }
    }
}

/// How long a reader of the instance sleeps between looks.
pub const LOOK_EVERY: Duration = Duration::from_millis(2);
/// The clock offset is re-read, services not yet open are opened and diagnostics made this often.
const SLOW_EVERY: Duration = Duration::from_secs(1);

/// Which looks are the slow ones (once a second, the first at once).
#[derive(Debug)]
pub struct Looks {
    next_slow: Instant,
}

impl Default for Looks {
    fn default() -> Self {
        Self { next_slow: Instant::now() }
    }
}

impl Looks {
    /// Whether this look is a slow one.
    pub fn slow(&mut self) -> bool {
        let now = Instant::now();
        let slow = now >= self.next_slow;
        if slow {
            self.next_slow = now + SLOW_EVERY;
        }
        slow
    }
}

/// Turns what arrived into ROS 2 messages.
pub struct Translator {
    selection: Selection,
    instance: String,
    joint_names: Vec<String>,
    arm: vservo_arm::SerialArm,
    /// The arm's frames by its robot description's names.
    frames: ArmFrames,
    /// Whether `tf_static` and `vservo/obstacles` were made (once: they are transient local).
    fixed_made: bool,
    /// The collision guard's scene (`[collision]` given).
    collision: Option<vservo_config::Collision>,
    mount: vservo_scene::CameraMount,
    camera: vservo_scene::CameraIntrinsics,
    board: vservo_scene::Board,
    /// The system clock's offset from the monotonic one, read again on each slow look.
    clock: StampClock,
    /// The stamp of the last joint state made (ns, CLOCK_MONOTONIC).
    last_joint_state_ns: u64,
    joint_state_every_ns: u64,
    /// The daemon's newest status.
    status: Option<DaemonStatusMsg>,
    /// Each node's newest telemetry.
    telemetry: [Option<TelemetryMsg>; 4],
    /// Messages that cannot be made: an image of another format or short, a joint state of another arm
    /// (those of another schema the instance's side refuses, [`crate::cell::Cell::refused`]).
    refused: u64,
}

impl Translator {
    /// For the cell `config` describes.
    pub fn new(config: &Config, selection: Selection) -> Self {
        Self {
            joint_state_every_ns: vservo_time::Nanos::period_of_hz(selection.joint_state_rate_hz).get(),
            selection,
            instance: config.instance.clone(),
            joint_names: convert::joint_names(&config.ros2.joint_names, &config.cell.arm),
            arm: config.cell.arm.clone(),
            frames: ArmFrames::of(&config.cell.arm),
            fixed_made: false,
            collision: config.cell.collision.clone(),
            mount: config.cell.mount(),
            camera: config.cell.camera,
            board: config.cell.board,
            clock: StampClock::now(),
            last_joint_state_ns: 0,
            status: None,
            telemetry: [None; 4],
            refused: 0,
        }
    }

    /// One look at the instance: what arrived, and each image, as messages to `out`; on a slow look the clock
    /// offset read again, the services not yet open opened, and the diagnostics with `extra(refused)` (the
    /// messages refused so far) after the cell's and nodes'.
    pub fn look(
        &mut self,
        cell: &mut Cell,
        slow: bool,
        extra: impl FnOnce(u64) -> Vec<DiagnosticStatus>,
        out: &mut impl FnMut(RosMessage),
    ) -> Result<(), ClientError> {
        if slow {
            self.clock = StampClock::now();
            cell.open();
        }
        if !self.fixed_made {
            self.fixed(out);
        }
        let mut arrived = Arrived::default();
        cell.take(&mut arrived);
        self.take(&arrived, out);
        cell.each_image(|header, pixels| self.image(header, pixels, out))?;
        if slow {
            self.diagnostics(extra(cell.refused + self.refused), out);
        }
        Ok(())
    }

    /// What does not move, once: `tf_static`, and the guard's obstacles (a cell with `[collision]`).
    fn fixed(&mut self, out: &mut impl FnMut(RosMessage)) {
        let stamp = self.clock.ros_time(vservo_time::monotonic_ns());
        if self.wants(Ros2Topic::TfStatic) {
            out(RosMessage::TfStatic(TfMessage { transforms: self.frames.fixed(&self.mount, stamp) }));
        }
        if let Some(collision) = self.collision.as_ref().filter(|_| self.wants(Ros2Topic::Obstacles)) {
            out(RosMessage::Obstacles(crate::obstacles::markers(collision, &self.frames.base, stamp)));
        }
        self.fixed_made = true;
    }

    fn wants(&self, topic: Ros2Topic) -> bool {
        self.selection.topics.contains(&topic)
    }

    /// What arrived (of this schema: the inbox refused the others), as messages to `out`; the status and telemetry kept for [`Translator::diagnostics`].
    fn take(&mut self, arrived: &Arrived, out: &mut impl FnMut(RosMessage)) {
        self.status = arrived.status.or(self.status);
        for (kept, new) in self.telemetry.iter_mut().zip(arrived.telemetry) {
            *kept = new.or(*kept);
        }
        if let Some(state) = &arrived.joint_state {
            self.joint_state(state, out);
        }
        for features in &arrived.features {
            self.features(features, out);
        }
        for twist in &arrived.twists {
            self.twist(twist, out);
        }
    }

    /// `joint_states` and the arm's `tf`, at most at the selected rate.
    fn joint_state(&mut self, state: &JointStateMsg, out: &mut impl FnMut(RosMessage)) {
        if state.stamp_ns.saturating_sub(self.last_joint_state_ns) < self.joint_state_every_ns {
            return;
        }
        self.last_joint_state_ns = state.stamp_ns;
        let stamp = self.clock.ros_time(state.stamp_ns);
        if self.wants(Ros2Topic::JointStates) {
            match convert::joint_state(state, &self.joint_names, stamp) {
                Some(message) => out(RosMessage::JointState(message)),
                None => self.refused += 1,
            }
        }
        if self.wants(Ros2Topic::Tf) {
            let transforms = self.frames.moving(&self.arm, state, stamp);
            if !transforms.is_empty() {
                out(RosMessage::Tf(TfMessage { transforms }));
            }
        }
    }

    /// A frame's features, and the target as seen in them on `tf`, stamped with the frame's exposure.
    fn features(&mut self, features: &FeaturesMsg, out: &mut impl FnMut(RosMessage)) {
        if self.wants(Ros2Topic::Features) {
            out(RosMessage::Features(convert::features(features)));
        }
        let stamp = self.clock.ros_time(features.capture_stamp_ns);
        if self.wants(Ros2Topic::Tf)
            && let Some(target) = convert::target_transform(&self.camera, &self.board, features, stamp)
        {
            out(RosMessage::Tf(TfMessage { transforms: vec![target] }));
        }
    }

    fn twist(&mut self, twist: &CameraTwistMsg, out: &mut impl FnMut(RosMessage)) {
        if self.wants(Ros2Topic::CameraTwist) {
            out(RosMessage::CameraTwist(convert::twist(twist, self.clock.ros_time(twist.stamp_ns))));
        }
    }

    /// A camera image (every n-th) and its camera info, with the exposure's stamp.
    fn image(&mut self, header: &CameraImageHeader, pixels: &[u8], out: &mut impl FnMut(RosMessage)) {
        let stamp = self.clock.ros_time(header.capture_stamp_ns);
        if self.wants(Ros2Topic::CameraInfo) {
            out(RosMessage::CameraInfo(Box::new(convert::camera_info(&self.camera, stamp))));
        }
        let every = self.selection.image_every.max(1);
        if self.wants(Ros2Topic::Image) && header.frame.is_multiple_of(every) {
            match convert::image(header, pixels, stamp) {
                Some(image) => out(RosMessage::Image(image)),
                None => self.refused += 1,
            }
        }
    }

    /// The cell's and nodes' diagnostics (each node's telemetry if it is of the process the daemon runs) and
    /// `extra`; none before the daemon's first status.
    fn diagnostics(&self, extra: Vec<DiagnosticStatus>, out: &mut impl FnMut(RosMessage)) {
        let Some(status) = self.status else { return };
        if !self.wants(Ros2Topic::Diagnostics) {
            return;
        }
        let telemetry: [Option<TelemetryMsg>; 4] =
            std::array::from_fn(|i| self.telemetry[i].filter(|t| status.nodes[i].pid == t.pid));
        let view = vservo_client::StatusView::new(&self.instance, &status, &telemetry);
        let mut message = convert::diagnostics(&view, self.clock.ros_time(status.stamp_ns));
        message.status.extend(extra);
        out(RosMessage::Diagnostics(message));
    }
}
