//! The live view (`[viewer] enabled = true`): vservod starts `vservoctl view` (installed next to vservod)
//! on the configured address and port, restarts it if it ends, and stops it with the cell. The viewer is a
//! client of the instance like any other: it reads with iceoryx2's safe overflow, so a slow or absent
//! viewer never slows the loop, and its failure is a warning, never a fault of the cell.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;

/// After the viewer ended, wait this long before starting it again.
const RESTART_AFTER: Duration = Duration::from_secs(5);

/// The viewer process, if the configuration asks for one.
pub struct Viewer {
    command: Option<Command>,
    child: Option<Child>,
    restart_at: Option<Instant>,
}

impl Viewer {
    /// Starts the viewer when `settings.enabled`.
    pub fn start(
        settings: &vservo_config::Viewer,
        vservod: &Path,
        config_path: &Path,
        runtime_base: &Path,
    ) -> Self {
        let command = settings.enabled.then(|| {
            let mut command = Command::new(vservod.with_file_name("vservoctl"));
            command
                .arg("view")
                .arg("--config")
                .arg(config_path)
                .arg("--address")
                .arg(&settings.address)
                .arg("--port")
                .arg(settings.port.to_string())
                .arg("--max-clients")
                .arg(settings.max_clients.to_string())
                .env(vservo_protocol::instance_dir::RUNTIME_DIR_ENV, runtime_base)
                .env_remove("NOTIFY_SOCKET")
                .env_remove("WATCHDOG_USEC")
                .env_remove("WATCHDOG_PID")
                .stdin(Stdio::null());
            command
        });
        let mut viewer = Self { command, child: None, restart_at: Some(Instant::now()) };
        viewer.poll();
        viewer
    }

    /// Starts the viewer again once it has been gone for [`RESTART_AFTER`]; call every supervisor cycle.
    pub fn poll(&mut self) {
        let Some(command) = self.command.as_mut() else { return };
        if let Some(child) = &mut self.child
            && let Ok(Some(status)) = child.try_wait()
        {
            tracing::warn!(%status, restart_in_s = RESTART_AFTER.as_secs_f64(), "the Foxglove viewer ended");
            self.child = None;
            self.restart_at = Some(Instant::now() + RESTART_AFTER);
        }
        if self.child.is_none() && self.restart_at.is_some_and(|at| Instant::now() >= at) {
            self.restart_at = None;
            match command.spawn() {
                Ok(child) => {
                    tracing::info!(pid = child.id(), "the Foxglove viewer started");
                    self.child = Some(child);
                }
                Err(error) => {
                    tracing::warn!(%error, "the Foxglove viewer (vservoctl view) could not be started");
                    self.restart_at = Some(Instant::now() + RESTART_AFTER);
                }
            }
        }
    }

    /// Stops the viewer (SIGTERM, then SIGKILL after a second).
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
