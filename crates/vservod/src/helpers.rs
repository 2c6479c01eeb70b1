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
    command: Option<Command>,
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
    /// `program` (next to vservod) with `--config` and `args`, run as vservod's own processes are; `None`
    /// when not `enabled`.
    fn command(&self, enabled: bool, program: &str, args: &[String]) -> Option<Command> {
        enabled.then(|| {
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
        })
    }
}

impl Helper {
    /// The Foxglove viewer (`vservoctl view`), started when `settings.enabled`.
    pub fn viewer(settings: &vservo_config::Viewer, launch: &Launch) -> Self {
        let args = ["view", "--address", &settings.address, "--port", &settings.port.to_string()]
            .into_iter()
            .map(String::from)
            .chain(["--max-clients".to_string(), settings.max_clients.to_string()])
            .collect::<Vec<_>>();
        Self::start("the Foxglove viewer", launch.command(settings.enabled, "vservoctl", &args))
    }

    /// The ROS 2 bridge (`vservo-ros2`), started when `settings.enabled`; it ends with this daemon.
    pub fn ros2_bridge(settings: &vservo_config::Ros2, launch: &Launch) -> Self {
        let args = ["--daemon-pid".to_string(), std::process::id().to_string()];
        Self::start("the ROS 2 bridge", launch.command(settings.enabled, "vservo-ros2", &args))
    }

    /// The ROS 2 driver (`vservo-ros2-driver`), started when `[robot] driver` or `[camera] source` is
    /// `"ros2"`; it ends with this daemon.
    pub fn ros2_driver(config: &vservo_config::Config, launch: &Launch) -> Self {
        let args = ["--daemon-pid".to_string(), std::process::id().to_string()];
        let command = launch.command(config.runs_ros2_driver(), "vservo-ros2-driver", &args);
        Self::start_keyed("the ROS 2 driver", command, launch.seal_key)
    }

    /// The Franka driver (`vservo-franka`), started with `[robot] driver = "franka"`; it ends with this daemon
    /// (bringing the arm to rest and ending its motion).
    pub fn franka_driver(config: &vservo_config::Config, launch: &Launch) -> Self {
        let runs = config.cell.robot.driver == vservo_config::RobotDriver::Franka;
        let args = ["--daemon-pid".to_string(), std::process::id().to_string()];
        Self::start_keyed("the Franka driver", launch.command(runs, "vservo-franka", &args), launch.seal_key)
    }

    /// The GStreamer camera (`vservo-gst-camera`), started with `[camera] source = "gstreamer"` on the
    /// pipeline of `[camera.gstreamer]`; it ends with this daemon.
    pub fn gst_camera(config: &vservo_config::Config, launch: &Launch) -> Self {
        let runs = config.cell.vision.source == vservo_config::VisionSource::Gstreamer;
        let args = ["--daemon-pid".to_string(), std::process::id().to_string()];
        Self::start("the GStreamer camera", launch.command(runs, "vservo-gst-camera", &args))
    }

    fn start(what: &'static str, command: Option<Command>) -> Self {
        let mut helper = Self { what, command, key: None, child: None, restart_at: Some(Instant::now()) };
        helper.poll();
        helper
    }

    /// A robot driver: handed the run's key on its stdin at each start.
    fn start_keyed(what: &'static str, mut command: Option<Command>, key: &SealKey) -> Self {
        if let Some(command) = command.as_mut() {
            command.arg("--seal-key-stdin").stdin(Stdio::piped());
        }
        let key = Some(key.clone());
        let mut helper = Self { what, command, key, child: None, restart_at: Some(Instant::now()) };
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
        let Some(command) = self.command.as_mut() else { return };
        if let Some(child) = &mut self.child
            && let Ok(Some(status)) = child.try_wait()
        {
            tracing::warn!(%status, restart_in_s = RESTART_AFTER.as_secs_f64(), "{} ended", self.what);
            self.child = None;
            self.restart_at = Some(Instant::now() + RESTART_AFTER);
        }
        if self.child.is_none() && self.restart_at.is_some_and(|at| Instant::now() >= at) {
            self.restart_at = None;
            match command.spawn() {
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
