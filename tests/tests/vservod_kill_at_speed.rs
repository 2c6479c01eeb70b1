//! The daemon SIGKILLed while a joint moves fast (issue 37): the nodes bring the arm to rest on their own, and
//! the simulated drive then holds it with its own servo, never with the rmrc's last (braking) torque. Twenty
//! kills, each with a joint at 0.9 rad/s or more: every joint comes to rest below 0.05 rad/s within 100 ms of
//! the kill, and none turns back faster than 0.05 rad/s. Real processes over iceoryx2.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use nix::sys::signal::{Signal, kill};
use nix::time::{ClockId, clock_gettime};
use nix::unistd::Pid;
use serde_json::Value;
use vservo_system_tests::{
    Killed, binary, exclusive, fastest_joint_rad_s, numbers, remove_instance, running_daemon, status, unique,
    vservoctl, wait_until,
};

const KILLS: usize = 20;
/// A joint at least this fast when vservod is killed (rad/s).
const FAST_RAD_S: f64 = 0.9;
/// The speed the test waits for before it kills (rad/s): above [`FAST_RAD_S`], since under load a joint's speed
/// wobbles by a few hundredths between the state heard and the kill (one kill on the bar itself fell at 0.876).
/// The move cruises at 1.16 rad/s (measured; at 0.16 of the limits it cruised at 0.93), so the kill lands while
/// the joint still speeds up.
const KILL_AT_RAD_S: f64 = 1.0;
/// At rest: below this speed (rad/s), and a reversal is a joint turning back faster than it.
const REST_RAD_S: f64 = 0.05;
/// Within this long of the kill (ms).
const REST_WITHIN_MS: f64 = 100.0;

/// A joint state as heard: its stamp (CLOCK_MONOTONIC, ns) and the joints' speeds (rad/s).
struct Heard {
    stamp_ns: u64,
    qd_rad_s: Vec<f64>,
}

fn monotonic_ns() -> u64 {
    let now = clock_gettime(ClockId::CLOCK_MONOTONIC).expect("the monotonic clock");
    now.tv_sec() as u64 * 1_000_000_000 + now.tv_nsec() as u64
}

/// The joint states of `instance` as they come, on a channel (the echo is killed when the guard drops).
fn joint_states(instance: &str) -> (Killed, mpsc::Receiver<Heard>) {
    let mut echo = Killed(
        Command::new(binary("vservoctl"))
            .args(["echo", "joint_state", "--instance", instance, "--duration-s", "20"])
            .stdout(Stdio::piped())
            .spawn()
            .expect("echo starts"),
    );
    let stdout = echo.0.stdout.take().expect("piped");
    let (sender, receiver) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let Ok(state) = serde_json::from_str::<Value>(&line) else { continue };
            let heard = Heard {
                stamp_ns: state["stamp_ns"].as_u64().expect("a stamp"),
                qd_rad_s: numbers(&state["qd_rad_s"]),
            };
            if sender.send(heard).is_err() {
                break;
            }
        }
    });
    (echo, receiver)
}

