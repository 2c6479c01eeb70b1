//! `vservoctl model` as a user runs it: its JSON agrees with the arm library, bad input exits with 2.

use serde_json::Value;
use vservo_arm::puma560;
use vservo_system_tests::run;

fn model_json(args: &[&str]) -> Value {
    let mut all = vec!["model", "--json"];
    all.extend_from_slice(args);
    let output = run("vservoctl", &all);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("one JSON object")
}

fn numbers(value: &Value) -> Vec<f64> {
    match value {
        Value::Array(items) => items.iter().flat_map(numbers).collect(),
        Value::Number(n) => vec![n.as_f64().expect("a float")],
        other => panic!("not a number or array: {other}"),
    }
}

#[test]
fn json_holds_every_documented_key_and_agrees_with_the_library() {
    let q = "0.3,0.9,-2.6,0.4,0.7,-0.2";
    let qd = "0.5,-0.4,0.3,1,-0.8,0.6";
    let qdd = "1,2,-1.5,3,0.5,-2";
    let json = model_json(&["--q", q, "--qd", qd, "--qdd", qdd]);
    let arm = puma560::puma560();
    let vector = |t: &str| {
        let values: Vec<f64> = t.split(',').map(|v| v.parse::<f64>().expect("number")).collect();
        vservo_arm::joint_vector(&values).expect("six joints")
    };
    let (q, qd, qdd) = (vector(q), vector(qd), vector(qdd));

    let fkine = numbers(&json["fkine"]);
    assert_eq!(fkine.len(), 16);
    let expected = arm.base_from_tool(&q).to_homogeneous();
    assert!((fkine[3] - expected[(0, 3)]).abs() < 1e-12);
    assert_eq!(numbers(&json["jacob0"]).len(), 36);
    assert_eq!(numbers(&json["jacobe"]).len(), 36);
    assert!((json["manipulability"].as_f64().expect("number") - arm.manipulability(&q)).abs() < 1e-12);
    for key in ["inertia", "coriolis"] {
        assert_eq!(numbers(&json["rigid"][key]).len(), 36, "rigid.{key}");
    }
    let rne = numbers(&json["full"]["rne"]);
    let expected = arm.rne(&q, &qd, &qdd);
    assert!(rne.iter().zip(expected.iter()).all(|(a, b)| (a - b).abs() < 1e-9), "{rne:?}");
    assert_eq!(numbers(&json["rigid"]["gravload"]).len(), 6);
    assert_eq!(numbers(&json["rigid"]["rne"]).len(), 6);
    assert_eq!(numbers(&json["full"]["inertia"]).len(), 36);

    let ik = json["ik"].as_array().expect("ik is an array");
    assert_eq!(ik.len(), 8);
    let holds_input = ik.iter().any(|s| {
        s["q"].is_array() && numbers(&s["q"]).iter().zip(q.iter()).all(|(a, b)| (a - b).abs() < 1e-9)
    });
    assert!(holds_input, "one IK solution is the input configuration: {ik:?}");
    assert!(ik.iter().all(|s| s["config"].is_string()));
}

#[test]
fn velocities_and_accelerations_default_to_zero() {
    let json = model_json(&["--q", "qn"]);
    let gravload = numbers(&json["rigid"]["gravload"]);
    let rne = numbers(&json["full"]["rne"]);
    assert!(gravload.iter().zip(&rne).all(|(a, b)| (a - b).abs() < 1e-12));
    assert!(numbers(&json["rigid"]["coriolis"]).iter().all(|c| *c == 0.0));
}

#[test]
fn bad_input_exits_with_2_and_says_what_is_wrong() {
    let cases: [(&[&str], &str); 5] = [
        (&["model", "--q", "1,2,3"], "expected 6"),
        (&["model", "--q", "0,0.7,-3,0,zero,0"], "not a number"),
        (&["model", "--q", "0,0,1,0,0,0"], "joint 3 position"),
        (&["model", "--q", "qn", "--qd", "0,0,0,0,0,9"], "joint 6 velocity"),
        (&["model"], "--q"),
    ];
    for (args, message) in cases {
        let output = run("vservoctl", args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr:?} should mention {message:?}");
        assert!(output.stdout.is_empty(), "{args:?} printed a result");
    }
}

