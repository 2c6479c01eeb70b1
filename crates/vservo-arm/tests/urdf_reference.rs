//! The kinematics of arms read from their URDFs against PyBullet's (an independent implementation): the
//! xArm6 and the Franka Panda of PyBullet's `pybullet_data`, tool pose and geometric Jacobian at random joint
//! vectors (crates/vservo-arm/tests/data/pybullet_kinematics.json, written by scripts/urdf-reference.py).
//! The URDFs are read where scripts/setup.sh links pybullet_data (target/pybullet_data).

use std::path::PathBuf;

use nalgebra::{Matrix3, Vector3};
use serde_json::Value;
use vservo_arm::urdf;
use vservo_arm::{JointLimits, JointVector, SerialArm, joint_vector};

/// PyBullet reports link poses in single precision; its Jacobian is in double.
const POSITION_TOLERANCE_M: f64 = 5e-7;
const ROTATION_TOLERANCE: f64 = 2e-6;
const JACOBIAN_TOLERANCE: f64 = 1e-12;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn reference() -> Value {
    let path = root().join("crates/vservo-arm/tests/data/pybullet_kinematics.json");
    serde_json::from_str(&std::fs::read_to_string(path).expect("the reference file")).expect("JSON")
}

fn urdf_path(relative: &str) -> PathBuf {
    let path = root().join("target/pybullet_data").join(relative);
    assert!(
        path.exists(),
        "{}: missing; scripts/setup.sh links PyBullet's pybullet_data there",
        path.display()
    );
    path
}

fn numbers(value: &Value) -> Vec<f64> {
    value.as_array().expect("array").iter().map(|v| v.as_f64().expect("number")).collect()
}

fn matrix(value: &Value) -> Vec<Vec<f64>> {
    value.as_array().expect("rows").iter().map(numbers).collect()
}

#[test]
fn tool_poses_and_jacobians_match_pybullets_for_the_xarm6_and_the_panda() {
    let reference = reference();
    for name in ["xarm6", "panda"] {
        let arm_reference = &reference["arms"][name];
        let tip = arm_reference["tip_link"].as_str().expect("tip");
        let arm = urdf::read(&urdf_path(arm_reference["urdf"].as_str().expect("urdf")), None, Some(tip))
            .expect("the URDF gives an arm");
        let joints: Vec<&str> = arm.chain.joints.iter().map(|j| j.name.as_str()).collect();
        let expected: Vec<&str> =
            arm_reference["joints"].as_array().expect("joints").iter().filter_map(Value::as_str).collect();
        assert_eq!(joints, expected, "{name}");
        let mut worst = (0.0_f64, 0.0_f64, 0.0_f64);
        for sample in arm_reference["samples"].as_array().expect("samples") {
            let q = numbers(&sample["q_rad"]);
            let frames = arm.chain.frames(&q);
            let position = Vector3::from_iterator(numbers(&sample["base_from_tool_translation_m"]));
            let rotation = Matrix3::from_row_iterator(matrix(&sample["base_from_tool_rotation"]).concat());
            let jacobian = matrix(&sample["jacobian_base"]);
            let ours = frames.jacobian_base();
            worst.0 = worst.0.max((frames.tool.translation.vector - position).amax());
            worst.1 = worst.1.max((frames.tool.rotation.matrix() - rotation).amax());
            for (r, row) in jacobian.iter().enumerate() {
                for (c, value) in row.iter().enumerate() {
                    worst.2 = worst.2.max((ours[(r, c)] - value).abs());
                }
            }
        }
        assert!(worst.0 < POSITION_TOLERANCE_M, "{name}: position off by {} m", worst.0);
        assert!(worst.1 < ROTATION_TOLERANCE, "{name}: rotation off by {}", worst.1);
        assert!(worst.2 < JACOBIAN_TOLERANCE, "{name}: Jacobian off by {}", worst.2);
        eprintln!(
            "{name}: worst position {:.1e} m, rotation {:.1e}, Jacobian {:.1e}",
            worst.0, worst.1, worst.2
        );
    }
}

