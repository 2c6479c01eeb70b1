//! The bridge's loop: every few milliseconds it takes what the instance published and publishes it to ROS 2,
//! then answers the services' requests; once a second it publishes the diagnostics and reads the system
//! clock's offset again.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use ros2_client::Publisher;
use vservo_config::Config;
use vservo_protocol::{CameraImageHeader, DaemonStatusMsg, JointStateMsg, SCHEMA_VERSION, TelemetryMsg};
use vservo_ros2::convert::{self, StampClock};
use vservo_ros2::msg::{CameraInfo, TfMessage};

use crate::cell::{Arrived, Cell};
use crate::graph::Graph;
use crate::services::{Counts, Services};

/// How long the loop sleeps between looks.
const LOOK_EVERY: Duration = Duration::from_millis(2);
/// Diagnostics, the services not yet open and the clock offset, this often.
const SLOW_EVERY: Duration = Duration::from_secs(1);

/// Runs until `stop` is set.
pub fn run(config: &Config, config_path: &Path, stop: &AtomicBool) -> anyhow::Result<()> {
    let graph = Graph::open(&config.ros2)?;
    tracing::info!(
        domain_id = config.ros2.domain_id,
        namespace = %config.ros2.namespace,
        interface = ?config.ros2.interface,
        allow_motion = config.ros2.allow_motion,
        "in the ROS 2 graph"
    );
    let Some(mut cell) = Cell::connect(&config.instance, stop)? else { return Ok(()) };
    tracing::info!(instance = %config.instance, "bridging the instance");
    let mut bridge = Bridge::new(config, config_path, graph);
    let mut next_slow = Instant::now();
    while !vservo_protocol::signals::stopped(stop) {
        let slow = Instant::now() >= next_slow;
        if slow {
            next_slow = Instant::now() + SLOW_EVERY;
            bridge.clock = stamp_clock();
            cell.open();
        }
        bridge.step(&mut cell, slow)?;
        std::thread::sleep(LOOK_EVERY);
    }
    tracing::info!(published = bridge.published, failed = bridge.failed, "stopped (SIGINT/SIGTERM)");
    Ok(())
}

/// CLOCK_REALTIME − CLOCK_MONOTONIC, now.
fn stamp_clock() -> StampClock {
    use nix::time::{ClockId, clock_gettime};
    let ns = |clock| {
        clock_gettime(clock).map_or(0, |t| i128::from(t.tv_sec()) * 1_000_000_000 + i128::from(t.tv_nsec()))
    };
    let monotonic = ns(ClockId::CLOCK_MONOTONIC);
    let realtime = ns(ClockId::CLOCK_REALTIME);
    StampClock { realtime_minus_monotonic_ns: realtime - monotonic }
}

struct Bridge<'a> {
    config: &'a Config,
    config_path: &'a Path,
    graph: Graph,
    clock: StampClock,
    joint_names: Vec<String>,
    /// The stamp of the last joint state published (ns, CLOCK_MONOTONIC).
    last_joint_state_ns: u64,
    joint_state_every_ns: u64,
    /// The daemon's newest status.
    status: Option<DaemonStatusMsg>,
    /// Each node's newest telemetry.
    telemetry: [Option<TelemetryMsg>; 4],
    requests: Counts,
    /// Messages published.
    published: u64,
    /// Messages DDS refused (a reliable window full) or that could not be made.
    failed: u64,
    /// Images of another schema, refused.
    refused_images: u64,
}

impl<'a> Bridge<'a> {
    fn new(config: &'a Config, config_path: &'a Path, graph: Graph) -> Self {
        Self {
            config,
            config_path,
            graph,
            clock: stamp_clock(),
            joint_names: convert::joint_names(&config.ros2.joint_names, config.arm.joint_count()),
            last_joint_state_ns: 0,
            joint_state_every_ns: (1e9 / config.ros2.joint_state_rate_hz) as u64,
            status: None,
            telemetry: [None; 4],
            requests: Counts::default(),
            published: 0,
            failed: 0,
            refused_images: 0,
        }
    }

