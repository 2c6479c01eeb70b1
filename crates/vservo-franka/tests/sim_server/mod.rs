//! Starts franka-sim from the venv `setup-franka-sim.sh` makes, on a free port, and stops it on drop.

use std::fs::File;
use std::net::{SocketAddr, TcpListener};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use vservo_franka::Connection;

/// How long franka-sim may take to serve its first state (MuJoCo model compile included).
const STARTUP: Duration = Duration::from_secs(90);

/// A running franka-sim; dropping it stops the process (SIGTERM, then SIGKILL after 10 s).
pub struct SimServer {
    child: Child,
    port: u16,
    log: PathBuf,
}

/// The venv, or a message saying how to make it.
fn find_venv() -> Result<PathBuf, String> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut candidates: Vec<PathBuf> =
        std::env::var_os("FRANKA_SIM_VENV").map(PathBuf::from).into_iter().collect();
    if let Some(target) = Path::new(env!("CARGO_TARGET_TMPDIR")).parent() {
        candidates.push(target.join("franka-sim-venv"));
    }
    candidates.extend(manifest.ancestors().map(|a| a.join("target").join("franka-sim-venv")));
    let mut seen = std::collections::HashSet::new();
    candidates.retain(|c| seen.insert(c.clone()));
    for venv in &candidates {
        let python = venv.join("bin").join("python");
        let ok = Command::new(&python)
            .args(["-c", "import franka_sim.run_server, franky_sim"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Ok(venv.clone());
        }
    }
    let looked: Vec<String> = candidates.iter().map(|c| c.display().to_string()).collect();
    Err(format!(
        "franka-sim is not installed: no venv with franka_sim and franky_sim at any of [{}]. Make it with \
         `scripts/setup-franka-sim.sh <repository root>` (scripts/setup.sh runs it: `python3 -m venv \
         <root>/target/franka-sim-venv` and `pip install franka-sim==1.1.7 franky-sim==1.0.4`), or point \
         FRANKA_SIM_VENV at such a venv.",
        looked.join(", ")
    ))
}

/// franky-sim's fr3.xml says meshdir="assets" but the wheel ships `meshes/`: two symlinks make it load
/// (MuJoCo resolves meshdir from the symlink's directory) without fetching anything.
fn prepare_mjcf(venv: &Path) -> PathBuf {
    let lib = venv.join("lib");
    let site = std::fs::read_dir(&lib)
        .unwrap_or_else(|e| panic!("reading {}: {e}", lib.display()))
        .filter_map(Result::ok)
        .map(|e| e.path().join("site-packages").join("franky_sim").join("assets"))
        .find(|p| p.join("fr3.xml").is_file())
        .unwrap_or_else(|| panic!("no franky_sim/assets/fr3.xml under {}", lib.display()));
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("franka-sim-fr3-mjcf");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("creating {}: {e}", dir.display()));
    for (link, target) in [("fr3.xml", site.join("fr3.xml")), ("assets", site.join("meshes"))] {
        let link = dir.join(link);
        if std::fs::read_link(&link).ok().as_deref() != Some(target.as_path()) {
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink(&target, &link)
                .unwrap_or_else(|e| panic!("linking {} -> {}: {e}", link.display(), target.display()));
        }
    }
    dir.join("fr3.xml")
}

fn free_port() -> u16 {
    // The server binds 0.0.0.0, so probe the same.
    TcpListener::bind("0.0.0.0:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .unwrap_or_else(|e| panic!("{e}"))
}

impl SimServer {
    /// Starts franka-sim headless with both enforcements on a free port; fails the test if it cannot.
    pub fn start() -> SimServer {
        let venv = find_venv().unwrap_or_else(|message| panic!("{message}"));
        let mjcf = prepare_mjcf(&venv);
        let port = free_port();
        let log = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("franka-sim-{port}.log"));
        let out = File::create(&log).unwrap_or_else(|e| panic!("creating {}: {e}", log.display()));
        let err = out.try_clone().unwrap_or_else(|e| panic!("{e}"));
        let child = Command::new(venv.join("bin").join("python"))
            .args(["-m", "franka_sim.run_server", "--port", &port.to_string(), "--no-gripper"])
            .args(["--enforce-motion-limits", "--enforce-comm-constraints"])
            .env("FR3_MJCF", &mjcf)
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(err)
            .spawn()
            .unwrap_or_else(|e| panic!("starting franka-sim from {}: {e}", venv.display()));
        SimServer { child, port, log }
    }

    /// The TCP command port.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Connects once the server serves states (retrying while it starts up).
    pub fn connect(&mut self) -> Connection {
        let addr = SocketAddr::from(([127, 0, 0, 1], self.port));
        let deadline = Instant::now() + STARTUP;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                panic!("franka-sim exited during startup ({status}); log:\n{}", self.log_tail());
            }
            match Connection::connect(addr, Duration::from_secs(2)) {
                Ok(conn) => return conn,
                Err(e) if Instant::now() > deadline => {
                    panic!("franka-sim not ready within {STARTUP:?}: {e}; log:\n{}", self.log_tail())
                }
                Err(_) => std::thread::sleep(Duration::from_millis(200)),
            }
        }
    }

    fn log_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(30)..].join("\n")
    }
}

impl Drop for SimServer {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("franka-sim log ({}), last lines:\n{}", self.log.display(), self.log_tail());
        }
        // SIGTERM (an orderly shutdown) to this child only, by its id; SIGKILL if it lingers.
        let _ = Command::new("kill").args(["-TERM", &self.child.id().to_string()]).status();
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
