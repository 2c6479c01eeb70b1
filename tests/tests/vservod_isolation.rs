//! No door for other users (docs/PROTOCOL.md, "Where an instance lives"): another user (`nobody`) can read,
//! write, create or remove nothing that decides whether an instance runs. Needs root (to be `nobody`).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use vservo_system_tests::{Daemon, exclusive, instance_config, running, status, unique, wait_until};

fn is_root() -> bool {
    nix::unistd::geteuid().is_root()
}

/// Runs a shell script as `nobody` with `args`; its stdout.
fn as_nobody(script: &str, args: &[String]) -> String {
    let out = Command::new("runuser")
        .args(["-u", "nobody", "--", "sh", "-c", script, "sh"])
        .args(args)
        .current_dir("/")
        .output()
        .expect("runuser runs");
    String::from_utf8_lossy(&out.stdout).to_string()
}

/// The instance's objects in /dev/shm.
fn shared_memory_of(prefix: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .expect("/dev/shm")
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
        .map(|e| e.path().display().to_string())
        .collect()
}

/// Every file and directory under `dir`.
fn tree(dir: &Path) -> Vec<String> {
    let mut found = vec![dir.display().to_string()];
    let mut pending = vec![dir.to_path_buf()];
    while let Some(path) = pending.pop() {
        for entry in std::fs::read_dir(&path).into_iter().flatten().flatten() {
            found.push(entry.path().display().to_string());
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                pending.push(entry.path());
            }
        }
    }
    found
}

/// What `nobody` managed to do to each path (tests/nobody-tries.sh): one line per success.
fn nobody_tries(paths: &[String]) -> String {
    let script = vservo_system_tests::repository_root().join("tests/nobody-tries.sh");
    let text = std::fs::read_to_string(&script).expect("tests/nobody-tries.sh");
    as_nobody(&text, paths)
}

/// Creates each named file with garbage, open to everyone, as another user would to block a name.
const PLANT: &str = r#"
for f in "$@"; do printf 'garbage from nobody' > "$f" && chmod 666 "$f" && echo "planted $f"; done
"#;

#[test]
fn another_user_can_neither_touch_nor_pre_create_what_an_instance_runs_on() {
    if !is_root() {
        println!("skipped: needs root to act as nobody");
        return;
    }
    let _one = exclusive();
    let instance = unique("isolated");
    let config = instance_config(&instance);
    // before the first start: the names an instance used before (a predictable prefix) are planted
    let old_style = format!(
        "/dev/shm/vservo_{instance}_9204dd183d1c4d8e1ff592a30766ffa6765aa8b5_node.0_10_0.global_mgmt"
    );
    assert!(as_nobody(PLANT, std::slice::from_ref(&old_style)).contains("planted"));
    let mut daemon = Daemon::start(&config);
    let up = |instance: &str| {
        wait_until(Duration::from_secs(10), || status(instance).is_some_and(|s| running(&s)))
    };
    assert!(up(&instance), "{}", daemon.log());

    let dir = vservo_protocol::InstanceDir::locate(&instance).expect("the instance's directory");
    let shm = shared_memory_of(&dir.prefix);
    assert!(shm.iter().any(|f| f.ends_with(".global_mgmt")), "the node counter is there: {shm:?}");
    let mut targets: Vec<String> = shm.clone();
    targets.extend(tree(&dir.base));
    let done = nobody_tries(&targets);
    assert!(done.is_empty(), "nobody managed:\n{done}");

    // the instance still runs, and still makes nodes (a restarted node takes a number from the counter)
    let before = status(&instance).expect("status");
    let pid = before["nodes"]["servo"]["pid"].as_u64().expect("pid") as i32;
    kill(Pid::from_raw(pid), Signal::SIGKILL).expect("kill the servo");
    let restarted = wait_until(Duration::from_secs(10), || {
        status(&instance).is_some_and(|s| running(&s) && s["nodes"]["servo"]["restarts"] == 1)
    });
    assert!(restarted, "{:?}\n{}", status(&instance), daemon.log());
    let shm_now = shared_memory_of(&dir.prefix);
    daemon.signal(Signal::SIGTERM);
    assert_eq!(daemon.wait(Duration::from_secs(5)), Some(0), "{}", daemon.log());

    // stopped: nobody, who saw every name the run used, plants all of them
    let mut seen: Vec<String> = shm.into_iter().chain(shm_now).collect();
    seen.sort();
    seen.dedup();
    let planted = as_nobody(PLANT, &seen);
    assert!(planted.contains("planted"), "{planted}");
    // the next start leaves that prefix to them and runs under a new one
    let mut daemon = Daemon::start(&config);
    assert!(up(&instance), "{}", daemon.log());
    let renewed = vservo_protocol::InstanceDir::locate(&instance).expect("the instance's directory");
    assert_ne!(renewed.prefix, dir.prefix);
    assert!(daemon.log().contains("prefix was replaced"), "{}", daemon.log());
    daemon.signal(Signal::SIGTERM);
    assert_eq!(daemon.wait(Duration::from_secs(5)), Some(0), "{}", daemon.log());
    for path in seen.iter().map(PathBuf::from).chain([PathBuf::from(old_style)]) {
        let _ = std::fs::remove_file(path);
    }
}
