//! One writer per stream (issue 22, docs/PROTOCOL.md "One writer per stream"): while the cell runs, a second
//! writer on any stream is refused by iceoryx2; a process that takes a stream's slot while its node restarts
//! is named (fault `stream_taken`, the log names its pid) and what it sends moves nothing: twists and
//! features without their node's seal are refused, and so are joint commands without the rmrc's. The attacker
//! is this test process: another process of the daemon's user, as a user's own faulty or hostile script is.

use std::time::{Duration, Instant};

use iceoryx2::prelude::{Node, ipc};
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;
use serde_json::Value;
use vservo_protocol::{
    CameraTwistMsg, CellModeMsg, CommandMode, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointCommandMsg,
    JointStateMsg, ObjectMsg, Opening, ProtocolError, SimWorldMsg, TelemetryMsg, Topic, Verdict,
};
use vservo_system_tests::{
    Daemon, TempConfig, exclusive, run, running, running_daemon, status, unique, wait_until,
};

/// The writer port `create` made, refused as "every slot held", or refused otherwise (the test fails).
fn refused_as_taken<P>(what: &str, created: Result<P, ProtocolError>) -> bool {
    match created {
        Ok(_) => false,
        Err(e) if e.is_slot_taken() => true,
        Err(e) => panic!("{what}: refused for another reason: {e}"),
    }
}

#[test]
fn a_second_writer_is_refused_on_every_stream_while_the_cell_runs() {
    let _one = exclusive();
    let instance = unique("second-writer");
    let (_config, daemon) = running_daemon(&instance);
    let rogue = vservo_protocol::create_node(&instance, "rogue").expect("a node");
    let i = instance.as_str();
    use vservo_protocol::{camera_image_notifier, camera_image_publisher, notifier, publisher};
    let attempts = [
        (
            "joint_state",
            refused_as_taken("joint_state", publisher::<JointStateMsg>(&rogue, i, Topic::JointState)),
        ),
        ("joint_state event", refused_as_taken("joint_state event", notifier(&rogue, i, Topic::JointState))),
        ("joint_command", refused_as_taken("", publisher::<JointCommandMsg>(&rogue, i, Topic::JointCommand))),
        ("sim_world", refused_as_taken("sim_world", publisher::<SimWorldMsg>(&rogue, i, Topic::SimWorld))),
        ("features", refused_as_taken("features", publisher::<FeaturesMsg>(&rogue, i, Topic::Features))),
        ("features event", refused_as_taken("features event", notifier(&rogue, i, Topic::Features))),
        ("camera_twist", refused_as_taken("", publisher::<CameraTwistMsg>(&rogue, i, Topic::CameraTwist))),
        ("telemetry", refused_as_taken("telemetry", publisher::<TelemetryMsg>(&rogue, i, Topic::Telemetry))),
        ("status", refused_as_taken("status", publisher::<DaemonStatusMsg>(&rogue, i, Topic::Status))),
        ("gains", refused_as_taken("gains", publisher::<GainsMsg>(&rogue, i, Topic::Gains))),
        ("object", refused_as_taken("object", publisher::<ObjectMsg>(&rogue, i, Topic::Object))),
        ("cell_mode", refused_as_taken("cell_mode", publisher::<CellModeMsg>(&rogue, i, Topic::CellMode))),
        ("camera_image", refused_as_taken("camera_image", camera_image_publisher(&rogue, i))),
        ("camera_image event", refused_as_taken("camera_image event", camera_image_notifier(&rogue, i))),
    ];
    let server = vservo_protocol::open_command_service(&rogue, i, Opening::OpenOnly)
        .expect("the command service opens")
        .server_builder()
        .create();
    let command_server_refused = matches!(
        server,
        Err(iceoryx2::service::port_factory::server::ServerCreateError::ExceedsMaxSupportedServers)
    );
    for (stream, refused) in &attempts {
        println!("second writer on {stream}: {}", if *refused { "refused" } else { "ACCEPTED" });
    }
    println!("second server on command: {}", if command_server_refused { "refused" } else { "ACCEPTED" });
    // the premise: the services are open to this process (it reads them), only their writer slots are held
    let reader = vservo_protocol::subscriber::<CameraTwistMsg>(&rogue, i, Topic::CameraTwist);
    assert!(reader.is_ok(), "a reader is let in: the refusals above are the writer slots'");
    assert!(attempts.iter().all(|(_, refused)| *refused), "{attempts:?}");
    assert!(command_server_refused, "a second command server");
    let after = status(&instance).expect("status");
    assert!(running(&after), "the attempts changed nothing: {after}\n{}", daemon.log());
    daemon.stop();
}

