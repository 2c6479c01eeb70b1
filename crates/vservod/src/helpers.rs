//! The helper processes vservod starts when the configuration asks for them, restarts if they end and stops
//! with the cell: the live view (`[viewer] enabled = true`: `vservoctl view` on the configured address and
//! port), the ROS 2 bridge (`[ros2] enabled = true`: `vservo-ros2`), and the drivers the configuration names:
//! the ROS 2 driver (`[robot] driver` or `[camera] source` = `"ros2"`: `vservo-ros2-driver`), the Franka
//! driver (`[robot] driver = "franka"`: `vservo-franka`) and the GStreamer camera (`[camera] source =
//! "gstreamer"`: `vservo-gst-camera`), all installed next to vservod. An `"external"` driver is the user's to
//! start: vservod never starts it. The viewer and the bridge are clients of the instance like any other: they
//! read with iceoryx2's safe overflow, so a slow or absent helper never slows the loop, and its failure is a
//! warning, never a fault of the cell. A driver is the cell's: while it is away the arm is found stalled (or
//! the camera silent) and the cell stops safely, as with any driver. The robot drivers are handed the run's seal
//! key on their stdin, as the nodes are (`--seal-key-stdin`): they take only the rmrc's sealed commands and the
//! daemon's sealed cell modes (`vservo_driver::DriverSide`).
//!
//! Each helper is a row of [`HELPERS`] (its program, when the configuration asks for it, its arguments, whether
//! it gets the key, when it stops); the supervisor starts, polls and stops the list, naming none of them.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_protocol::seal::SealKey;

/// After a helper ended, wait this long before starting it again.
const RESTART_AFTER: Duration = Duration::from_secs(5);

/// A helper process, if the configuration asks for it.
pub struct Helper {
    /// What it is, for the log.
    what: &'static str,
    stops: Stops,
    command: Command,
    /// The run's key, written on its stdin at each start (a robot driver's).
    key: Option<SealKey>,
    child: Option<Child>,
    restart_at: Option<Instant>,
}

/// Where the helpers are and what they are given.
pub struct Launch<'a> {
    /// vservod's own executable: the helpers are installed next to it.
    pub vservod: &'a Path,
    /// The configuration in force, as vservod wrote it into the instance's directory (every key resolved,
    /// paths absolute; written again after a reload): a helper runs what the nodes run, not a file edited since.
    pub config_path: &'a Path,
    /// The instance's runtime base.
    pub runtime_base: &'a Path,
    /// The run's seal key, for the robot drivers.
    pub seal_key: &'a SealKey,
}

impl Launch<'_> {
    /// `program` (next to vservod) with `args` and `--config`, run as vservod's own processes are.
    fn command(&self, program: &str, args: &[String]) -> Command {
        let mut command = Command::new(self.vservod.with_file_name(program));
        command
            .args(args)
            .arg("--config")
            .arg(self.config_path)
            .env(vservo_protocol::instance_dir::RUNTIME_DIR_ENV, self.runtime_base)
            .env_remove("NOTIFY_SOCKET")
            .env_remove("WATCHDOG_USEC")
            .env_remove("WATCHDOG_PID")
            .stdin(Stdio::null());
        command
    }
}

/// When a helper stops: an observer before the arm is brought to rest, a driver after (it carries the ramp to rest
/// to the arm, then commands rest as it ends).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stops {
    /// With the observers, first.
    First,
    /// With the arm's drivers, last.
    Last,
}

/// One helper vservod may start: a row of [`HELPERS`]. A new in-tree helper is its program and one row.
pub struct HelperRow {
    /// What it is, for the log.
    pub what: &'static str,
    /// Its program, installed next to vservod.
    pub program: &'static str,
    /// Whether the configuration asks for it.
    pub runs: fn(&vservo_config::Config) -> bool,
    /// Its arguments before `--config` (none but `--daemon-pid` for most).
    pub args: fn(&vservo_config::Config) -> Vec<String>,
    /// Whether it is handed the run's seal key on its stdin (a robot driver's, `--seal-key-stdin`).
    pub keyed: bool,
    /// When it stops.
    pub stops: Stops,
}

/// `--daemon-pid` and this daemon's process id: a helper that ends with the daemon.
fn ends_with_the_daemon(_: &vservo_config::Config) -> Vec<String> {
    vec!["--daemon-pid".to_string(), std::process::id().to_string()]
}

/// The live view's arguments: the configured address, port and viewers.
fn viewer_args(config: &vservo_config::Config) -> Vec<String> {
    let viewer = &config.viewer;
    let args = ["view", "--address", &viewer.address, "--port", &viewer.port.to_string()];
    args.into_iter()
        .map(String::from)
        .chain(["--max-clients".to_string(), viewer.max_clients.to_string()])
        .collect()
}