fn fastest(state: &Heard) -> f64 {
    state.qd_rad_s.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// What one kill measured.
struct Kill {
    /// The fastest joint at the kill (rad/s).
    speed_at_kill_rad_s: f64,
    /// From the kill to the state after which every joint stays below [`REST_RAD_S`] (ms).
    rest_after_ms: f64,
    /// The fastest any joint turned back against its motion at the kill (rad/s).
    reversal_rad_s: f64,
}

/// Kills the nodes left when a round ends, passed or not, and removes the instance the killed daemon left.
struct Reaper {
    instance: String,
    pids: Vec<i32>,
}

impl Drop for Reaper {
    fn drop(&mut self) {
        for &pid in &self.pids {
            let _ = kill(Pid::from_raw(pid), Signal::SIGKILL);
        }
        remove_instance(&self.instance);
    }
}

fn one_kill(round: usize) -> Kill {
    let instance = unique(&format!("kill-speed-{round}"));
    let (_config, mut daemon) = running_daemon(&instance);
    let status = status(&instance).expect("a status");
    let pids = ["servo", "vision", "rmrc", "plant"]
        .iter()
        .filter_map(|role| status["nodes"][role]["pid"].as_i64())
        .map(|pid| pid as i32)
        .collect();
    let _reaper = Reaper { instance: instance.clone(), pids };
    // the loop converged from its start: the arm at rest
    assert!(
        wait_until(Duration::from_secs(10), || fastest_joint_rad_s(&instance, "0.2") < REST_RAD_S),
        "{}",
        daemon.log()
    );
    let (_echo, states) = joint_states(&instance);
    // the start's joints from a state of the loop, the goal 1.5 rad away on the waist and 0.4 rad on the shoulder
    let q = start_joints(&instance);
    let goal: Vec<String> =
        q.iter().enumerate().map(|(j, v)| format!("{}", v + [1.5, 0.4, 0.0, 0.0, 0.0, 0.0][j])).collect();
    let (code, out) = vservoctl(&[
        "move-joints",
        "--instance",
        &instance,
        "--q",
        &goal.join(","),
        "--speed-fraction",
        "0.20",
    ]);
    assert_eq!(code, Some(0), "{out}");
    // kill as soon as a joint is fast
    let until = Instant::now() + Duration::from_secs(5);
    let mut before_kill = None;
    while Instant::now() < until {
        let Ok(state) = states.recv_timeout(Duration::from_millis(100)) else { continue };
        if fastest(&state) >= KILL_AT_RAD_S {
            before_kill = Some(state);
            break;
        }
    }
    let before_kill =
        before_kill.unwrap_or_else(|| panic!("no joint reached {KILL_AT_RAD_S} rad/s\n{}", daemon.log()));
    daemon.signal(Signal::SIGKILL);
    let killed_ns = monotonic_ns();
    let _ = daemon.wait(Duration::from_secs(2));
    // every state until the plant has ended (no state for half a second)
    let mut heard = vec![before_kill];
    while let Ok(state) = states.recv_timeout(Duration::from_millis(500)) {
        heard.push(state);
    }
    measure(&heard, killed_ns)
}

/// The joints of the instance's newest joint state (the echo asked again while it hears none: on a loaded
/// machine its start can take longer than its window).
fn start_joints(instance: &str) -> Vec<f64> {
    let until = Instant::now() + Duration::from_secs(5);
    let state = loop {
        if let Some(state) = vservo_system_tests::echo_lines(instance, "joint_state", "0.1").pop() {
            break state;
        }
        assert!(Instant::now() < until, "no joint state of {instance} within 5 s");
    };
    let count = state["joint_count"].as_u64().expect("joint_count") as usize;
    numbers(&state["q_rad"])[..count].to_vec()
}

fn measure(heard: &[Heard], killed_ns: u64) -> Kill {
    let at_kill = heard.iter().rev().find(|s| s.stamp_ns <= killed_ns).expect("a state before the kill");
    let after: Vec<&Heard> = heard.iter().filter(|s| s.stamp_ns > at_kill.stamp_ns).collect();
    assert!(after.len() > 50, "the arm's states after the kill were heard: {}", after.len());
    let moving = |s: &Heard| s.qd_rad_s.iter().any(|v| v.abs() >= REST_RAD_S);
    let rest_from = after.iter().rposition(|s| moving(s)).map_or(at_kill.stamp_ns, |i| after[i].stamp_ns);
    let reversal_rad_s = after
        .iter()
        .flat_map(|s| {
            s.qd_rad_s
                .iter()
                .zip(&at_kill.qd_rad_s)
                .map(|(v, was)| if was.abs() >= REST_RAD_S { (-v * was.signum()).max(0.0) } else { 0.0 })
        })
        .fold(0.0, f64::max);
    Kill {
        speed_at_kill_rad_s: fastest(at_kill),
        rest_after_ms: rest_from.saturating_sub(killed_ns) as f64 / 1e6,
        reversal_rad_s,
    }
}

#[test]
fn twenty_kills_of_the_daemon_at_speed_end_at_rest_within_100_ms_without_a_reversal() {
    let _one = exclusive();
    let kills: Vec<Kill> = (0..KILLS).map(one_kill).collect();
    for (i, k) in kills.iter().enumerate() {
        println!(
            "kill {i:2}: fastest joint {:.3} rad/s at the kill; at rest (< {REST_RAD_S} rad/s) after {:.1} ms; \
             fastest turn back {:.4} rad/s",
            k.speed_at_kill_rad_s, k.rest_after_ms, k.reversal_rad_s
        );
    }
    let worst = |f: fn(&Kill) -> f64| kills.iter().map(f).fold(0.0, f64::max);
    println!(
        "worst of {KILLS}: at rest after {:.1} ms, turn back {:.4} rad/s",
        worst(|k| k.rest_after_ms),
        worst(|k| k.reversal_rad_s)
    );
    for (i, k) in kills.iter().enumerate() {
        assert!(k.speed_at_kill_rad_s >= FAST_RAD_S, "kill {i}: {} rad/s", k.speed_at_kill_rad_s);
        assert!(k.rest_after_ms <= REST_WITHIN_MS, "kill {i}: at rest after {} ms", k.rest_after_ms);
        assert!(k.reversal_rad_s <= REST_RAD_S, "kill {i}: turned back at {} rad/s", k.reversal_rad_s);
    }
}
