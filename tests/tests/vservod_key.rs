//! The seal key out of reach, and an ordinary user's instance found by that user's clients (issue 22;
//! docs/PROTOCOL.md, "Seals" and "Where an instance lives").
//!
//! The daemon runs as an ordinary user (`nobody`; the tests need root to become it, else they print
//! "skipped: needs root"), its instance in that user's own base (`/tmp/vservo-65534`), while the system
//! instance's `/run/vservo` exists. As that same user, a process tries to read the daemon's and each node's
//! memory (`/proc/<pid>/maps`, `/proc/<pid>/mem`, `process_vm_readv`): refused, while the same reads of a
//! process of its own (`sleep`) work; and that user's `vservoctl status` and Python client find the instance
//! with no environment variable.

use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use serde_json::Value;
use vservo_system_tests::{
    Daemon, Killed, binary, exclusive, instance_config, repository_root, unique, wait_until,
};

/// The base directory of the system instance (root's, as the systemd unit's is the `vservo` user's).
const SYSTEM_BASE: &str = "/run/vservo";

/// An ordinary user of this machine.
#[derive(Clone, Copy)]
struct User {
    uid: u32,
    gid: u32,
}

/// `nobody`, when this test runs as root (which it needs to become another user); else says it is skipped.
fn nobody_if_root() -> Option<User> {
    if !nix::unistd::geteuid().is_root() {
        println!("skipped: needs root to run the daemon as nobody");
        return None;
    }
    let user = nix::unistd::User::from_name("nobody").ok().flatten().expect("the user nobody exists");
    Some(User { uid: user.uid.as_raw(), gid: user.gid.as_raw() })
}

/// `program` run as `user`, with no runtime directory in its environment, from `/`.
fn as_user(program: impl AsRef<std::ffi::OsStr>, user: User) -> Command {
    let mut command = Command::new(program);
    command
        .uid(user.uid)
        .gid(user.gid)
        .env_remove("VSERVO_RUNTIME_DIR")
        .env_remove("XDG_RUNTIME_DIR")
        .current_dir("/");
    command
}

/// The system instance's base exists for the test, as it does where the system service runs: made root's
/// with mode 0750 (as vservod makes it) when missing, and removed afterwards only if this test made it and
/// nothing was put in it meanwhile.
struct SystemBase {
    made: bool,
}

impl SystemBase {
    fn ensure() -> Self {
        use std::os::unix::fs::DirBuilderExt;
        let made = std::fs::DirBuilder::new().mode(0o750).create(SYSTEM_BASE).is_ok();
        assert!(Path::new(SYSTEM_BASE).is_dir(), "{SYSTEM_BASE} exists");
        Self { made }
    }
}

impl Drop for SystemBase {
    fn drop(&mut self) {
        if self.made {
            let _ = std::fs::remove_dir(SYSTEM_BASE);
        }
    }
}

/// What an ordinary user's daemon leaves of its instance: its directory under `/tmp/vservo-<uid>`, its
/// iceoryx2 files and its shared memory; removed when dropped (after the daemon and its nodes are gone).
struct UserInstance {
    base: PathBuf,
    instance: String,
    /// The daemon's and nodes' pids, once known: waited for before anything is removed.
    pids: Vec<i32>,
}

impl UserInstance {
    fn new(user: User, instance: &str) -> Self {
        Self {
            base: PathBuf::from(format!("/tmp/vservo-{}", user.uid)),
            instance: instance.to_string(),
            pids: vec![],
        }
    }
}

