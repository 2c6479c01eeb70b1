//! README.md's commands that start the daemon run as written (issue 38: its `scripts/run.sh --config …` once
//! could not). Every line of a code block and every inline code span of README.md that starts with
//! `scripts/run.sh` or `vservod` and is a command, not a synopsis (no `[`, `|`, `…`, FILE or NAME), is run from
//! the repository's root as the README writes it, with the test's binaries (`VSERVO_BIN_DIR`, which run.sh takes
//! instead of a release build): the instance its configuration names comes up running, and Ctrl-C (SIGINT)
//! ends it with exit code 0.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_system_tests::{binary, exclusive, remove_instance, repository_root, running, status, wait_until};

/// The instance the README's commands run: every configuration they name keeps config/vservo.toml's name.
const INSTANCE: &str = "default";

/// The command lines of README.md's code blocks and inline code spans (a line's `# comment` cut off).
fn code_lines(readme: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let mut in_block = false;
    for line in readme.lines() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            continue;
        }
        if in_block {
            let command = line.split(" #").next().unwrap_or(line);
            lines.push(command.trim().to_string());
        } else {
            lines.extend(line.split('`').skip(1).step_by(2).map(|span| span.trim().to_string()));
        }
    }
    lines
}

/// The lines that start the daemon and are commands to run as they stand.
fn daemon_commands(readme: &str) -> Vec<String> {
    let synopsis = |line: &str| ["[", "|", "…", "FILE", "NAME"].iter().any(|mark| line.contains(mark));
    let mut commands: Vec<String> = code_lines(readme)
        .into_iter()
        .filter(|line| {
            line == "scripts/run.sh" || line.starts_with("scripts/run.sh ") || line.starts_with("vservod ")
        })
        .filter(|line| !synopsis(line))
        .collect();
    commands.dedup();
    commands
}

/// The command's process (bash exec'd into run.sh, which execs vservod), ended and its instance removed when
/// the test ends, passed or not.
struct Started {
    child: Child,
}

impl Drop for Started {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        remove_instance(INSTANCE);
    }
}

fn run_as_written(command: &str) {
    assert!(
        status(INSTANCE).is_none(),
        "an instance {INSTANCE:?} already runs on this machine: the README's commands start that one; stop it first"
    );
    let bin_dir = binary("vservod").parent().expect("the binaries' folder").to_path_buf();
    let log = std::env::temp_dir().join(format!("vservo-readme-{}.log", std::process::id()));
    let output = std::fs::File::create(&log).expect("a log");
    let mut started = Started {
        child: Command::new("bash")
            .args(["-c", &format!("exec {command}")])
            .current_dir(repository_root())
            .env("VSERVO_BIN_DIR", &bin_dir)
            .stdin(Stdio::null())
            .stdout(output.try_clone().expect("the log again"))
            .stderr(output)
            .spawn()
            .expect("bash starts"),
    };
    let log_text = || std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        wait_until(Duration::from_secs(60), || status(INSTANCE).is_some_and(|s| running(&s))),
        "`{command}` did not bring instance {INSTANCE:?} up running:\n{}",
        log_text()
    );
    kill(Pid::from_raw(started.child.id() as i32), Signal::SIGINT).expect("SIGINT");
    let until = Instant::now() + Duration::from_secs(10);
    let code = loop {
        if let Some(exit) = started.child.try_wait().expect("its state") {
            break exit.code();
        }
        assert!(Instant::now() < until, "`{command}` did not end within 10 s of Ctrl-C:\n{}", log_text());
        std::thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(code, Some(0), "`{command}` ended with {code:?} after Ctrl-C:\n{}", log_text());
    println!("`{command}`: came up running, ended with 0 on Ctrl-C");
    let _ = std::fs::remove_file(&log);
}

#[test]
fn the_readme_commands_that_start_the_daemon_run_as_written() {
    let _one = exclusive();
    let readme = std::fs::read_to_string(repository_root().join("README.md")).expect("README.md");
    let commands = daemon_commands(&readme);
    // the main job and its example with another configuration, at least
    assert!(commands.iter().any(|c| c == "scripts/run.sh"), "{commands:?}");
    assert!(commands.iter().any(|c| c.starts_with("scripts/run.sh --config ")), "{commands:?}");
    for command in &commands {
        run_as_written(command);
    }
}

#[test]
fn synopses_are_told_from_commands() {
    let readme = "```sh\nscripts/run.sh            # the main job\nvservod [--config FILE]\n```\n\
                  for example `scripts/run.sh --config config/scenarios/rotation-step.toml`, or `vservoctl sim`.\n";
    assert_eq!(
        daemon_commands(readme),
        ["scripts/run.sh", "scripts/run.sh --config config/scenarios/rotation-step.toml"]
    );
}