/// The fastest joint speed (rad/s) in the joint states `states` brings during `window`.
fn fastest_joint(states: &iceoryx2::port::subscriber::Subscriber<ipc::Service, JointStateMsg, ()>) -> f64 {
    let mut fastest = 0.0f64;
    while let Ok(Some(state)) = states.receive() {
        fastest = state.qd_rad_s.iter().fold(fastest, |m, v| m.max(v.abs()));
    }
    fastest
}

fn fault_of(status: &Value) -> String {
    status["fault"]["name"].as_str().unwrap_or("none").to_string()
}

fn node_pid(instance: &str, role: &str) -> i32 {
    status(instance).and_then(|s| s["nodes"][role]["pid"].as_i64()).expect("the node's pid") as i32
}

fn rejected(instance: &str, role: &str) -> i64 {
    status(instance).and_then(|s| s["nodes"][role]["rejected_messages"].as_i64()).unwrap_or(0)
}

/// What one attack did.
struct Attack {
    /// The fastest joint over 2 s of the cell alone, converged, and over the 2 s attack (rad/s).
    alone_rad_s: f64,
    attacked_rad_s: f64,
    /// The fastest joint from [`BRAKED_AFTER`] into the attack on (rad/s).
    braked_rad_s: f64,
    /// From the slot taken to the status naming `stream_taken`.
    named_after: Option<Duration>,
    /// Messages the attack sent.
    sent: u64,
}