impl Drop for UserInstance {
    fn drop(&mut self) {
        let alive = |pid: &i32| Path::new(&format!("/proc/{pid}")).exists();
        wait_until(Duration::from_secs(5), || !self.pids.iter().any(alive));
        let path = self.base.join(&self.instance);
        if let Ok(prefix) = std::fs::read_to_string(path.join("prefix")) {
            let prefix = prefix.trim();
            let iceoryx2 = self.base.join("iceoryx2");
            for dir in [
                PathBuf::from("/dev/shm"),
                iceoryx2.clone(),
                iceoryx2.join("services"),
                iceoryx2.join("nodes"),
            ] {
                for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
                    if entry.file_name().to_string_lossy().starts_with(prefix) {
                        let _ = std::fs::remove_file(entry.path())
                            .or_else(|_| std::fs::remove_dir_all(entry.path()));
                    }
                }
            }
        }
        let _ = std::fs::remove_dir_all(path);
    }
}

/// `vservoctl status --json` of `instance` as `user`, with no environment variable to say where it is.
fn status_as(user: User, instance: &str) -> Result<Value, String> {
    let out = as_user(binary("vservoctl"), user)
        .args(["status", "--json", "--instance", instance, "--timeout-s", "1"])
        .output()
        .expect("vservoctl runs");
    if out.status.success() {
        serde_json::from_slice(&out.stdout).map_err(|e| e.to_string())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).to_string())
    }
}

/// A daemon of the default cell (the simulated robot) run by `user`, once its status says it runs.
fn running_as(user: User, instance: &str) -> (vservo_system_tests::TempConfig, Daemon, Value) {
    let config = instance_config(instance);
    let daemon = Daemon::start_as(&config, user.uid, user.gid);
    let mut last = Err(String::new());
    let running = wait_until(Duration::from_secs(20), || {
        last = status_as(user, instance);
        last.as_ref().is_ok_and(|s| s["state"] == "running")
    });
    assert!(running, "not running as uid {}: {last:?}\n{}", user.uid, daemon.log());
    let status = last.expect("a status");
    (config, daemon, status)
}

/// The daemon's pid and each node's, by role, from a status.
fn pids(status: &Value) -> Vec<(String, i32)> {
    let mut pids = vec![("vservod".to_string(), status["daemon_pid"].as_i64().expect("daemon_pid") as i32)];
    for role in ["plant", "rmrc", "servo", "vision"] {
        pids.push((role.to_string(), status["nodes"][role]["pid"].as_i64().expect("a node's pid") as i32));
    }
    pids
}

/// A line of `/proc/<pid>/<file>` starting with `key`, read as root.
fn proc_line(pid: i32, file: &str, key: &str) -> String {
    let text = std::fs::read_to_string(format!("/proc/{pid}/{file}")).expect("root reads /proc");
    text.lines().find(|l| l.starts_with(key)).unwrap_or_default().to_string()
}

/// A readable mapped address of a process, read by root from its maps: its heap if it has one.
fn mapped_address(pid: i32) -> u64 {
    let maps = std::fs::read_to_string(format!("/proc/{pid}/maps")).expect("root reads the maps");
    let readable: Vec<&str> =
        maps.lines().filter(|l| l.split_whitespace().nth(1).is_some_and(|p| p.starts_with('r'))).collect();
    let line =
        readable.iter().find(|l| l.ends_with("[heap]")).or(readable.first()).expect("a readable mapping");
    u64::from_str_radix(line.split('-').next().expect("a start"), 16).expect("hex")
}

