//! The Python clients' structures and codes (clients/python/) are the Rust declarations': every ctypes
//! structure has the fields, offsets and sizes of the Rust payload of the same type name, and the codes they
//! name have the Rust enums' numbers and names. Read from the Python files as Python sees them.

use std::collections::BTreeMap;

use serde_json::Value;
use vservo_protocol::{CommandKind, CommandMode, DaemonState, DriverStatus, Fault, SCHEMA_VERSION};
use vservo_system_tests::repository_root;

fn python_view() -> Value {
    let python = repository_root().join("target/python-venv/bin/python");
    let out = std::process::Command::new(&python)
        .arg(repository_root().join("tests/python/dump_layouts.py"))
        .arg(repository_root().join("clients/python"))
        .output()
        .expect("python runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON")
}

/// "SCREAMING_CASE" of a code's variant name as the Python files write it.
fn screaming(name: &str) -> String {
    name.to_uppercase().replace([' ', '-'], "_")
}

#[test]
fn the_python_clients_structures_are_the_rust_layouts() {
    let python = python_view();
    let rust: BTreeMap<&str, _> =
        vservo_protocol::layout::layouts().into_iter().map(|l| (l.type_name, l)).collect();
    let structures = python["structures"].as_object().expect("structures");
    assert!(structures.len() >= 8, "{structures:?}");
    for (type_name, layout) in structures {
        let declared =
            rust.get(type_name.as_str()).unwrap_or_else(|| panic!("{type_name}: no such Rust payload"));
        assert_eq!(layout["size"].as_u64(), Some(declared.size as u64), "{type_name}: size");
        let fields: Vec<(String, u64, u64)> = layout["fields"]
            .as_array()
            .expect("fields")
            .iter()
            .map(|f| {
                (
                    f[0].as_str().expect("a name").to_owned(),
                    f[1].as_u64().expect("an offset"),
                    f[2].as_u64().expect("a size"),
                )
            })
            .collect();
        let expected: Vec<(String, u64, u64)> =
            declared.fields.iter().map(|f| (f.name.to_owned(), f.offset as u64, f.size as u64)).collect();
        assert_eq!(fields, expected, "{type_name}: fields (name, offset, size)");
    }
}

#[test]
fn the_python_clients_codes_are_the_rust_enums() {
    let codes = &python_view()["codes"];
    assert_eq!(codes["schema"], serde_json::json!([SCHEMA_VERSION, SCHEMA_VERSION]));
    let names = |all: &[DaemonState]| all.iter().map(|s| s.name()).collect::<Vec<_>>();
    assert_eq!(codes["daemon_state"], serde_json::json!(names(DaemonState::ALL)));
    assert_eq!(codes["fault"], serde_json::json!(Fault::ALL.iter().map(|f| f.name()).collect::<Vec<_>>()));
    for kind in CommandKind::ALL {
        let python_name = screaming(kind.name());
        assert_eq!(
            codes["command_kind"][&python_name].as_u64(),
            Some(u64::from(kind.code())),
            "{python_name}"
        );
    }
    for mode in CommandMode::ALL {
        assert_eq!(codes["command_mode"][screaming(mode.name())].as_u64(), Some(u64::from(mode.code())));
    }
    for status in [DriverStatus::Following, DriverStatus::Holding] {
        assert_eq!(codes["driver_status"][screaming(status.name())].as_u64(), Some(u64::from(status.code())));
    }
}

