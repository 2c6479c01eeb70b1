//! The bridge's loop: every few milliseconds it takes what the instance published and publishes it to ROS 2
//! (`vservo_ros2::translate`, the diagnostics once a second), then answers the services' requests.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use vservo_config::Config;
use vservo_ros2::cell::Cell;
use vservo_ros2::convert::{self, BridgeCounts};
use vservo_ros2::translate::{LOOK_EVERY, Looks, RosMessage, Selection, Translator};

use crate::graph::Graph;
use crate::services::{Counts, Services};

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
        translator: Translator::new(config, Selection::configured(config)),
        graph,
        requests: Counts::default(),
        published: 0,
        failed: 0,
    };
    let mut looks = Looks::default();
    while !vservo_protocol::signals::stopped(stop) {
        bridge.step(&mut cell, looks.slow())?;
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
        let graph = &self.graph;
        let (mut published, mut failed) = (0, 0);
        let mut publish = |message: RosMessage| match graph.publish(message) {
            Ok(()) => published += 1,
            Err(()) => failed += 1,
        };
        let bridge_status = |refused_messages| {
            let counts = BridgeCounts {
                published: self.published,
                failed: self.failed,
                refused_messages,
                requests_done: self.requests.done,
                requests_refused: self.requests.refused,
                requests_bad: self.requests.bad,
                allow_motion: self.config.ros2.allow_motion,
            };
            vec![convert::bridge_status(&self.config.instance, &counts)]
        };
        self.translator.look(cell, slow, bridge_status, &mut publish)?;
        self.published += published;
        self.failed += failed;
        Services {
            client: &mut cell.client,
            allow_motion: self.config.ros2.allow_motion,
            config_path: self.config_path,
            counts: &mut self.requests,
        }
        .serve(&self.graph);
        Ok(())
    }
}