/// Whether `user` can run `interpreter` with `env`.
fn runs_as(user: User, interpreter: &Path, env: &[(&str, String)]) -> bool {
    as_user(interpreter, user)
        .envs(env.iter().map(|(k, v)| (*k, v)))
        .args(["-c", "import iceoryx2"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// A Python interpreter `user` can run, with PyPI's iceoryx2: the repository's `target/python-venv`, or,
/// when that venv's interpreter lies where the user cannot reach (a venv made by root from a pyenv in
/// `/root`), the system's Python of the same minor version with the venv's packages on its path.
fn python_for(user: User) -> (PathBuf, Vec<(&'static str, String)>) {
    let venv = repository_root().join("target/python-venv");
    let interpreter = venv.join("bin/python");
    if runs_as(user, &interpreter, &[]) {
        return (interpreter, vec![]);
    }
    let site_packages = std::fs::read_dir(venv.join("lib"))
        .expect("the venv's lib")
        .flatten()
        .map(|e| e.path().join("site-packages"))
        .find(|p| p.is_dir())
        .expect("the venv's site-packages");
    let system = PathBuf::from("/usr/bin/python3");
    let env = vec![("PYTHONPATH", site_packages.display().to_string())];
    assert!(runs_as(user, &system, &env), "no Python with iceoryx2 that uid {} can run", user.uid);
    (system, env)
}

fn show(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

#[test]
fn the_daemons_and_nodes_memory_is_out_of_reach_of_their_own_users_other_processes() {
    let Some(nobody) = nobody_if_root() else { return };
    let _one = exclusive();
    let _system = SystemBase::ensure();
    let instance = unique("key-memory");
    let mut files = UserInstance::new(nobody, &instance);
    let (_config, daemon, status) = running_as(nobody, &instance);
    let pids = pids(&status);
    files.pids = pids.iter().map(|(_, pid)| *pid).collect();

    let mut targets = Vec::new();
    for (role, pid) in &pids {
        // the premise: every process is nobody's, like the reader
        let uid = proc_line(*pid, "status", "Uid:");
        assert_eq!(uid.split_whitespace().nth(2), Some(nobody.uid.to_string().as_str()), "{role}: {uid}");
        // and no core dump would hold the key
        let core = proc_line(*pid, "limits", "Max core file size");
        assert_eq!(core.split_whitespace().skip(4).take(2).collect::<Vec<_>>(), ["0", "0"], "{role}: {core}");
        targets.push(format!("{pid}:{:x}", mapped_address(*pid)));
    }
    let reader = as_user("/usr/bin/python3", nobody)
        .arg(repository_root().join("tests/python/read_process_memory.py"))
        .args(&targets)
        .output()
        .expect("the reader runs");
    assert!(reader.status.success(), "{}", show(&reader));
    let report: Value = serde_json::from_slice(&reader.stdout).expect("the reader prints JSON");
    println!("uid {} reading its own `sleep`: {}", report["uid"], report["premise"]);
    let premise = &report["premise"];
    assert_eq!(premise["maps"]["ok"], true, "{premise}");
    assert_eq!(
        premise["mem"]["read"]["bytes"], 16,
        "the premise: a process of the user reads another's: {premise}"
    );
    assert_eq!(premise["process_vm_readv"]["bytes"], 16, "{premise}");
    for ((role, _), target) in pids.iter().zip(report["targets"].as_array().expect("targets")) {
        println!(
            "{role} (pid {}): maps {}, mem open {}, mem read {}, process_vm_readv {}",
            target["pid"],
            target["maps"],
            target["mem"]["open"],
            target["mem"]["read"],
            target["process_vm_readv"]
        );
        assert_eq!(target["maps"]["ok"], false, "{role}: {target}");
        assert_eq!(target["mem"]["open"]["ok"], false, "{role}: {target}");
        assert_eq!(target["mem"]["read"]["ok"], false, "{role}: {target}");
        assert_eq!(target["process_vm_readv"]["ok"], false, "{role}: {target}");
    }
    no_key_text_left(&pids);
    daemon.stop();
}

/// As root: no copy of the key's text (32 hex digits, as the daemon hands it to a node) is left in the private
/// memory of the daemon or any node (tests/python/find_key_text.py: a run of 32 hex digits whose binary form is
/// in the daemon's memory is the key's). The premise: the same scan finds the text of a key planted, with its
/// binary form, in a process of the test's.
fn no_key_text_left(pids: &[(String, i32)]) {
    use std::io::BufRead;
    let plant = "import os, time\n\
                 key = os.urandom(16)\n\
                 text = '%016x%016x' % (int.from_bytes(key[:8], 'little'), int.from_bytes(key[8:], 'little'))\n\
                 text = text.encode()\n\
                 print('ready', flush=True)\n\
                 time.sleep(30)";
    let mut planted = Killed(
        Command::new("/usr/bin/python3")
            .args(["-c", plant])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("python3 runs"),
    );
    let mut ready = String::new();
    let stdout = planted.0.stdout.take().expect("piped");
    std::io::BufReader::new(stdout).read_line(&mut ready).expect("the planted process says it is ready");
    let planted_pid = planted.0.id().to_string();
    let premise = key_text_scan(&planted_pid, std::slice::from_ref(&planted_pid));
    println!("key's text in memory (root's scan): planted {}", premise[&planted_pid]);
    assert!(
        premise[&planted_pid]["key_text"].as_u64() >= Some(1),
        "the premise: the scan finds a planted key's text: {premise}"
    );

    let daemon_pid = pids[0].1.to_string();
    let found = key_text_scan(&daemon_pid, &pids.iter().map(|(_, pid)| pid.to_string()).collect::<Vec<_>>());
    for (role, pid) in pids {
        let scan = &found[pid.to_string()];
        println!("key's text in memory (root's scan): {role} {scan}");
        assert!(scan["bytes_scanned"].as_u64() > Some(0), "{role}: {found}");
        assert_eq!(scan["key_text"], 0, "{role}: the key's text is left in memory: {found}");
        assert_eq!(scan["key_lines"], 0, "{role}: the key's line is left in memory: {found}");
    }
}

/// tests/python/find_key_text.py: the key's text in `pids`' memory, the key taken from `holder`'s.
fn key_text_scan(holder: &str, pids: &[String]) -> Value {
    let out = Command::new("/usr/bin/python3")
        .arg(repository_root().join("tests/python/find_key_text.py"))
        .arg(holder)
        .args(pids)
        .output()
        .expect("the scan runs");
    assert!(out.status.success(), "{}", show(&out));
    serde_json::from_slice(&out.stdout).expect("the scan prints JSON")
}

#[test]
fn an_ordinary_users_clients_find_its_instance_while_the_system_base_exists() {
    let Some(nobody) = nobody_if_root() else { return };
    let _one = exclusive();
    let _system = SystemBase::ensure();
    let instance = unique("key-locate");
    let mut files = UserInstance::new(nobody, &instance);
    let (_config, daemon, status) = running_as(nobody, &instance);
    files.pids = pids(&status).into_iter().map(|(_, pid)| pid).collect();
    assert!(
        files.base.join(&instance).join("prefix").exists(),
        "the instance is under {}",
        files.base.display()
    );
    // vservoctl found it already (`running_as` asks it): say what it printed
    println!("vservoctl status as nobody: state {}, daemon pid {}", status["state"], status["daemon_pid"]);

    let (python, env) = python_for(nobody);
    let out = as_user(&python, nobody)
        .envs(env.iter().map(|(k, v)| (*k, v)))
        .arg(repository_root().join("clients/python/vservo_client.py"))
        .args(["--instance", &instance, "status"])
        .output()
        .expect("the Python client runs");
    println!("Python client as nobody ({}): {}", python.display(), show(&out).trim());
    assert!(out.status.success(), "{}", show(&out));
    assert!(!show(&out).contains("is run by user"), "{}", show(&out));
    daemon.stop();
}

/// Issue 37: `nobody` runs an instance; a client of a third user (no name, no home), which can search neither
/// `/run/vservo` (root's, 0750) nor nobody's base, is told that it found none of its own and that the closed base
/// may hold another user's, and is never told that root runs the instance (vservoctl and the Python client).
#[test]
fn a_third_users_client_is_never_told_that_root_runs_another_users_instance() {
    let Some(nobody) = nobody_if_root() else { return };
    let _one = exclusive();
    let _system_base = SystemBase::ensure();
    let instance = unique("key-third-user");
    let mut files = UserInstance::new(nobody, &instance);
    let (_config, daemon, status) = running_as(nobody, &instance);
    files.pids = pids(&status).into_iter().map(|(_, pid)| pid).collect();
    let third = User { uid: 54321, gid: 54321 };
    let out = as_user(binary("vservoctl"), third)
        .args(["status", "--instance", &instance, "--timeout-s", "1"])
        .output()
        .expect("vservoctl runs");
    println!("vservoctl as uid 54321: {}", show(&out).trim());
    assert_eq!(out.status.code(), Some(1), "{}", show(&out));
    let (python, env) = python_for(third);
    let python_out = as_user(&python, third)
        .envs(env.iter().map(|(k, v)| (*k, v)))
        .arg(repository_root().join("clients/python/vservo_client.py"))
        .args(["--instance", &instance, "status"])
        .output()
        .expect("the Python client runs");
    println!("Python client as uid 54321: {}", show(&python_out).trim());
    assert!(!python_out.status.success(), "{}", show(&python_out));
    for said in [show(&out), show(&python_out)] {
        assert!(!said.contains("is run by user"), "no owner is named for the instance: {said}");
        assert!(said.contains("/run/vservo is closed to this user"), "{said}");
        assert!(said.contains("the directory is user \"root\"'s"), "{said}");
        assert!(!said.contains("Traceback"), "one line, no traceback: {said}");
    }
    daemon.stop();
}

/// Issue 37: the security review's replay against a daemon of a user other than root, by a process of that
/// user (tests/python/replay_attack.py, as nobody): the servo's sealed twists recorded while they moved the arm,
/// the servo SIGKILLed, its slot taken while it restarts and the twists played again for 2 s. The rmrc refuses
/// them (not the announced servo's run) and the arm moves no faster than alone, under 0.1 rad/s.
#[test]
fn replayed_sealed_twists_move_nothing_on_a_non_root_users_own_daemon() {
    let Some(nobody) = nobody_if_root() else { return };
    let _one = exclusive();
    let instance = unique("key-replay");
    let mut files = UserInstance::new(nobody, &instance);
    let (_config, daemon, status) = running_as(nobody, &instance);
    files.pids = pids(&status).into_iter().map(|(_, pid)| pid).collect();
    let refused_before = status["nodes"]["rmrc"]["rejected_messages"].as_i64().unwrap_or(0);
    let (python, env) = python_for(nobody);
    let out = as_user(&python, nobody)
        .envs(env.iter().map(|(k, v)| (*k, v)))
        .arg(repository_root().join("tests/python/replay_attack.py"))
        .arg(&instance)
        .output()
        .expect("the attacker runs");
    assert!(out.status.success(), "{}\n{}", show(&out), daemon.log());
    let stdout = String::from_utf8_lossy(&out.stdout);
    let attack: Value = serde_json::from_str(stdout.lines().last().expect("a line")).expect("JSON");
    println!("replay as nobody on nobody's daemon: {attack}");
    let refused = status_as(nobody, &instance).expect("a status")["nodes"]["rmrc"]["rejected_messages"]
        .as_i64()
        .unwrap_or(0)
        - refused_before;
    let (alone, attacked) = (
        attack["alone_rad_s"].as_f64().expect("alone"),
        attack["attacked_rad_s"].as_f64().expect("attacked"),
    );
    assert!(attack["sent"].as_u64().expect("sent") > 100, "{attack}");
    assert!(refused > 100, "the rmrc refused the replayed twists: {refused}");
    assert!(attacked <= alone + 0.01 && attacked < 0.1, "the arm moved: {attack}");
    daemon.stop();
}

/// The Python client's location rule, case by case (tests/python/check_locate.py), as vservoctl's unit tests
/// (`instance_dir::tests`).
#[test]
fn the_python_client_decides_where_an_instance_is_as_vservoctl_does() {
    let out = Command::new(repository_root().join("target/python-venv/bin/python"))
        .arg(repository_root().join("tests/python/check_locate.py"))
        .output()
        .expect("python runs");
    println!("{}", show(&out).trim());
    assert!(out.status.success(), "{}", show(&out));
}
