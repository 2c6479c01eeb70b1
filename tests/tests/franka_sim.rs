//! The first motion on a real arm, proven on the Franka's own protocol against a robot side someone else wrote:
//! franka-sim 1.1.7 (an FCI server, protocol version 10, on MuJoCo) with the FCI's motion-limit checker and its
//! communication constraints both on, vservod with its Franka driver (vservo-franka), through
//! `scripts/run-franka-sim.sh` (which starts the cell held, resumes it, moves to the start and servos); and the same
//! sequence against franky-sim 1.0.4, a second, independent FCI server (`--address`).

use serde_json::Value;
use std::time::Duration;

use vservo_system_tests::{
    Killed, exclusive, repository_root, run_file, run_script, run_script_to_convergence, wait_until,
};

/// The FR3's joint jerk limit (rad/s³), which franka-sim's checker enforces.
const FR3_JERK_RAD_S3: f64 = 5000.0;

/// `scripts/run-franka-sim.sh --json ARGS`: its summary, whether or not the loop converged.
fn run_franka_sim(args: &[&str]) -> Value {
    let mut all = vec!["--json"];
    all.extend_from_slice(args);
    run_script("run-franka-sim.sh", &all)
}

fn number(summary: &Value, key: &str) -> f64 {
    summary[key].as_f64().unwrap_or_else(|| panic!("{key} in {summary}"))
}

fn reflexes(summary: &Value) -> Vec<String> {
    summary["reflex_errors"]
        .as_array()
        .unwrap_or_else(|| panic!("reflex_errors in {summary}"))
        .iter()
        .map(|e| e.as_str().unwrap_or_default().to_string())
        .collect()
}

/// What every run that ran without a fault must show: no reflex, every command the driver sent within the FR3's
/// jerk limit as the robot measures it (and the limit used: the motion was not a crawl), no loss the robot counted
/// as a violation, and its command success rate.
fn assert_the_robot_accepted_every_command(summary: &Value) {
    assert!(reflexes(summary).is_empty(), "{summary}");
    let jerk = number(summary, "max_joint_jerk_rad_s3");
    assert!(jerk <= FR3_JERK_RAD_S3 && jerk > 1000.0, "{summary}");
    assert_eq!(number(summary, "sim_log_communication_violations"), 0.0, "{summary}");
    // The FCI counts a command lost when it misses its millisecond; over its window of 100 commands the robot
    // reports the share received. On these shared two-core machines the driver misses a single command now and
    // then (0.98–1.0 measured, docs/BENCHMARKS.md): the bar here is that no run of them comes near the robot's
    // limit of 20 in a row.
    assert!(number(summary, "min_control_command_success_rate") >= 0.95, "{summary}");
}

/// From the default start and from a medium-class start, the loop converges below one pixel on the simulated FR3,
/// and the robot accepted every command.
#[test]
fn the_loop_converges_on_franka_sim_with_its_motion_limits_and_communication_constraints_on() {
    let _one = exclusive();
    for start in ["default", "medium"] {
        let summary = run_script_to_convergence("run-franka-sim.sh", &["--start", start]);
        assert_the_robot_accepted_every_command(&summary);
        // the rmrc's own reference kept the limits: the driver's guard had nothing to take off
        assert!(number(&summary, "rmrc_max_jerk_ratio") <= 1.0, "{summary}");
    }
}

/// The dynamics override at a quarter on the FR3 over its own protocol (config/franka-sim.toml with `[robot]
/// speed_scale = 0.25`): the loop converges, and the rmrc's commands keep a quarter of the FR3's acceleration and
/// jerk limits as its controller would measure them, and use them; the robot accepted every command.
#[test]
fn at_a_quarter_speed_the_fr3_keeps_a_quarter_of_its_limits() {
    let _one = exclusive();
    let dir = vservo_system_tests::ScratchDir::new(&vservo_system_tests::unique("franka-quarter"));
    let file = repository_root().join("config/franka-sim.toml");
    let quarter = dir
        .write("quarter.toml", &format!("extends = \"{}\"\n[robot]\nspeed_scale = 0.25\n", file.display()));
    let summary =
        run_script_to_convergence("run-franka-sim.sh", &["--config", &quarter.display().to_string()]);
    assert!(reflexes(&summary).is_empty(), "{summary}");
    for key in ["rmrc_max_acceleration_ratio", "rmrc_max_jerk_ratio"] {
        assert!(number(&summary, key) <= 0.25 * (1.0 + 1e-9), "{key} over a quarter: {summary}");
    }
    assert!(number(&summary, "rmrc_max_jerk_ratio") > 0.2, "the quarter's limits were used: {summary}");
    assert!(number(&summary, "max_joint_jerk_rad_s3") <= 0.25 * FR3_JERK_RAD_S3 * (1.0 + 1e-9), "{summary}");
}

