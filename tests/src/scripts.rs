//! The run scripts (`scripts/run-*.sh`) as the tests run them: with this test run's binaries, their JSON summary
//! read back, and the files each run left in its own folder.

use std::path::Path;
use std::process::{Command, Stdio};

use serde_json::Value;

use crate::{binary, repository_root};

/// Runs `scripts/<script> ARGS` (which must include `--json`) with this test run's binaries (the scripts'
/// `VSERVO_BIN_DIR`) and returns the summary its last line gives, after checking that it ran.
pub fn run_script(script: &str, args: &[&str]) -> Value {
    let bin_dir = binary("vservod").parent().expect("target/<profile>").to_path_buf();
    let out = Command::new(repository_root().join("scripts").join(script))
        .args(args)
        .env("VSERVO_BIN_DIR", &bin_dir)
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("{script} runs: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let last = stdout.lines().last().expect("a JSON line");
    let summary: Value = serde_json::from_str(last)
        .unwrap_or_else(|e| panic!("the last line is JSON ({e}): {last}\n{stderr}"));
    println!("{summary}");
    summary
}

/// Runs `scripts/<script> --duration-s 15 --json` with `extra` arguments, as the README has people try a cell,
/// and returns its summary, after checking that the loop converged below 1 px with a settling time.
pub fn run_script_to_convergence(script: &str, extra: &[&str]) -> Value {
    let mut args = vec!["--duration-s", "15", "--json"];
    args.extend_from_slice(extra);
    let summary = run_script(script, &args);
    let final_error = summary["final_error_px"].as_f64().expect("final_error_px");
    let converged = final_error < 1.0 && summary["settling_time_s"].as_f64().is_some();
    assert!(converged, "{summary}\nwhat the run's logs said went wrong:\n{}", errors_logged(&summary));
    summary
}

/// The ERROR and WARN lines of the logs in a run's folder (vservod's, a simulator's), for a failure's message.
fn errors_logged(summary: &Value) -> String {
    let Some(folder) = summary["run_folder"].as_str() else { return "(no run folder)".to_string() };
    let Ok(entries) = std::fs::read_dir(folder) else { return format!("({folder} unreadable)") };
    let mut said = String::new();
    for path in entries.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|e| e == "log")) {
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        for line in text.lines().filter(|l| l.contains("ERROR") || l.contains("WARN")) {
            said.push_str(&format!("{}: {line}\n", path.file_name().unwrap_or_default().to_string_lossy()));
        }
    }
    said
}

/// The file `name` in the folder of the run a script's summary describes (its `run_folder`).
pub fn run_file(summary: &Value, name: &str) -> String {
    let folder = summary["run_folder"].as_str().unwrap_or_else(|| panic!("run_folder in {summary}"));
    let path = Path::new(folder).join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
