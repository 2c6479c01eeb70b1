//! # vservo-system-tests — end-to-end tests
//!
//! Owns the tests that run vservo's built binaries the way a user does (command lines, exit codes, and
//! later the daemon and its processes). This library holds only the helpers those tests share.

use std::path::PathBuf;
use std::process::{Command, Output};

/// The path of a workspace binary built by the same `cargo test` run (`target/<profile>/<name>`).
///
/// `cargo test --workspace` compiles every package's binaries before it runs any test, so the binary is
/// there; the panic says what to do when a test is run on its own.
pub fn binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test knows its own path");
    // target/<profile>/deps/<test>-<hash>
    let profile_dir = exe.parent().and_then(|deps| deps.parent()).expect("target/<profile>/deps");
    let path = profile_dir.join(name);
    assert!(
        path.exists(),
        "{} is not built: run `cargo build --workspace` (or the whole `cargo test --workspace`)",
        path.display()
    );
    path
}

/// Runs a workspace binary with arguments and returns its output.
pub fn run(name: &str, args: &[&str]) -> Output {
    Command::new(binary(name)).args(args).output().expect("the binary starts")
}

/// The repository's root (where `config/` is).
pub fn repository_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ is inside the repository").to_path_buf()
}

/// The default configuration file.
pub fn default_config() -> PathBuf {
    repository_root().join("config/vservo.toml")
}

/// A copy of the default configuration with one piece of text replaced, written to a temporary file that
/// lives as long as the returned guard.
pub fn config_with(old: &str, new: &str) -> TempConfig {
    let text = std::fs::read_to_string(default_config()).expect("the default config is readable");
    assert!(text.contains(old), "the default config holds {old:?}");
    let path = std::env::temp_dir().join(format!(
        "vservo-test-{}-{}.toml",
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    std::fs::write(&path, text.replacen(old, new, 1)).expect("temporary file is writable");
    TempConfig { path }
}

static TEMP_COUNTER: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A temporary configuration file, removed when dropped.
pub struct TempConfig {
    /// Its path.
    pub path: PathBuf,
}

impl TempConfig {
    /// The path as a string for command lines.
    pub fn arg(&self) -> String {
        self.path.display().to_string()
    }
}

impl Drop for TempConfig {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}