/// The premise: the same run with vservo's jerk limiting off (the arm's jerk limit raised out of reach, the driver's
/// guard off) is stopped by the robot's checker with the FCI's own discontinuity error.
#[test]
fn without_jerk_limiting_the_robot_stops_the_motion_with_its_discontinuity_error() {
    let _one = exclusive();
    let summary = run_franka_sim(&["--no-jerk-limit", "--duration-s", "4"]);
    let reflexes = reflexes(&summary);
    assert!(reflexes.iter().any(|r| r == "joint_motion_generator_acceleration_discontinuity"), "{summary}");
    assert!(number(&summary, "max_joint_jerk_rad_s3") > FR3_JERK_RAD_S3, "{summary}");
}

/// The driver stopped (SIGSTOP) for 100 ms mid-motion: the robot stops itself, as its controller does
/// (`communication_constraints_violation`), the cell stops safely naming the driver's fault and the robot's error,
/// and `vservoctl resume`
/// runs the robot's error recovery and a new motion, which converges.
#[test]
fn a_stopped_driver_is_a_named_safe_stop_and_resume_recovers_the_robot() {
    let _one = exclusive();
    let summary =
        run_script_to_convergence("run-franka-sim.sh", &["--start", "medium", "--fault", "driver-stopped"]);
    assert!(reflexes(&summary).iter().any(|r| r == "communication_constraints_violation"), "{summary}");
    assert_eq!(summary["fault_status"]["name"], "driver_fault", "{summary}");
    // the status names the Franka's own error
    assert_eq!(summary["fault_status"]["driver_error"], "communication_constraints_violation", "{summary}");
    assert_eq!(summary["resumed_after_fault"], true, "{summary}");
    assert!(number(&summary, "max_joint_jerk_rad_s3") <= FR3_JERK_RAD_S3, "{summary}");
}

