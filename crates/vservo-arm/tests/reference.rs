//! The arm model against the Robotics Toolbox's PUMA 560 (fixtures made by
//! `scripts/gen_puma560_fixtures.py`): every quantity agrees to 1e-9.

use serde::Deserialize;
use vservo_arm::ik::ArmConfig;
use vservo_arm::{JointMatrix, JointVector, SerialArm, puma560};

const TOLERANCE: f64 = 1e-9;

#[derive(Deserialize)]
struct Fixtures {
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Rigid {
    inertia: Vec<Vec<f64>>,
    gravload: Vec<f64>,
    coriolis: Vec<Vec<f64>>,
    rne: Vec<f64>,
    accel: Vec<f64>,
}

#[derive(Deserialize)]
struct Full {
    inertia: Vec<Vec<f64>>,
    rne: Vec<f64>,
    accel_of_rne: Vec<f64>,
}

#[derive(Deserialize)]
struct Ik {
    config: String,
    q: Option<Vec<f64>>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    fkine: Vec<Vec<f64>>,
    link_frames: Vec<Vec<Vec<f64>>>,
    jacob0: Vec<Vec<f64>>,
    jacobe: Vec<Vec<f64>>,
    manipulability: f64,
    rigid: Rigid,
    full: Full,
    ik: Vec<Ik>,
}

fn fixtures() -> Fixtures {
    let text = include_str!("fixtures/puma560_rtb.json");
    serde_json::from_str(text).expect("the fixture file parses")
}

fn vector(v: &[f64]) -> JointVector {
    vservo_arm::joint_vector(v).expect("six joints")
}

/// The PUMA's six joints of a joint vector, whose seventh entry must be zero.
fn six(v: &JointVector) -> &[f64] {
    assert_eq!(v[6], 0.0, "a six-joint arm's seventh entry");
    &v.as_slice()[..6]
}

/// The PUMA's six columns of a Jacobian, whose seventh column must be zero.
fn six_columns(jacobian: &vservo_arm::Jacobian) -> nalgebra::Matrix6<f64> {
    assert!(jacobian.column(6).iter().all(|v| *v == 0.0), "a six-joint arm's seventh column");
    jacobian.fixed_columns::<6>(0).into_owned()
}

/// Agreement to 1e-9, relative to the largest element of the reference quantity where that exceeds 1.
fn assert_close_slices(what: &str, case: &str, ours: &[f64], reference: &[f64]) {
    assert_eq!(ours.len(), reference.len(), "{case}: {what} size");
    let scale = reference.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
    for (k, (a, b)) in ours.iter().zip(reference).enumerate() {
        assert!(
            (a - b).abs() <= TOLERANCE * scale,
            "{case}: {what}[{k}] = {a}, toolbox {b} (difference {:e})",
            a - b
        );
    }
}

fn rows(m: &[Vec<f64>]) -> Vec<f64> {
    m.iter().flatten().copied().collect()
}

fn matrix_rows<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> Vec<f64> {
    (0..R).flat_map(|r| (0..C).map(move |c| m[(r, c)])).collect()
}

fn each_case(check: impl Fn(&SerialArm, &SerialArm, &Case)) {
    let full = puma560::puma560();
    let rigid = puma560::puma560_rigid();
    let fixtures = fixtures();
    assert!(fixtures.cases.len() >= 10);
    for case in &fixtures.cases {
        check(&full, &rigid, case);
    }
}

#[test]
fn forward_kinematics_matches_the_toolbox() {
    each_case(|arm, _, case| {
        let q = vector(&case.q);
        let tool = arm.base_from_tool(&q).to_homogeneous();
        assert_close_slices("fkine", &case.name, &matrix_rows(&tool), &rows(&case.fkine));
        for (i, (frame, reference)) in arm.link_frames(&q).iter().zip(&case.link_frames).enumerate() {
            let what = format!("link frame {}", i + 1);
            let ours = matrix_rows(&frame.to_homogeneous());
            assert_close_slices(&what, &case.name, &ours, &rows(reference));
        }
    });
}

#[test]
fn jacobians_and_manipulability_match_the_toolbox() {
    each_case(|arm, _, case| {
        let q = vector(&case.q);
        let j0 = matrix_rows(&six_columns(&arm.jacobian_base(&q)));
        assert_close_slices("jacob0", &case.name, &j0, &rows(&case.jacob0));
        let je = matrix_rows(&six_columns(&arm.jacobian_tool(&q)));
        assert_close_slices("jacobe", &case.name, &je, &rows(&case.jacobe));
        let m = [arm.manipulability(&q)];
        assert_close_slices("manipulability", &case.name, &m, &[case.manipulability]);
    });
}

#[test]
fn rigid_body_dynamics_matches_the_toolbox() {
    each_case(|_, rigid, case| {
        let (q, qd, qdd) = (vector(&case.q), vector(&case.qd), vector(&case.qdd));
        let name = &case.name;
        let inertia = matrix_rows(&rigid.mass_matrix_rigid(&q));
        assert_close_slices("rigid inertia", name, &inertia, &rows(&case.rigid.inertia));
        let gravity = rigid.gravity_torque(&q);
        assert_close_slices("gravload", name, six(&gravity), &case.rigid.gravload);
        let coriolis = matrix_rows(&rigid.coriolis_matrix(&q, &qd));
        assert_close_slices("coriolis", name, &coriolis, &rows(&case.rigid.coriolis));
        let tau = rigid.rne_rigid(&q, &qd, &qdd);
        assert_close_slices("rigid rne", name, six(&tau), &case.rigid.rne);
        let accel = rigid.forward_dynamics_rigid(&q, &qd, &tau).expect("forward dynamics");
        assert_close_slices("rigid accel", name, six(&accel), &case.rigid.accel);
    });
}

#[test]
fn full_model_with_armature_and_friction_matches_the_toolbox() {
    each_case(|arm, _, case| {
        let (q, qd, qdd) = (vector(&case.q), vector(&case.qd), vector(&case.qdd));
        let name = &case.name;
        let inertia: JointMatrix = arm.mass_matrix(&q);
        assert_close_slices("full inertia", name, &matrix_rows(&inertia), &rows(&case.full.inertia));
        let tau = arm.rne(&q, &qd, &qdd);
        assert_close_slices("full rne", name, six(&tau), &case.full.rne);
        let accel = arm.forward_dynamics(&q, &qd, &tau).expect("forward dynamics");
        assert_close_slices("full accel", name, six(&accel), &case.full.accel_of_rne);
    });
}

fn angle_difference(a: f64, b: f64) -> f64 {
    (a - b + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

#[test]
fn inverse_kinematics_gives_the_toolbox_solutions_for_each_configuration() {
    each_case(|arm, _, case| {
        // at a wrist singularity only q4 + q6 is defined; the round-trip property test covers those
        if case.q[4].sin().abs() < 1e-6 {
            return;
        }
        let pose = arm.base_from_tool(&vector(&case.q));
        let solutions = arm.inverse_kinematics(&pose).expect("a PUMA-shaped arm");
        for reference in &case.ik {
            let config = ArmConfig::from_code(&reference.config).expect("a toolbox config code");
            let ours = solutions.get(config).q;
            match (ours, &reference.q) {
                (Some(ours), Some(theirs)) => {
                    for j in 0..6 {
                        let d = angle_difference(ours[j], theirs[j]);
                        assert!(
                            d.abs() < TOLERANCE,
                            "{}: {config} joint {}: {} vs toolbox {}",
                            case.name,
                            j + 1,
                            ours[j],
                            theirs[j]
                        );
                    }
                }
                (None, None) => {}
                (ours, theirs) => {
                    panic!("{}: {config}: ours {ours:?}, toolbox {theirs:?}", case.name)
                }
            }
        }
    });
}
