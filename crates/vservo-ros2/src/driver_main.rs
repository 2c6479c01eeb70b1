//! `vservo-ros2-driver`: the instance's robot and camera driver over ROS 2 (docs/ROS2.md, "ROS 2 as the
//! driver"): a ros2_control arm (`[robot] driver = "ros2"`) and a ROS camera (`[camera] source = "ros2"`).
//! vservod starts it when either is configured, restarts it if it ends and ends it with itself; it also runs on
//! its own: `vservo-ros2-driver --config FILE`. The bridge (`vservo-ros2`), which only observes, is another
//! program: only this one holds the arm's and the camera's writer slots.
//!
//! [`driver`]: the node `vservo_driver`, the arm's joint states and the camera's images woken on by mio, each
//! passed on as it arrives through `vservo_ros2::arm_driver` and `vservo_ros2::image_in` onto the robot and
//! camera streams' one writer slots, header stamps mapped to CLOCK_MONOTONIC
//! (`vservo_ros2::convert::StampClock::arrival`: replaced when none or in the future beyond `[ros2.driver]
//! clock_tolerance_s`, flagged when older), the arm's period checked, rest commanded while the arm is silent and
//! at the end.
//!
//! Exit codes: 0 after SIGINT/SIGTERM, 1 on an error, 2 on a configuration it cannot run.

mod driver;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

/// The robot and camera driver of a vservo instance over ROS 2.
#[derive(Parser, Debug)]
#[command(name = "vservo-ros2-driver", version)]
struct Cli {
    /// The instance's configuration: its `[instance] name`, `[robot]`, `[camera]` and `[ros2.driver]`.
    #[arg(long, value_name = "FILE", default_value = "config/vservo.toml")]
    config: PathBuf,
    /// Started by this vservod: end when it does, however it ends.
    #[arg(long, value_name = "PID", hide = true)]
    daemon_pid: Option<i32>,
    /// Read the run's seal key from stdin, as vservod hands it: without it no command is the rmrc's, and none is
    /// taken.
    #[arg(long, hide = true)]
    seal_key_stdin: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    vservo_driver::logging::to_stderr("info,rustdds=error,ros2_client=error");
    let key = match vservo_driver::seal_key(cli.seal_key_stdin) {
        Ok(key) => key,
        Err(error) => {
            tracing::error!("{error:#}");
            return ExitCode::from(2);
        }
    };
    let config = match vservo_config::Config::load(&cli.config) {
        Ok(config) => config,
        Err(error) => {
            tracing::error!("{error}");
            return ExitCode::from(2);
        }
    };
    vservo_driver::logging::exit_code(vservo_protocol::signals::run_until_stopped(cli.daemon_pid, |stop| {
        driver::run(&config, key.clone(), stop)
    }))
}