/// franky-sim 1.0.4 as shipped (its own venv, target/franky-sim-venv, with the pinocchio it starts with), a second
/// FCI server written by others than franka-sim's authors: `run-franka-sim.sh --address` runs the held start, the
/// move and the servo against it, and from both starts the loop converges below 1 px with every command accepted.
/// franky-sim sends its states from 127.0.0.1 whatever address it is told to serve on (the driver takes states from
/// the robot's host only), and its port is 1337: it serves on 127.0.0.1:1337, this binary's tests one at a time.
#[test]
fn the_loop_converges_on_franky_sim_a_second_fci_server() {
    let _one = exclusive();
    let server = repository_root().join("target/franky-sim-venv/bin/franky-sim");
    let _franky = Killed(
        std::process::Command::new(server)
            .args(["-s", "mujoco", "--hostname", "127.0.0.1"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("franky-sim starts (scripts/setup-franka-sim.sh installs it)"),
    );
    let listening = || std::net::TcpStream::connect("127.0.0.1:1337").is_ok();
    assert!(wait_until(Duration::from_secs(60), listening), "franky-sim never listened on 127.0.0.1:1337");
    for start in ["default", "medium"] {
        let summary = run_script_to_convergence(
            "run-franka-sim.sh",
            &["--address", "127.0.0.1:1337", "--start", start],
        );
        println!("franky-sim, {start} start: {summary}");
        assert_the_robot_accepted_every_command(&summary);
    }
}

/// franka-sim itself killed mid-motion (the robot gone) and started again: the cell stops safely, a resume while
/// the robot is gone is refused naming the lost connection, and once franka-sim is back `vservoctl resume` starts a
/// new motion on the driver's new connection, which converges below 1 px.
#[test]
fn a_robot_server_killed_and_started_again_is_resumed_on_a_new_connection() {
    let _one = exclusive();
    let summary = run_script_to_convergence("run-franka-sim.sh", &["--fault", "server-restarted"]);
    let refused = summary["refused_while_gone"].as_str().unwrap_or_default();
    assert!(refused.contains("robot_connection_lost"), "the refusal names the cause: {summary}");
    assert_eq!(summary["resumed_after_restart"], true, "{summary}");
    assert_eq!(
        (summary["connections_lost"].as_u64(), summary["reconnections"].as_u64()),
        (Some(1), Some(1)),
        "{summary}"
    );
    assert!(number(&summary, "max_joint_jerk_rad_s3") <= FR3_JERK_RAD_S3, "{summary}");
}

/// A robot gone without a word (franka-sim SIGSTOPped: silent, its connection still open, as when a cable is
/// pulled): the cell stops safely; a resume asks the robot for its error recovery, which no one answers, so the
/// driver gives the connection up (`robot_connection_lost`, which a resume's refusal names); once the server runs
/// again, a resume starts a new motion on a new connection and the loop converges.
#[test]
fn a_silent_robot_is_given_up_after_its_recovery_and_resumed_once_it_is_back() {
    let _one = exclusive();
    let summary = run_script_to_convergence("run-franka-sim.sh", &["--fault", "server-silent"]);
    let silent = summary["silent_status"].to_string();
    assert!(silent.contains("robot_connection_lost"), "given up while silent: {summary}");
    let refused = summary["refused_while_silent"].as_str().unwrap_or_default();
    assert!(refused.contains("robot_connection_lost"), "the refusal names the cause: {summary}");
    assert_eq!(summary["resumed_after_return"], true, "{summary}");
    assert_eq!(
        (summary["connections_lost"].as_u64(), summary["reconnections"].as_u64()),
        (Some(1), Some(1)),
        "{summary}"
    );
    assert!(number(&summary, "max_joint_jerk_rad_s3") <= FR3_JERK_RAD_S3, "{summary}");
}

/// vservod SIGKILLed while the arm moves: its Franka driver brings the arm to rest within the limits and finishes
/// the motion; the robot saw no violation of any kind.
#[test]
fn the_daemon_killed_mid_motion_leaves_the_arm_at_rest_and_the_motion_finished() {
    let _one = exclusive();
    let summary = run_franka_sim(&["--start", "medium", "--fault", "daemon-killed"]);
    assert!(number(&summary, "speed_at_stop_rad_s") > 0.01, "the arm moved when the daemon died: {summary}");
    assert_eq!(summary["driver_finished"], true, "{summary}");
    assert!(reflexes(&summary).is_empty(), "{summary}");
    assert_eq!(number(&summary, "sim_log_communication_violations"), 0.0, "{summary}");
    assert!(number(&summary, "max_joint_jerk_rad_s3") <= FR3_JERK_RAD_S3, "{summary}");
}

/// Two runs of the script at once keep their own folders: each run's overlay, log and recordings are its own (a
/// shared folder once let one test read the other's aborted recording). Both run without vservo's jerk limiting,
/// so that each ends with its summary whatever the robot's checker does with two cells on two cores; one starts
/// from the default start and the other from the medium one, and each folder must hold its own run's overlay and
/// its own instance's log.
#[test]
fn two_runs_at_once_keep_their_own_folders() {
    let _one = exclusive();
    let runs: Vec<_> = ["default", "medium"]
        .into_iter()
        .map(|start| {
            std::thread::spawn(move || {
                run_franka_sim(&["--no-jerk-limit", "--start", start, "--duration-s", "2"])
            })
        })
        .collect();
    let summaries: Vec<Value> = runs.into_iter().map(|run| run.join().expect("the run's thread")).collect();
    let folders: Vec<&str> =
        summaries.iter().map(|s| s["run_folder"].as_str().expect("run_folder")).collect();
    assert_ne!(folders[0], folders[1], "{summaries:?}");
    for (summary, medium) in summaries.iter().zip([false, true]) {
        let overlay = run_file(summary, "franka-sim.toml");
        assert_eq!(overlay.contains("initial_camera_translation_m"), medium, "{overlay}");
        let instance = overlay.lines().find(|l| l.starts_with("name = ")).expect("the instance's name");
        let instance = instance.trim_start_matches("name = ").trim_matches('"');
        assert!(run_file(summary, "vservod.log").contains(instance), "{instance} in its own log");
    }
}

/// Issue 46's takeover of a held Franka cell: before any resume, a process of the daemon's user SIGKILLs the rmrc,
/// takes its `joint_command` slot and answers each joint state with 0.3 rad/s on joint 1, unsealed, for 3 s. The
/// Franka driver takes none of it (not the rmrc's seal) and the robot's joint 1 does not move (it moved 0.606 rad
/// before the driver checked the seal); vservod names the attacker's pid.
#[test]
fn a_rogue_that_takes_a_held_cells_command_stream_moves_nothing_and_is_named() {
    let _one = exclusive();
    let summary = run_franka_sim(&["--fault", "held-takeover"]);
    let attack = &summary["attack"];
    assert!(number(attack, "sent") > 1000.0, "the premise: the rogue answered the states for 3 s: {summary}");
    assert!(number(attack, "moved_rad") < 1e-3, "joint 1 moved: {summary}");
    assert!(number(attack, "fastest_rad_s") < 1e-3, "{summary}");
    // every rogue command the driver saw it refused; a driver late for a cycle finds only the newest samples in
    // its buffer (the service drops the oldest on overflow), so one pushed out is neither taken nor refused: seen
    // once in CI (3,046 refused of 3,047 sent, 4,526 late answers), while nothing moved
    let (refused, sent) = (number(&summary, "commands_refused"), number(attack, "sent"));
    assert!(refused >= 0.99 * sent, "the rogue's commands refused: {refused} of {sent}: {summary}");
    assert_eq!(attack["state_before"], attack["state_after"], "the cell stays held: {summary}");
    assert_eq!(summary["rogue_named"], true, "{summary}");
    assert!(reflexes(&summary).is_empty(), "{summary}");
}

/// Issue 46's attack on the Franka driver's state stream: 1 s into servoing a local process finds the driver's UDP
/// port and sends it one 10-byte datagram and 200 states numbered ahead of the robot's. The driver drops and counts
/// all 201 (not from the robot), answers the robot only, and the loop converges with no reflex (the 10-byte datagram
/// once ended the driver with the motion running, and the spoofed states took the stream over).
#[test]
fn datagrams_spoofed_to_the_drivers_udp_port_change_nothing_and_the_motion_goes_on() {
    let _one = exclusive();
    let summary = run_script_to_convergence("run-franka-sim.sh", &["--fault", "udp-spoof"]);
    assert_eq!(summary["spoof"]["sent_states"], 200, "the premise: the spoofer sent: {summary}");
    assert!(summary["spoof"]["driver_udp"].as_str().is_some_and(|a| !a.starts_with("0.0.0.0")), "{summary}");
    assert_eq!(number(&summary["datagrams_dropped"], "foreign"), 201.0, "{summary}");
    assert_the_robot_accepted_every_command(&summary);
}

/// A wrong `[franka] port` (nothing listens there): the driver vservod starts says, in one line, the address it
/// tried and what to check — the address, the cable and that FCI is activated in Desk — instead of a bare
/// "Connection refused" (issue 49).
#[test]
fn a_wrong_address_is_one_line_naming_it_and_what_to_check() {
    let _one = exclusive();
    let instance = vservo_system_tests::unique("franka-wrong-port");
    let free = std::net::TcpListener::bind("127.0.0.1:0").expect("a port").local_addr().expect("its address");
    let port = free.port();
    let config = vservo_system_tests::config_from(
        "config/franka-sim.toml",
        &[
            ("name = \"franka-sim\"", &format!("name = \"{instance}\"")),
            ("port = 1337", &format!("port = {port}")),
        ],
    );
    let daemon = vservo_system_tests::Daemon::start(&config);
    let address = format!("127.0.0.1:{port}");
    let line = |log: &str| {
        log.lines()
            .filter(|l| l.contains(&address) && l.contains("FCI is activated in Desk"))
            .map(str::to_string)
            .next()
    };
    let said =
        vservo_system_tests::wait_until(std::time::Duration::from_secs(10), || line(&daemon.log()).is_some());
    assert!(said, "{}", daemon.log());
    let said = line(&daemon.log()).expect("the line");
    println!("{said}");
    assert!(said.contains("check the address, the cable"), "{said}");
    daemon.stop();
}
