//! The bridge's loop: every few milliseconds it takes what the instance published and publishes it to ROS 2
//! (`vservo_ros2::translate`), then answers the services' requests; once a second it publishes the
//! diagnostics and reads the system clock's offset again.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use vservo_config::Config;
use vservo_ros2::cell::{Arrived, Cell};
use vservo_ros2::convert::{self, BridgeCounts};
use vservo_ros2::translate::{RosMessage, Selection, Translator};

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
    let Some(mut cell) = Cell::connect(&config.instance, || vservo_protocol::signals::stopped(stop))? else {
        return Ok(());
    };
    tracing::info!(instance = %config.instance, "bridging the instance");
    let mut bridge = Bridge {
        config,
        config_path,
        translator: Translator::new(config, Selection::configured(config), convert::StampClock::now()),
        graph,
        requests: Counts::default(),
        published: 0,
        failed: 0,
    };
    let mut next_slow = Instant::now();
    while !vservo_protocol::signals::stopped(stop) {
        let slow = Instant::now() >= next_slow;
        if slow {
            next_slow = Instant::now() + SLOW_EVERY;
            bridge.translator.clock = convert::StampClock::now();
            cell.open();
        }
        bridge.step(&mut cell, slow)?;
        std::thread::sleep(LOOK_EVERY);
    }
    tracing::info!(published = bridge.published, failed = bridge.failed, "stopped (SIGINT/SIGTERM)");
    Ok(())
}

struct Bridge<'a> {
    config: &'a Config,
    config_path: &'a Path,
    translator: Translator,
    graph: Graph,
    requests: Counts,
    /// Messages published.
    published: u64,
    /// Messages DDS refused (a reliable window full).
    failed: u64,
}

impl Bridge<'_> {
    /// One look: what arrived, published; the requests answered.
    fn step(&mut self, cell: &mut Cell, slow: bool) -> anyhow::Result<()> {
        let mut arrived = Arrived::default();
        cell.take(&mut arrived);
        let graph = &self.graph;
        let (mut published, mut failed) = (0, 0);
        let mut publish = |message: RosMessage| match graph.publish(message) {
            Ok(()) => published += 1,
            Err(()) => failed += 1,
        };
        self.translator.take(&arrived, &mut publish);
        cell.each_image(|header, pixels| self.translator.image(header, pixels, &mut publish))?;
        if slow {
            let counts = BridgeCounts {
                published: self.published,
                failed: self.failed,
                refused_messages: cell.refused + self.translator.refused,
                requests_done: self.requests.done,
                requests_refused: self.requests.refused,
                requests_bad: self.requests.bad,
                allow_motion: self.config.ros2.allow_motion,
            };
            let bridge_status = convert::bridge_status(&self.config.instance, &counts);
            self.translator.diagnostics(vec![bridge_status], &mut publish);
        }
        self.published += published;
        self.failed += failed;
        Services {
            client: &mut cell.client,
            instance: &self.config.instance,
            allow_motion: self.config.ros2.allow_motion,
            config_path: self.config_path,
            counts: &mut self.requests,
        }
        .serve(&self.graph);
        Ok(())
    }
}