    /// One look: what arrived, published; the requests answered.
    fn step(&mut self, cell: &mut Cell, slow: bool) -> anyhow::Result<()> {
        let mut arrived = Arrived::default();
        cell.take(&mut arrived);
        self.status = arrived.status.or(self.status);
        for (kept, new) in self.telemetry.iter_mut().zip(arrived.telemetry) {
            *kept = new.or(*kept);
        }
        if let Some(state) = arrived.joint_state {
            self.joint_state(&state);
        }
        for features in &arrived.features {
            self.features(features);
        }
        for twist in &arrived.twists {
            let message = convert::twist(twist, self.clock.ros_time(twist.stamp_ns));
            publish(&self.graph.camera_twist, message, &mut self.published, &mut self.failed);
        }
        cell.each_image(|header, pixels| self.image(header, pixels))?;
        if slow {
            self.diagnostics(cell.refused);
        }
        Services {
            client: &mut cell.client,
            instance: &self.config.instance,
            allow_motion: self.config.ros2.allow_motion,
            config_path: self.config_path,
            counts: &mut self.requests,
        }
        .serve(&self.graph.safe_stop, &self.graph.resume);
        Ok(())
    }

    /// A frame's features, and the target as seen in them on `tf`, stamped with the frame's exposure.
    fn features(&mut self, features: &vservo_protocol::FeaturesMsg) {
        if features.schema != SCHEMA_VERSION {
            return;
        }
        let stamp = self.clock.ros_time(features.capture_stamp_ns);
        publish(&self.graph.features, convert::features(features), &mut self.published, &mut self.failed);
        if self.graph.tf.is_some()
            && let Some(target) =
                convert::target_transform(&self.config.camera, &self.config.board, features, stamp)
        {
            let message = TfMessage { transforms: vec![target] };
            publish(&self.graph.tf, message, &mut self.published, &mut self.failed);
        }
    }

    /// `joint_states` and the arm's `tf`, at most at the configured rate.
    fn joint_state(&mut self, state: &JointStateMsg) {
        if state.schema != SCHEMA_VERSION
            || state.stamp_ns.saturating_sub(self.last_joint_state_ns) < self.joint_state_every_ns
        {
            return;
        }
        self.last_joint_state_ns = state.stamp_ns;
        let stamp = self.clock.ros_time(state.stamp_ns);
        match convert::joint_state(state, &self.joint_names, stamp) {
            Some(message) => {
                publish(&self.graph.joint_states, message, &mut self.published, &mut self.failed)
            }
            None => self.failed += 1,
        }
        if self.graph.tf.is_some() {
            let transforms =
                convert::arm_transforms(&self.config.arm, &self.config.tool_from_camera, state, stamp);
            publish(&self.graph.tf, TfMessage { transforms }, &mut self.published, &mut self.failed);
        }
    }

    /// A camera image (every `image_every`-th) and its camera info, with the exposure's stamp.
    fn image(&mut self, header: &CameraImageHeader, pixels: &[u8]) {
        if header.schema != SCHEMA_VERSION {
            self.refused_images += 1;
            return;
        }
        let stamp = self.clock.ros_time(header.capture_stamp_ns);
        let info: CameraInfo = convert::camera_info(&self.config.camera, stamp);
        publish(&self.graph.camera_info, info, &mut self.published, &mut self.failed);
        if header.frame.is_multiple_of(u64::from(self.config.ros2.image_every)) && self.graph.image.is_some()
        {
            match convert::image(header, pixels, stamp) {
                Some(image) => publish(&self.graph.image, image, &mut self.published, &mut self.failed),
                None => self.refused_images += 1,
            }
        }
    }

    /// The cell's and nodes' diagnostics (each node's telemetry if it is of the process the daemon runs), and
    /// the bridge's own; none before the daemon's first status.
    fn diagnostics(&mut self, refused_messages: u64) {
        let Some(status) = self.status else { return };
        let telemetry: [Option<TelemetryMsg>; 4] =
            std::array::from_fn(|i| self.telemetry[i].filter(|t| status.nodes[i].pid == t.pid));
        let view = vservo_client::StatusView::new(&self.config.instance, &status, &telemetry);
        let mut message = convert::diagnostics(&view, self.clock.ros_time(status.stamp_ns));
        let counts = convert::BridgeCounts {
            published: self.published,
            failed: self.failed,
            refused_messages: refused_messages + self.refused_images,
            requests_done: self.requests.done,
            requests_refused: self.requests.refused,
            requests_bad: self.requests.bad,
            allow_motion: self.config.ros2.allow_motion,
        };
        message.status.push(convert::bridge_status(&self.config.instance, &counts));
        publish(&self.graph.diagnostics, message, &mut self.published, &mut self.failed);
    }
}

/// Publishes on `publisher` if the topic is configured; counts what was published and what DDS refused.
fn publish<T: serde::Serialize>(
    publisher: &Option<Publisher<T>>,
    message: T,
    published: &mut u64,
    failed: &mut u64,
) {
    let Some(publisher) = publisher else { return };
    match publisher.publish(message) {
        Ok(()) => *published += 1,
        Err(_) => *failed += 1,
    }
}