#[test]
fn a_urdf_arm_of_six_or_seven_joints_has_the_chains_kinematics() {
    let reference = reference();
    for (name, joint_count) in [("xarm6", 6), ("panda", 7)] {
        let arm_reference = &reference["arms"][name];
        let file = urdf_path(arm_reference["urdf"].as_str().expect("urdf"));
        let urdf_arm = urdf::read(&file, None, arm_reference["tip_link"].as_str()).expect("an arm");
        let limits =
            [JointLimits { position_min: -6.3, position_max: 6.3, velocity_max: 3.0, torque_max: 1.0 }; 7];
        let arm = SerialArm::from_chain(name, urdf_arm.chain.clone(), &limits[..joint_count])
            .expect("six or seven");
        assert_eq!(arm.joint_count(), joint_count);
        for sample in arm_reference["samples"].as_array().expect("samples") {
            let q = joint_vector(&numbers(&sample["q_rad"])).expect("at most seven");
            let frames = urdf_arm.chain.frames(q.as_slice());
            let (tool, jacobian) = arm.base_from_tool_and_jacobian(&q);
            assert_eq!(tool, frames.tool);
            assert_eq!(jacobian, frames.jacobian_base());
            assert_eq!(arm.link_frames(&q)[joint_count - 1], frames.tool);
            assert_eq!(arm.link_frames(&q)[2], frames.links[2]);
            // the closed-form IK is the PUMA's: another geometry is solved numerically
            assert!(arm.inverse_kinematics(&tool).is_err());
            let near = q + joint_vector(&vec![0.05; joint_count]).expect("seven at most");
            let reached = arm.reach(&tool, &near).expect("reachable near q");
            assert!(
                (arm.base_from_tool(&reached).translation.vector - tool.translation.vector).norm() < 1e-9
            );
        }
    }
}

/// config/arms/ur5e.urdf was written from Universal Robots' published standard-DH parameters of the UR5e: read
/// as a URDF chain, it is the same arm as that DH table read by the DH kinematics (checked against the Robotics
/// Toolbox in tests/reference.rs), tool pose and Jacobian, at joint vectors over the whole range.
#[test]
fn the_ur5e_urdf_is_the_ur5e_dh_table() {
    use std::f64::consts::FRAC_PI_2;
    use vservo_arm::DhParameters;
    let urdf = urdf::read(&root().join("config/arms/ur5e.urdf"), None, Some("flange")).expect("the UR5e");
    let limits =
        [JointLimits { position_min: -6.3, position_max: 6.3, velocity_max: 3.2, torque_max: 1.0 }; 6];
    let from_urdf = SerialArm::from_chain("UR5e (URDF)", urdf.chain, &limits).expect("six joints");
    let dh = [
        DhParameters::new(0.0, FRAC_PI_2, 0.1625, 0.0),
        DhParameters::new(-0.425, 0.0, 0.0, 0.0),
        DhParameters::new(-0.3922, 0.0, 0.0, 0.0),
        DhParameters::new(0.0, FRAC_PI_2, 0.1333, 0.0),
        DhParameters::new(0.0, -FRAC_PI_2, 0.0997, 0.0),
        DhParameters::new(0.0, 0.0, 0.0996, 0.0),
    ];
    let from_dh = SerialArm::kinematic("UR5e (DH)", dh, limits);
    let mut worst = (0.0_f64, 0.0_f64);
    for k in 0..50 {
        let q = JointVector::from_fn(
            |j, _| if j < 6 { 3.0 * ((k * 7 + j * 13) as f64 * 0.37).sin() } else { 0.0 },
        );
        let (a, ja) = from_urdf.base_from_tool_and_jacobian(&q);
        let (b, jb) = from_dh.base_from_tool_and_jacobian(&q);
        worst.0 = worst.0.max((a.to_homogeneous() - b.to_homogeneous()).amax());
        worst.1 = worst.1.max((ja - jb).amax());
    }
    assert!(worst.0 < 1e-12 && worst.1 < 1e-12, "pose {:.1e}, Jacobian {:.1e}", worst.0, worst.1);
}