/// Every helper vservod may start, in the order it starts them.
pub const HELPERS: [HelperRow; 5] = [
    HelperRow {
        what: "the Foxglove viewer",
        program: "vservoctl",
        runs: |config| config.viewer.enabled,
        args: viewer_args,
        keyed: false,
        stops: Stops::First,
    },
    HelperRow {
        what: "the ROS 2 bridge",
        program: "vservo-ros2",
        runs: |config| config.ros2.enabled,
        args: ends_with_the_daemon,
        keyed: false,
        stops: Stops::First,
    },
    HelperRow {
        what: "the ROS 2 driver",
        program: "vservo-ros2-driver",
        runs: vservo_config::Config::runs_ros2_driver,
        args: ends_with_the_daemon,
        keyed: true,
        stops: Stops::Last,
    },
    HelperRow {
        what: "the Franka driver",
        program: "vservo-franka",
        runs: |config| config.cell.robot.driver == vservo_config::RobotDriver::Franka,
        args: ends_with_the_daemon,
        keyed: true,
        stops: Stops::Last,
    },
    HelperRow {
        what: "the GStreamer camera",
        program: "vservo-gst-camera",
        runs: |config| config.cell.vision.source == vservo_config::VisionSource::Gstreamer,
        args: ends_with_the_daemon,
        keyed: false,
        stops: Stops::Last,
    },
];

/// The helpers of [`HELPERS`] the configuration asks for, each started now.
pub fn start_helpers(config: &vservo_config::Config, launch: &Launch) -> Vec<Helper> {
    HELPERS
        .iter()
        .filter(|row| (row.runs)(config))
        .map(|row| {
            let command = launch.command(row.program, &(row.args)(config));
            let key = row.keyed.then_some(launch.seal_key);
            Helper::start(row.what, row.stops, command, key)
        })
        .collect()
}

impl Helper {
    /// When it stops.
    pub fn stops(&self) -> Stops {
        self.stops
    }

    /// Starts `command`; a robot driver (`key` given) is handed the run's key on its stdin at each start.
    fn start(what: &'static str, stops: Stops, mut command: Command, key: Option<&SealKey>) -> Self {
        if key.is_some() {
            command.arg("--seal-key-stdin").stdin(Stdio::piped());
        }
        let key = key.cloned();
        let mut helper = Self { what, stops, command, key, child: None, restart_at: Some(Instant::now()) };
        helper.poll();
        helper
    }

    /// Writes the key line on the child's stdin and closes it; a child that cannot be handed its key is ended.
    fn hand_key(&self, child: &mut Child) -> std::io::Result<()> {
        let (Some(key), Some(mut stdin)) = (self.key.as_ref(), child.stdin.take()) else { return Ok(()) };
        vservo_protocol::seal::write_key_line(key, &mut stdin)
    }

    /// Starts the helper again once it has been gone for [`RESTART_AFTER`]; call every supervisor cycle.
    pub fn poll(&mut self) {
        if let Some(child) = &mut self.child
            && let Ok(Some(status)) = child.try_wait()
        {
            tracing::warn!(%status, restart_in_s = RESTART_AFTER.as_secs_f64(), "{} ended", self.what);
            self.child = None;
            self.restart_at = Some(Instant::now() + RESTART_AFTER);
        }
        if self.child.is_none() && self.restart_at.is_some_and(|at| Instant::now() >= at) {
            self.restart_at = None;
            match self.command.spawn() {
                Ok(mut child) => {
                    if let Err(error) = self.hand_key(&mut child) {
                        tracing::warn!(%error, "{} could not be handed the run's key: ended", self.what);
                        let _ = child.kill();
                    }
                    tracing::info!(pid = child.id(), "{} started", self.what);
                    self.child = Some(child);
                }
                Err(error) => {
                    tracing::warn!(%error, "{} could not be started", self.what);
                    self.restart_at = Some(Instant::now() + RESTART_AFTER);
                }
            }
        }
    }

    /// Stops the helper (SIGTERM, then SIGKILL after a second).
    pub fn stop(&mut self) {
        let Some(mut child) = self.child.take() else { return };
        let _ = kill(Pid::from_raw(child.id() as i32), Signal::SIGTERM);
        let until = Instant::now() + Duration::from_secs(1);
        while Instant::now() < until {
            if let Ok(Some(_)) = child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = child.kill();
        let _ = child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_helper_is_one_row_the_robot_drivers_keyed_and_stopped_after_the_arm_is_at_rest() {
        let programs: std::collections::BTreeSet<&str> = HELPERS.iter().map(|row| row.program).collect();
        assert_eq!(programs.len(), HELPERS.len(), "a program per row");
        for row in &HELPERS {
            let drives_the_arm = row.keyed;
            assert_eq!(
                drives_the_arm,
                ["vservo-ros2-driver", "vservo-franka"].contains(&row.program),
                "{}",
                row.what
            );
            // the drivers (the arm's and the camera's) stop last, the observers first
            let observer = ["vservoctl", "vservo-ros2"].contains(&row.program);
            assert_eq!(row.stops == Stops::First, observer, "{}", row.what);
        }
        // the default configuration (the simulated cell, no viewer, no bridge) starts none
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default configuration");
        assert!(HELPERS.iter().all(|row| !(row.runs)(&config)));
        assert_eq!((HELPERS[0].args)(&config)[..3], ["view", "--address", config.viewer.address.as_str()]);
    }
}
