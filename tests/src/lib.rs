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
