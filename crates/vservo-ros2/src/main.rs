//! `vservo-ros2`: a vservo instance in a ROS 2 graph (docs/ROS2.md). vservod starts it with `[ros2]
//! enabled = true` and restarts it if it ends; it also runs on its own: `vservo-ros2 --config FILE`.
//!
//! It publishes what the instance's services carry as ROS 2 messages (`joint_states`, `tf`, the camera's
//! image and camera info, the features, the twist, `diagnostics`) and serves `vservo/safe_stop` (always
//! taken: the instance's safe-stop path, which no client can crowd out) and `vservo/resume` (refused unless
//! `[ros2] allow_motion`). It never writes to the loop's services.
//!
//! The instance's robot and camera driver over ROS 2 (`[robot] driver = "ros2"`, `[camera] source = "ros2"`),
//! which owns the arm, is another program: `vservo-ros2-driver` (src/driver_main.rs), so that the bridge, which
//! only observes, cannot command the arm.
//!
//! The binary's modules: [`graph`] (the participant, on one interface if configured, the node, a publisher per
//! configured topic, `vservo/safe_stop` and `vservo/resume` as `std_srvs/Trigger` with ROS 2's Cyclone DDS
//! request/reply mapping); [`bridge`] (the loop: a look at the instance, published over DDS, then the
//! services); [`services`] (safe stop on the safe-stop path, always; resume and the targets —
//! `vservo_msgs/SetTargetFeatures`, `SetTargetPose`, clients/ros2/vservo_msgs — only with `allow_motion`,
//! checked by the daemon as any client's; each request counted).
//!
//! Exit codes: 0 after SIGINT/SIGTERM, 1 on an error, 2 on a configuration it cannot run.

mod bridge;
mod graph;
mod services;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

/// The bridge from a vservo instance to a ROS 2 graph over DDS.
#[derive(Parser, Debug)]
#[command(name = "vservo-ros2", version)]
struct Cli {
    /// The instance's configuration: its `[instance] name`, `[ros2]` and the cell's arm, camera and board.
    #[arg(long, value_name = "FILE", default_value = "config/vservo.toml")]
    config: PathBuf,
    /// Refused: the ROS 2 driver is its own program, `vservo-ros2-driver` (this one only observes).
    #[arg(long, hide = true)]
    driver: bool,
    /// Started by this vservod: end when it does, however it ends.
    #[arg(long, value_name = "PID", hide = true)]
    daemon_pid: Option<i32>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    vservo_driver::logging::to_stderr("info,rustdds=error,ros2_client=error");
    if cli.driver {
        tracing::error!(
            "--driver: the ROS 2 driver is its own program now, `vservo-ros2-driver --config FILE`; `vservo-ros2` is \
             the bridge, which only observes"
        );
        return ExitCode::from(2);
    }
    let config = match vservo_config::Config::load(&cli.config) {
        Ok(config) => config,
        Err(error) => {
            tracing::error!("{error}");
            return ExitCode::from(2);
        }
    };
    vservo_driver::logging::exit_code(vservo_protocol::signals::run_until_stopped(cli.daemon_pid, |stop| {
        bridge::run(&config, &cli.config, stop)
    }))
}