/// An arm from a URDF (the xArm6 of PyBullet's pybullet_data, config/arms/xarm6.toml): its joints and limits
/// from the file, and the tool where PyBullet puts it (crates/vservo-arm/tests/data/pybullet_kinematics.json).
#[test]
fn a_urdf_arm_is_described_from_its_configuration() {
    let root = vservo_system_tests::repository_root();
    let reference = pybullet_reference();
    let sample = &reference["arms"]["xarm6"]["samples"][0];
    let q: Vec<String> = numbers(&sample["q_rad"]).iter().map(|v| format!("{v}")).collect();
    let config = root.join("config/arms/xarm6.toml");
    let json = model_json(&["--config", config.to_str().expect("utf-8"), "--q", &q.join(",")]);

    let names: Vec<&str> =
        json["joints"].as_array().expect("joints").iter().filter_map(|j| j["name"].as_str()).collect();
    assert_eq!(names, ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]);
    assert_eq!(numbers(&json["joints"][2]["range_rad"]), [-3.927, 0.19198]);
    // the file says 3.14 rad/s
    assert_eq!(json["joints"][0]["velocity_max_rad_s"].as_f64(), "3.14".parse().ok());
    let fkine = numbers(&json["fkine"]);
    let position = numbers(&sample["base_from_tool_translation_m"]);
    for (axis, expected) in position.iter().enumerate() {
        assert!((fkine[4 * axis + 3] - expected).abs() < 1e-6, "tool position {axis}: {fkine:?}");
    }
    // the links, the last of them the tool; no dynamics and no closed-form IK for this arm
    assert_eq!(json["links"].as_array().expect("links").len(), 6);
    assert_eq!(numbers(&json["links"][5]), fkine);
    assert!(json["rigid"].is_null() && json["full"].is_null() && json["ik"].is_null());
    // the PUMA's named poses are the PUMA's
    let output = run("vservoctl", &["model", "--config", config.to_str().expect("utf-8"), "--q", "qn"]);
    assert_eq!(output.status.code(), Some(2));
}

/// The seven-joint Panda (config/arms/panda.toml): seven joints named from its URDF, seven links (the last the
/// tool), a Jacobian of seven columns, and the tool where PyBullet puts it.
#[test]
fn a_seven_joint_urdf_arm_is_described_with_its_seven_joints() {
    let root = vservo_system_tests::repository_root();
    let reference = pybullet_reference();
    let panda = &reference["arms"]["panda"];
    let sample = &panda["samples"][0];
    let q: Vec<String> = numbers(&sample["q_rad"]).iter().map(|v| format!("{v}")).collect();
    assert_eq!(q.len(), 7);
    // the reference's tool is the configuration's: the flange
    assert_eq!(panda["tip_link"], "panda_link8");
    let config = root.join("config/arms/panda.toml");
    let json = model_json(&["--config", config.to_str().expect("utf-8"), "--q", &q.join(",")]);
    let names: Vec<&str> =
        json["joints"].as_array().expect("joints").iter().filter_map(|j| j["name"].as_str()).collect();
    assert_eq!(names, (1..=7).map(|j| format!("panda_joint{j}")).collect::<Vec<_>>());
    assert_eq!(numbers(&json["q"]).len(), 7);
    assert_eq!(json["links"].as_array().expect("links").len(), 7);
    assert_eq!(numbers(&json["links"][6]), numbers(&json["fkine"]));
    let jacobian = json["jacob0"].as_array().expect("rows");
    assert_eq!(jacobian.len(), 6);
    assert!(jacobian.iter().all(|row| numbers(row).len() == 7), "{jacobian:?}");
    let fkine = numbers(&json["fkine"]);
    let position = numbers(&sample["base_from_tool_translation_m"]);
    for (axis, expected) in position.iter().enumerate() {
        assert!((fkine[4 * axis + 3] - expected).abs() < 1e-6, "tool position {axis}: {fkine:?}");
    }
    // six angles are not a seven-joint arm's
    let output =
        run("vservoctl", &["model", "--config", config.to_str().expect("utf-8"), "--q", "0,0,0,0,0,0"]);
    assert_eq!(output.status.code(), Some(2));
}

/// crates/vservo-arm/tests/data/pybullet_kinematics.json: PyBullet's kinematics of pybullet_data's arms.
fn pybullet_reference() -> Value {
    let path =
        vservo_system_tests::repository_root().join("crates/vservo-arm/tests/data/pybullet_kinematics.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("the PyBullet reference")).expect("JSON")
}