/// Runs the default cell until it converged, then kills `role`, takes the slot of `topic` that its death
/// frees, and sends for 2 s what `forge` makes of the latest joint state (at about 500 Hz); once the
/// attacker is gone, the node comes back and the cell resumes.
fn attack<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + Copy + 'static>(
    name: &str,
    role: &str,
    topic: Topic,
    mut forge: impl FnMut(&JointStateMsg, u64, &[T]) -> T,
) -> (Attack, Daemon, String, TempConfig) {
    let instance = unique(name);
    let (config, daemon) = running_daemon(&instance);
    // the attacker, of the daemon's user, records the stream from the start (its sealed samples of the transient)
    let rogue: Node<ipc::Service> = vservo_protocol::create_node(&instance, "rogue").expect("a node");
    let recorder = vservo_protocol::subscriber::<T>(&rogue, &instance, topic).expect("a recorder");
    let mut recorded: Vec<T> = Vec::new();
    let converged = wait_until(Duration::from_secs(30), || {
        while let Ok(Some(sample)) = recorder.receive() {
            recorded.push(*sample);
        }
        status(&instance).and_then(|s| s["feature_error_px"].as_f64()).is_some_and(|e| e < 1.0)
    });
    assert!(converged, "the cell alone converges: {:?}\n{}", status(&instance), daemon.log());
    drop(recorder);
    let states =
        vservo_protocol::subscriber::<JointStateMsg>(&rogue, &instance, Topic::JointState).expect("a reader");
    // converged below a pixel is not yet at rest: the arm settles first, so that the window alone and the attack's
    // start from the same still arm (a CI run measured 0.017 rad/s alone, still closing in, against 0.033 rad/s in
    // the kill's own transient, with every rogue twist refused)
    let settled = wait_until(Duration::from_secs(10), || {
        while states.receive().ok().flatten().is_some() {}
        std::thread::sleep(Duration::from_millis(500));
        fastest_joint(&states) < vservo_runtime::AT_REST_RAD_S
    });
    assert!(settled, "the cell alone comes to rest: {:?}\n{}", status(&instance), daemon.log());
    std::thread::sleep(Duration::from_secs(2));
    let alone_rad_s = fastest_joint(&states);

    let pid = node_pid(&instance, role);
    kill(Pid::from_raw(pid), Signal::SIGKILL).expect("the node can be killed");
    let publisher = take_slot::<T>(&rogue, &instance, topic);
    let taken_at = Instant::now();
    let mut named_after = None;
    let mut latest = JointStateMsg::default();
    let mut fastest = 0.0f64;
    let mut fastest_after_brake = 0.0f64;
    let mut sent = 0u64;
    let mut next_look = taken_at;
    while taken_at.elapsed() < Duration::from_secs(2) {
        while let Ok(Some(state)) = states.receive() {
            fastest = state.qd_rad_s.iter().fold(fastest, |m, v| m.max(v.abs()));
            if taken_at.elapsed() >= BRAKED_AFTER {
                fastest_after_brake = state.qd_rad_s.iter().fold(fastest_after_brake, |m, v| m.max(v.abs()));
            }
            latest = *state;
        }
        if publisher.send_copy(forge(&latest, sent, &recorded)).is_ok() {
            sent += 1;
        }
        if named_after.is_none() && Instant::now() >= next_look {
            next_look = Instant::now() + Duration::from_millis(100);
            if status(&instance).is_some_and(|s| fault_of(&s) == "stream_taken") {
                named_after = Some(taken_at.elapsed());
            }
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    drop(publisher);
    let attack =
        Attack { alone_rad_s, attacked_rad_s: fastest, braked_rad_s: fastest_after_brake, named_after, sent };
    (attack, daemon, instance, config)
}

/// The slot a killed node's death frees, taken before the daemon restarts the node.
fn take_slot<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + Copy + 'static>(
    rogue: &Node<ipc::Service>,
    instance: &str,
    topic: Topic,
) -> iceoryx2::port::publisher::Publisher<ipc::Service, T, ()> {
    let until = Instant::now() + Duration::from_secs(2);
    loop {
        match vservo_protocol::publisher::<T>(rogue, instance, topic) {
            Ok(publisher) => return publisher,
            Err(e) if e.is_slot_taken() && Instant::now() < until => {
                std::thread::sleep(Duration::from_micros(200))
            }
            Err(e) => panic!("the premise: the attacker takes the {} slot: {e}", topic.name()),
        }
    }
}

/// The attacker gone, the node is back and a resume lets the cell servo again.
fn recovers(daemon: &Daemon, instance: &str, role: &str) {
    let back = wait_until(Duration::from_secs(30), || {
        status(instance).is_some_and(|s| s["nodes"][role]["healthy"] == true)
    });
    assert!(back, "the {role} node is back once the slot is free: {:?}\n{}", status(instance), daemon.log());
    let resumed = wait_until(Duration::from_secs(10), || {
        let _ = run("vservoctl", &["resume", "--instance", instance]);
        status(instance).is_some_and(|s| running(&s))
    });
    assert!(resumed, "the cell resumes: {:?}\n{}", status(instance), daemon.log());
}

fn report(what: &str, attack: &Attack, refused: i64) {
    println!(
        "{what}: sent {} for 2 s; fastest joint alone {:.4} rad/s, under attack {:.4} rad/s ({:.4} rad/s once braked); refused {refused}; \
         stream_taken in the status after {}",
        attack.sent,
        attack.alone_rad_s,
        attack.attacked_rad_s,
        attack.braked_rad_s,
        attack.named_after.map_or("never".into(), |d| format!("{:.2} s", d.as_secs_f64())),
    );
}

/// When the rmrc is the node killed, its death alone hands the arm to the drives' brake (the last command's reference
/// followed for `hold_after_missed_ticks`, then braked to rest), a transient no attacker causes or can change;
/// by this time into the attack that brake has brought the arm to rest, so a command taken from the
/// attacker would show as motion after it (a forged torque the plant took would be applied on every tick).
const BRAKED_AFTER: Duration = Duration::from_millis(500);

/// The margin over the cell alone's fastest joint within which the arm counts as unmoved (rad/s).
const UNMOVED_MARGIN_RAD_S: f64 = 0.01;

fn named_in_the_log(daemon: &Daemon) -> bool {
    let log = daemon.log();
    let pid = format!("pid={}", std::process::id());
    log.lines().any(|line| line.contains("stream taken") && line.contains(&pid))
}

/// Whose refusals count for an attack, and whether the arm's speed says anything (not when the attacker
/// publishes the joint states itself).
struct Expect {
    refused_by: Option<&'static str>,
    arm: ArmJudged,
}

/// What the arm's joint speeds must show under an attack.
#[derive(Clone, Copy)]
enum ArmJudged {
    /// Nothing (the attacker publishes the joint states itself).
    NotMeasured,
    /// Over the whole attack, no faster than the cell alone and settled (the killed node's job is taken over by
    /// the rmrc, which keeps commanding the arm), and at rest from [`BRAKED_AFTER`] on, while the attacker still
    /// sends (a message taken would move it on every tick).
    NoFasterThanAlone,
    /// At rest from [`BRAKED_AFTER`] on (the killed node is the rmrc: the drives hold the arm).
    AtRestOnceBraked,
}

/// The attack moved nothing (as far as measured), stopped the cell with `stream_taken` naming this process,
/// was refused by the node it targeted; once the attacker let go, the node `role` came back and the cell
/// resumes.
fn judge(what: &str, attack: &Attack, daemon: Daemon, instance: &str, role: &str, expect: Expect) {
    let refused = expect.refused_by.map_or(0, |node| rejected(instance, node));
    report(what, attack, refused);
    match expect.arm {
        ArmJudged::NotMeasured => {}
        ArmJudged::NoFasterThanAlone => {
            assert!(attack.attacked_rad_s <= attack.alone_rad_s + UNMOVED_MARGIN_RAD_S, "the arm moved");
            assert!(
                attack.braked_rad_s <= vservo_runtime::AT_REST_RAD_S,
                "the arm is not at rest under the attack"
            )
        }
        ArmJudged::AtRestOnceBraked => {
            assert!(attack.braked_rad_s <= vservo_runtime::AT_REST_RAD_S, "the arm is not held at rest")
        }
    }
    assert!(
        attack.named_after.is_some(),
        "stream_taken in the status: {:?}\n{}",
        status(instance),
        daemon.log()
    );
    assert!(named_in_the_log(&daemon), "the log names this process:\n{}", daemon.log());
    if let Some(node) = expect.refused_by {
        assert!(refused > 100, "the {node} refused the unsealed messages ({refused})");
    }
    recovers(&daemon, instance, role);
    daemon.stop();
}

#[test]
fn rogue_twists_in_the_servos_slot_move_nothing_and_are_named() {
    let _one = exclusive();
    let (attack, daemon, instance, _config) =
        attack("rogue-twists", "servo", Topic::CameraTwist, |_, n, _| CameraTwistMsg {
            verdict: Verdict::Servoing.into(),
            frame: 1_000_000 + n,
            gains_version: 1,
            // in range: 0.05 m/s along the optical axis (the attack)
            twist: [0.0, 0.0, 0.05, 0.0, 0.0, 0.0],
            feature_error_px: 0.0,
            seal: n.wrapping_mul(0x9e37_79b9_7f4a_7c15),
            ..CameraTwistMsg::default()
        });
    let expect = Expect { refused_by: Some("rmrc"), arm: ArmJudged::NoFasterThanAlone };
    judge("rogue twists", &attack, daemon, &instance, "servo", expect);
}

/// The security review's replay: the servo's own sealed twists, recorded from the start of the run (the transient,
/// when they moved the arm), played again into its slot while it restarts. Sealed, but stale: the rmrc refuses
/// them (`vservo_protocol::freshness::stream_standing`) and the arm does not move.
#[test]
fn replayed_sealed_twists_in_the_servos_slot_move_nothing() {
    let _one = exclusive();
    let (attack, daemon, instance, _config) =
        attack("replayed-twists", "servo", Topic::CameraTwist, |_, n, recorded: &[CameraTwistMsg]| {
            let moving: Vec<&CameraTwistMsg> =
                recorded.iter().filter(|t| t.twist.iter().any(|v| v.abs() > 0.01)).collect();
            assert!(!moving.is_empty(), "the premise: twists that moved the arm were recorded");
            *moving[n as usize % moving.len()]
        });
    let expect = Expect { refused_by: Some("rmrc"), arm: ArmJudged::NoFasterThanAlone };
    judge("replayed sealed twists", &attack, daemon, &instance, "servo", expect);
}

/// The same with the vision node's sealed features of the transient, into its slot: the servo refuses them.
#[test]
fn replayed_sealed_features_in_the_vision_nodes_slot_move_nothing() {
    let _one = exclusive();
    let (attack, daemon, instance, _config) =
        attack("replayed-features", "vision", Topic::Features, |_, n, recorded: &[FeaturesMsg]| {
            assert!(
                recorded.len() >= 3,
                "the premise: the transient's features were recorded ({})",
                recorded.len()
            );
            // the first frames: far from the target
            recorded[n as usize % 3]
        });
    let expect = Expect { refused_by: Some("servo"), arm: ArmJudged::NoFasterThanAlone };
    judge("replayed sealed features", &attack, daemon, &instance, "vision", expect);
}

#[test]
fn rogue_features_in_the_vision_nodes_slot_move_nothing_and_are_named() {
    let _one = exclusive();
    // the real features the cell converged on, +40 px: what the attacker sent
    let target = [151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0].map(|v: f64| v + 40.0);
    let (attack, daemon, instance, _config) =
        attack("rogue-features", "vision", Topic::Features, |state, n, _| FeaturesMsg {
            valid_mask: 0b1111,
            frame: 1_000_000 + n,
            capture_tick: state.tick,
            capture_stamp_ns: state.stamp_ns,
            stamp_ns: state.stamp_ns,
            features_px: target,
            seal: n,
            ..FeaturesMsg::default()
        });
    let expect = Expect { refused_by: Some("servo"), arm: ArmJudged::NoFasterThanAlone };
    judge("rogue features", &attack, daemon, &instance, "vision", expect);
}

#[test]
fn a_torque_flood_in_the_rmrcs_slot_moves_nothing_and_is_named() {
    let _one = exclusive();
    // inside every limit: only the seal refuses these
    let within_limits_nm = [87.8, 167.8, 80.5, 21.8, 18.1, 19.2, 0.0];
    let (attack, daemon, instance, _config) =
        attack("torque-flood", "rmrc", Topic::JointCommand, |state, n, _| JointCommandMsg {
            mode: CommandMode::Torque.into(),
            answers_tick: state.tick,
            driver_epoch: state.driver_epoch,
            state_stamp_ns: state.stamp_ns,
            stamp_ns: state.stamp_ns,
            torque_nm: within_limits_nm,
            q_ref_rad: state.q_rad,
            seal: n,
            ..JointCommandMsg::default()
        });
    let expect = Expect { refused_by: Some("plant"), arm: ArmJudged::AtRestOnceBraked };
    judge("torque flood", &attack, daemon, &instance, "rmrc", expect);
}

#[test]
fn a_second_driver_in_the_plants_slot_is_named_and_stops_the_cell() {
    let _one = exclusive();
    // the joints the real driver last said, 0.05 rad off, with its epoch and the next tick: the second
    // driver (which this process also hears: the ticks go on from its own)
    let mut real: Option<JointStateMsg> = None;
    let (attack, daemon, instance, _config) =
        attack("second-driver", "plant", Topic::JointState, |state, _, _| {
            let mut forged = *real.get_or_insert(*state);
            forged.tick = state.tick + 1;
            forged.q_rad[0] += 0.05;
            forged
        });
    let held = status(&instance).expect("status");
    assert_eq!(held["state"], "safe-stop", "{held}");
    judge(
        "second driver",
        &attack,
        daemon,
        &instance,
        "plant",
        Expect { refused_by: None, arm: ArmJudged::NotMeasured },
    );
}

/// Issue 37: the plant killed, a forged joint state 0.2 rad away left in the stream (its slot taken while the
/// plant restarts): the restarted plant starts where the plant it replaces was, from a state that plant sent,
/// not from the forged one.
#[test]
fn a_restarted_plant_resumes_from_its_own_last_state_not_a_forged_one() {
    let _one = exclusive();
    let instance = unique("forged-resume");
    let (_config, daemon) = running_daemon(&instance);
    assert!(
        wait_until(Duration::from_secs(30), || status(&instance)
            .and_then(|s| s["feature_error_px"].as_f64())
            .is_some_and(|e| e < 1.0)),
        "{}",
        daemon.log()
    );
    let rogue: Node<ipc::Service> = vservo_protocol::create_node(&instance, "rogue").expect("a node");
    let states =
        vservo_protocol::subscriber::<JointStateMsg>(&rogue, &instance, Topic::JointState).expect("a reader");
    while states.receive().ok().flatten().is_some() {}
    std::thread::sleep(Duration::from_millis(50));
    kill(Pid::from_raw(node_pid(&instance, "plant")), Signal::SIGKILL).expect("the plant can be killed");
    let publisher = take_slot::<JointStateMsg>(&rogue, &instance, Topic::JointState);
    // every state the dead plant sent: the last is where the arm is
    let mut own = None;
    while let Ok(Some(state)) = states.receive() {
        own = Some(*state);
    }
    let own = own.expect("the plant's states");
    for n in 0..100 {
        let mut forged = own;
        forged.tick = own.tick + 1 + n;
        forged.q_rad[0] += 0.2;
        let _ = publisher.send_copy(forged);
        std::thread::sleep(Duration::from_millis(2));
    }
    drop(publisher);
    // the restarted plant's first state: the first of another driver epoch than the dead plant's (the forged
    // states carry its epoch)
    let mut first = None;
    let restarted = wait_until(Duration::from_secs(15), || {
        while let Ok(Some(state)) = states.receive() {
            if state.driver_epoch != own.driver_epoch {
                first = Some(*state);
                return true;
            }
        }
        false
    });
    assert!(restarted, "the plant restarts: {:?}\n{}", status(&instance), daemon.log());
    let first = first.expect("its first state");
    for j in 0..6 {
        assert!(
            (first.q_rad[j] - own.q_rad[j]).abs() < 1e-9,
            "joint {}: the restarted plant starts at {} rad, the plant it replaces was at {} rad (forged: {})",
            j + 1,
            first.q_rad[j],
            own.q_rad[j],
            own.q_rad[j] + if j == 0 { 0.2 } else { 0.0 }
        );
    }
    println!("the restarted plant starts where its predecessor was: {:?}", &first.q_rad[..6]);
}