/// What the Python script `script` (run on clients/python/) prints for `input` on its stdin, one JSON line each.
fn python_verdicts(script: &str, input: &str) -> Vec<Value> {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let python = repository_root().join("target/python-venv/bin/python");
    let mut child = Command::new(&python)
        .arg(repository_root().join(script))
        .arg(repository_root().join("clients/python"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python runs");
    child.stdin.take().expect("stdin").write_all(input.as_bytes()).expect("the input written");
    let out = child.wait_with_output().expect("python ends");
    assert!(out.status.success(), "{script}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect()
}

/// The Python reference drivers take a command by the Rust driver side's rule: clients/python/vservo_driver.py's
/// `refusal` and `vservo_driver::DriverSide::take_command` are handed the same commands — one valid, and one
/// broken in each way the contract names, at each edge of the age window — and refuse the same ones for the same
/// cause. The Rust side is handed each command as the rmrc sealed it: the seal is the part a driver without the
/// run's key (a third party's, started by the user) cannot check; the drivers vservod starts check it first.
#[test]
fn the_python_drivers_take_a_command_by_the_rust_driver_sides_rule() {
    use vservo_driver::{DriverSettings, DriverSide, MAX_COMMAND_AGE_TICKS, Measured};
    use vservo_protocol::{JointCommandMsg, MAX_JOINTS};

    const EPOCH: u64 = 77;
    let settings = DriverSettings {
        mode: CommandMode::Velocity,
        joint_count: 6,
        period_ns: 1_000_000,
        hold_after_ns: 20_000_000,
        position_min_rad: [-10.0; MAX_JOINTS],
        position_max_rad: [10.0; MAX_JOINTS],
        velocity_max_rad_s: [10.0; MAX_JOINTS],
        braking_gain_rad_s: [0.0; MAX_JOINTS],
    };
    let key = vservo_protocol::seal::SealKey::random().expect("a key");
    let published = |last: Option<u64>| {
        let mut side = DriverSide::new(settings.clone(), EPOCH, Some(key.clone()));
        let at_rest = Measured {
            q_rad: [0.0; MAX_JOINTS],
            qd_rad_s: [0.0; MAX_JOINTS],
            torque_nm: [f64::NAN; MAX_JOINTS],
        };
        if let Some(last) = last {
            for tick in 0..=last {
                side.joint_state(tick, tick * 1_000_000, &at_rest, None);
            }
        }
        side
    };
    let valid = JointCommandMsg {
        mode: CommandMode::Velocity.code(),
        joint_count: 6,
        answers_tick: 10,
        driver_epoch: EPOCH,
        qd_ref_rad_s: [0.1; MAX_JOINTS],
        ..JointCommandMsg::default()
    };
    let mut nan_in_a_joint = valid;
    nan_in_a_joint.qd_ref_rad_s[5] = f64::NAN;
    let mut nan_past_the_arm = valid;
    nan_past_the_arm.qd_ref_rad_s[6] = f64::NAN;
    let mut nan_in_another_mode = valid;
    nan_in_another_mode.q_ref_rad[0] = f64::NAN;
    let cases: Vec<(JointCommandMsg, Option<u64>)> = vec![
        (valid, Some(10)),
        (valid, Some(10 + MAX_COMMAND_AGE_TICKS)),
        (valid, Some(11 + MAX_COMMAND_AGE_TICKS)),
        (valid, Some(9)),
        (valid, None),
        (JointCommandMsg { schema: SCHEMA_VERSION - 1, ..valid }, Some(10)),
        (JointCommandMsg { driver_epoch: EPOCH + 1, ..valid }, Some(10)),
        (JointCommandMsg { mode: CommandMode::Position.code(), ..valid }, Some(10)),
        (JointCommandMsg { joint_count: 7, ..valid }, Some(10)),
        (nan_in_a_joint, Some(10)),
        (nan_past_the_arm, Some(10)),
        (nan_in_another_mode, Some(10)),
    ];
    let number = |v: f64| if v.is_finite() { serde_json::json!(v) } else { Value::Null };
    let input: String = cases
        .iter()
        .map(|(c, last)| {
            let line = serde_json::json!({
                "epoch": EPOCH, "mode": CommandMode::Velocity.code(), "joint_count": 6, "last_tick": last,
                "command": {
                    "schema": c.schema, "mode": c.mode, "joint_count": c.joint_count, "answers_tick": c.answers_tick,
                    "driver_epoch": c.driver_epoch,
                    "qd_ref_rad_s": c.qd_ref_rad_s.map(number), "q_ref_rad": c.q_ref_rad.map(number),
                    "torque_nm": c.torque_nm.map(number),
                },
            });
            format!("{line}\n")
        })
        .collect();
    let python_verdicts = python_verdicts("tests/python/admission.py", &input);
    assert_eq!(python_verdicts.len(), cases.len());
    let mut causes = std::collections::BTreeSet::new();
    for ((command, last), python) in cases.iter().zip(&python_verdicts) {
        let mut sealed = *command;
        key.sign(&mut sealed);
        let rust = published(*last).take_command(&sealed, 0).err().map(|refused| refused.kind());
        causes.insert(rust);
        assert_eq!(python, &serde_json::json!(rust), "answers {} with last {last:?}", command.answers_tick);
    }
    // the premise: the cases took every branch of the rule
    assert_eq!(causes.len(), 8, "{causes:?}");
}

/// A third party's driver, which has no key to check the rmrc's seal, can still keep a held cell's arm to a ramp to
/// rest: clients/python/vservo_driver.py's `HeldCell` and the Rust driver side are handed the same cell modes and
/// velocity commands — a hold that begins at speed, a ramp that first gains what a jerk-limited stop gains, a joint
/// that speeds up again or turns around, an older and an unknown mode, a resume and a second hold — and take the
/// same commands.
#[test]
fn the_python_drivers_keep_a_held_cell_to_a_ramp_to_rest_by_the_rust_rule() {
    use vservo_driver::{DriverSettings, DriverSide, Measured, speed_gained_braking};
    use vservo_protocol::seal::SealKey;
    use vservo_protocol::{CellMode, CellModeMsg, JointCommandMsg, MAX_JOINTS};

    const EPOCH: u64 = 5;
    let gain = speed_gained_braking(10.0, 5000.0);
    let settings = DriverSettings {
        mode: CommandMode::Velocity,
        joint_count: 6,
        period_ns: 1_000_000,
        hold_after_ns: 1_000_000_000,
        position_min_rad: [-10.0; MAX_JOINTS],
        position_max_rad: [10.0; MAX_JOINTS],
        velocity_max_rad_s: [10.0; MAX_JOINTS],
        braking_gain_rad_s: [gain; MAX_JOINTS],
    };
    let key = SealKey::random().expect("a key");
    let mut side = DriverSide::new(settings, EPOCH, Some(key.clone()));
    let at_rest =
        Measured { q_rad: [0.0; MAX_JOINTS], qd_rad_s: [0.0; MAX_JOINTS], torque_nm: [f64::NAN; MAX_JOINTS] };
    let speeds = |first: f64, second: f64| [first, second, 0.0, 0.0, 0.0, 0.0];
    enum Event {
        Mode(u32, u64),
        Command([f64; 6]),
    }
    use Event::{Command, Mode};
    let (servoing, safe_stop) = (CellMode::Servoing.code(), CellMode::SafeStop.code());
    let events = [
        Mode(servoing, 1),
        Command(speeds(0.3, 0.0)),
        Command(speeds(0.5, -0.2)),
        Mode(safe_stop, 2),
        Command(speeds(0.5 + 0.9 * gain, -0.2 - 0.9 * gain)),
        Command(speeds(0.5 + 1.1 * gain, -0.2)),
        Command(speeds(0.3, -0.1)),
        Command(speeds(0.3 + 1.5 * gain, -0.1)),
        Command(speeds(0.2, 0.05)),
        Command(speeds(0.0, 0.0)),
        Mode(servoing, 1),
        Command(speeds(0.3, 0.0)),
        Mode(7, 9),
        Command(speeds(0.3, 0.0)),
        Mode(servoing, 3),
        Command(speeds(0.3, 0.0)),
        Mode(safe_stop, 4),
        Command(speeds(0.3 + 0.5 * gain, 0.0)),
        Command(speeds(-0.001, 0.0)),
        Command(speeds(0.0, 0.0)),
    ];
    let mut input = format!("{}\n", serde_json::json!({ "gain": vec![gain; 6] }));
    let mut rust = Vec::new();
    let mut tick = 0;
    for event in &events {
        match event {
            Mode(mode, sequence) => {
                input += &format!("{}\n", serde_json::json!({ "mode": mode, "sequence": sequence }));
                let mut message = CellModeMsg {
                    schema: SCHEMA_VERSION,
                    mode: *mode,
                    sequence: *sequence,
                    ..CellModeMsg::default()
                };
                key.sign(&mut message);
                side.cell_mode(&message);
            }
            Command(values) => {
                input += &format!("{}\n", serde_json::json!({ "command": values }));
                side.joint_state(tick, tick * 1_000_000, &at_rest, None);
                let mut command = JointCommandMsg {
                    mode: CommandMode::Velocity.code(),
                    joint_count: 6,
                    answers_tick: tick,
                    driver_epoch: EPOCH,
                    ..JointCommandMsg::default()
                };
                command.qd_ref_rad_s[..6].copy_from_slice(values);
                key.sign(&mut command);
                rust.push(side.take_command(&command, tick * 1_000_000).err().map(|refused| refused.kind()));
                tick += 1;
            }
        }
    }
    let python_verdicts = python_verdicts("tests/python/held.py", &input);
    let refused = rust.iter().filter(|verdict| verdict.is_some()).count();
    assert_eq!(python_verdicts, rust.iter().map(|v| serde_json::json!(v)).collect::<Vec<_>>(), "{rust:?}");
    // the premise: the events took both ways, and every refusal was the held cell's
    assert!(refused >= 5 && rust.iter().flatten().all(|kind| *kind == "not towards rest"), "{rust:?}");
}
