//! What starts the node processes: each a child of the daemon's own executable (`vservod node <role>`), in
//! a process group of its own, handed the run's seal key and the configuration in force on its stdin; a
//! restarted plant resumes at rest where the arm was, a restarted vision node tracks from the last features.

use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_protocol::NodeRole;
use vservo_protocol::seal::SealKey;

use super::node::NodeRecord;

/// Where a restarted node resumes: the last joint state and features heard.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Resume {
    /// The joints (rad), one per joint of the arm, and tick of the latest joint state.
    pub joints: Option<(Vec<f64>, u64)>,
    /// The latest features (px).
    pub features_px: Option<[f64; 8]>,
}

/// The arguments after `vservod --config <file> node <role> --config-stdin` that make `role` resume:
/// the plant at rest where the arm stopped, the vision node from where the marks were last seen.
pub fn resume_arguments(role: NodeRole, resume: &Resume) -> Vec<String> {
    let list = |values: &[f64]| values.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(",");
    match (role, resume) {
        (NodeRole::Plant, Resume { joints: Some((q, tick)), .. }) => {
            vec![format!("--resume-q={}", list(q)), format!("--resume-tick={}", tick + 1)]
        }
        (NodeRole::Vision, Resume { features_px: Some(features), .. })
            if features.iter().all(|v| v.is_finite()) =>
        {
            vec![format!("--resume-features={}", list(features))]
        }
        _ => Vec::new(),
    }
}

/// How a process ended: its exit code, or minus the signal that ended it.
pub fn exit_code(status: ExitStatus) -> i32 {
    status.code().unwrap_or_else(|| -status.signal().unwrap_or(0))
}

/// What the daemon needs to start a node.
pub struct Launcher {
    /// The daemon's executable.
    pub executable: PathBuf,
    /// The configuration file, for the nodes' messages (they read the text on stdin).
    pub config_path: PathBuf,
    /// The base of the instance's runtime directory, handed to the nodes (`VSERVO_RUNTIME_DIR`).
    pub runtime_base: PathBuf,
    /// The run's key: the nodes take gains and object commands sealed with it only.
    pub seal_key: SealKey,
}

impl Launcher {
    /// Starts a node on `config_text`, the configuration in force (handed over on its stdin: a node
    /// restarted after an edit that was not reloaded, or was refused, runs what the others run).
    pub fn spawn(&self, role: NodeRole, resume: &Resume, config_text: &str) -> std::io::Result<Child> {
        let mut child = Command::new(&self.executable)
            .arg("--config")
            .arg(&self.config_path)
            .args(["node", role.name(), "--config-stdin"])
            .args(resume_arguments(role, resume))
            .stdin(Stdio::piped())
            .env(crate::node_process::DAEMON_PID_ENV, std::process::id().to_string())
            .env(vservo_protocol::instance_dir::RUNTIME_DIR_ENV, &self.runtime_base)
            // only the daemon talks to systemd
            .env_remove("NOTIFY_SOCKET")
            .env_remove("WATCHDOG_USEC")
            .env_remove("WATCHDOG_PID")
            // a terminal's Ctrl-C reaches the daemon only; it stops the nodes in order
            .process_group(0)
            .spawn()?;
        // a few kB: the pipe takes it whole; closing it ends the node's read. The key's text is written from
        // a buffer wiped when dropped, never formatted into a string (docs/PROTOCOL.md, "Seals")
        if let Some(mut stdin) = child.stdin.take() {
            use std::io::Write;
            vservo_protocol::seal::write_key_line(&self.seal_key, &mut stdin)?;
            stdin.write_all(config_text.as_bytes())?;
        }
        Ok(child)
    }
}

/// A node and its process.
pub struct Supervised {
    /// What the supervisor knows of it.
    pub record: NodeRecord,
    /// Its process while it runs.
    pub process: Option<Child>,
    /// Ended on purpose to restart with a reloaded configuration (not lost).
    pub planned_restart: bool,
}

/// The nodes that read the camera's lens and mount at their start: a reload that changes them (the cell held)
/// restarts these.
pub const CAMERA_READERS: [NodeRole; 3] = [NodeRole::Vision, NodeRole::Servo, NodeRole::Rmrc];

/// Ends the nodes that read the camera (SIGTERM), each to restart with the configuration in force.
pub fn end_camera_readers(nodes: &mut [Supervised]) {
    for node in nodes.iter_mut().filter(|n| CAMERA_READERS.contains(&n.record.role) && n.process.is_some()) {
        node.planned_restart = true;
        node.signal(Signal::SIGTERM);
    }
}

/// The process of each node running, by role (0 while none runs): the writers the daemon announces.
pub fn writers_of(nodes: &[Supervised]) -> [u32; 4] {
    let mut writers = [0; 4];
    for node in nodes.iter().filter(|n| n.process.is_some()) {
        writers[node.record.role as usize] = node.record.pid.unwrap_or(0);
    }
    writers
}

/// Each node's latest telemetry from its running process, in role order.
pub fn telemetry_of(nodes: &[Supervised]) -> [Option<vservo_protocol::TelemetryMsg>; 4] {
    let mut out = [None; 4];
    for node in nodes {
        out[node.record.role as usize] = node.record.own_telemetry();
    }
    out
}

impl Supervised {
    /// Sends `signal` to its process, if it runs.
    pub fn signal(&self, signal: Signal) {
        if let Some(child) = &self.process {
            let _ = kill(Pid::from_raw(child.id() as i32), signal);
        }
    }

    /// How its process ended, if it did since the last look (the process is then gone).
    pub fn reap(&mut self) -> Option<i32> {
        let status = self.process.as_mut()?.try_wait().ok()??;
        self.process = None;
        Some(exit_code(status))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_restarted_plant_resumes_at_the_next_tick_where_the_arm_was() {
        let resume = Resume { joints: Some((vec![0.5, -1.0, 0.0, 0.0, 0.0, 2.0], 41)), features_px: None };
        assert_eq!(
            resume_arguments(NodeRole::Plant, &resume),
            ["--resume-q=5e-1,-1e0,0e0,0e0,0e0,2e0", "--resume-tick=42"]
        );
        assert!(resume_arguments(NodeRole::Plant, &Resume::default()).is_empty(), "nothing heard: the start");
        assert!(resume_arguments(NodeRole::Rmrc, &resume).is_empty());
    }

    #[test]
    fn a_restarted_vision_node_tracks_from_the_last_features_only_when_all_were_seen() {
        let mut features = [151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0];
        let resume = Resume { joints: None, features_px: Some(features) };
        assert_eq!(
            resume_arguments(NodeRole::Vision, &resume),
            ["--resume-features=1.51e2,1.68e2,3.18e2,1.78e2,3.39e2,7.5e1,1.72e2,7e1"]
        );
        features[3] = f64::NAN;
        let missing = Resume { joints: None, features_px: Some(features) };
        assert!(resume_arguments(NodeRole::Vision, &missing).is_empty());
        assert!(resume_arguments(NodeRole::Servo, &resume).is_empty());
    }
}
