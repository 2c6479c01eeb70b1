//! Defining identities of the arm model, checked on random states inside the PUMA 560's joint limits.

use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;
use vservo_arm::{JointMatrix, JointVector, SerialArm, puma560, six_joints};

fn arm() -> SerialArm {
    puma560::puma560()
}

fn configuration() -> impl Strategy<Value = JointVector> {
    let arm = arm();
    let limits = arm.limits();
    let ranges: Vec<_> = limits.map(|l| l.position_min..l.position_max).collect();
    ranges.prop_map(|q| JointVector::from_fn(|i, _| q.get(i).copied().unwrap_or(0.0)))
}

fn joint_vector(magnitude: f64) -> impl Strategy<Value = JointVector> {
    proptest::array::uniform6(-magnitude..magnitude).prop_map(six_joints)
}

/// A 6×6 matrix over the PUMA's joints times a joint vector (the seventh entry zero).
fn times(matrix: &JointMatrix, v: &JointVector) -> JointVector {
    let product = matrix * v.fixed_rows::<6>(0);
    JointVector::from_fn(|i, _| product.get(i).copied().unwrap_or(0.0))
}

/// The small rotation that turns `from` into `to`, as a vector: the skew part of to · fromᵀ
/// (sin θ · axis, accurate for the tiny angles of a finite difference, unlike acos of the trace).
fn rotation_rate(from: &Matrix3<f64>, to: &Matrix3<f64>) -> Vector3<f64> {
    let delta = to * from.transpose();
    Vector3::new(delta[(2, 1)] - delta[(1, 2)], delta[(0, 2)] - delta[(2, 0)], delta[(1, 0)] - delta[(0, 1)])
        * 0.5
}

/// `q` with joint `j` moved by +h and by −h, for central differences.
fn nudged(q: &JointVector, j: usize, h: f64) -> (JointVector, JointVector) {
    let (mut plus, mut minus) = (*q, *q);
    plus[j] += h;
    minus[j] -= h;
    (plus, minus)
}

fn max_abs(values: impl IntoIterator<Item = f64>) -> f64 {
    values.into_iter().fold(0.0, |m, v| m.max(v.abs()))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn jacobian_is_the_derivative_of_forward_kinematics(q in configuration()) {
        let arm = arm();
        let jacobian = arm.jacobian_base(&q);
        let h = 1e-6;
        for j in 0..6 {
            let (plus, minus) = nudged(&q, j, h);
            let (tp, tm) = (arm.base_from_tool(&plus), arm.base_from_tool(&minus));
            let linear = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
            let angular = rotation_rate(tm.rotation.matrix(), tp.rotation.matrix()) / (2.0 * h);
            for k in 0..3 {
                prop_assert!((jacobian[(k, j)] - linear[k]).abs() < 1e-7, "v[{k}] col {j}");
                prop_assert!((jacobian[(k + 3, j)] - angular[k]).abs() < 1e-7, "w[{k}] col {j}");
            }
        }
        // the tool-frame Jacobian is the same twist seen from the tool
        let tool_from_base = arm.base_from_tool(&q).rotation.matrix().transpose();
        let jt = arm.jacobian_tool(&q);
        for j in 0..6 {
            let v = tool_from_base * jacobian.fixed_view::<3, 1>(0, j);
            let w = tool_from_base * jacobian.fixed_view::<3, 1>(3, j);
            prop_assert!((jt.fixed_view::<3, 1>(0, j) - v).norm() < 1e-12);
            prop_assert!((jt.fixed_view::<3, 1>(3, j) - w).norm() < 1e-12);
        }
    }

    #[test]
    fn mass_matrix_is_symmetric_positive_definite(q in configuration()) {
        let arm = arm();
        for mass in [arm.mass_matrix(&q), arm.mass_matrix_rigid(&q)] {
            prop_assert!((mass - mass.transpose()).amax() < 1e-12);
            let eigenvalues = mass.symmetric_eigenvalues();
            prop_assert!(eigenvalues.min() > 0.0, "eigenvalues {eigenvalues}");
        }
    }

    #[test]
    fn newton_euler_equals_the_lagrangian_form(
        q in configuration(), qd in joint_vector(2.0), qdd in joint_vector(5.0)
    ) {
        let arm = arm();
        let lagrange = times(&arm.mass_matrix_rigid(&q), &qdd) + times(&arm.coriolis_matrix(&q, &qd), &qd)
            + arm.gravity_torque(&q);
        let rne = arm.rne_rigid(&q, &qd, &qdd);
        prop_assert!((rne - lagrange).amax() < 1e-9, "rne {rne} vs M qdd + C qd + g {lagrange}");
        // the drive terms add the armature to M and friction on top
        let full = times(&arm.mass_matrix(&q), &qdd) + times(&arm.coriolis_matrix(&q, &qd), &qd) + arm.gravity_torque(&q)
            + arm.drive_torque(&qd, &JointVector::zeros());
        prop_assert!((arm.rne(&q, &qd, &qdd) - full).amax() < 1e-9);
    }

    #[test]
    fn mass_matrix_rate_minus_twice_coriolis_is_skew(q in configuration(), qd in joint_vector(2.0)) {
        let arm = arm();
        let h = 1e-6;
        let mass_rate = (arm.mass_matrix(&(q + qd * h)) - arm.mass_matrix(&(q - qd * h))) / (2.0 * h);
        let n = mass_rate - arm.coriolis_matrix(&q, &qd) * 2.0;
        prop_assert!((n + n.transpose()).amax() < 1e-7, "N + Nᵀ = {}", n + n.transpose());
    }

    #[test]
    fn forward_dynamics_inverts_inverse_dynamics(
        q in configuration(), qd in joint_vector(2.0), qdd in joint_vector(5.0)
    ) {
        let arm = arm();
        let tau = arm.rne(&q, &qd, &qdd);
        let back = arm.forward_dynamics(&q, &qd, &tau).expect("positive definite mass matrix");
        prop_assert!((back - qdd).amax() < 1e-9, "{back} vs {qdd}");
        let tau_rigid = arm.rne_rigid(&q, &qd, &qdd);
        let back = arm.forward_dynamics_rigid(&q, &qd, &tau_rigid).expect("positive definite");
        prop_assert!((back - qdd).amax() < 1e-9);
    }

    #[test]
    fn inverse_kinematics_round_trips(q in configuration()) {
        let arm = arm();
        // away from the shoulder, elbow and wrist singularities the eight solutions are distinct
        prop_assume!(arm.manipulability(&q) > 5e-3);
        let pose = arm.base_from_tool(&q);
        let solutions = arm.inverse_kinematics(&pose).expect("PUMA geometry");
        let mut holds_input = false;
        for solution in solutions.iter() {
            let Some(candidate) = solution.q else { continue };
            let back = arm.base_from_tool(&candidate);
            let position_error = (back.translation.vector - pose.translation.vector).norm();
            let rotation_error = (back.rotation.matrix() - pose.rotation.matrix()).amax();
            prop_assert!(position_error < 1e-9 && rotation_error < 1e-9, "{} misses the pose", solution.config);
            let same = (0..6).all(|j| {
                let d = (candidate[j] - q[j] + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                d.abs() < 1e-7
            });
            holds_input |= same;
        }
        prop_assert!(holds_input, "no solution equals the input {q} mod 2π: {solutions:?}");
        // and the nearest solution to the input, inside the limits, is the input itself
        let nearest = solutions.nearest(&arm, &q).expect("the input is inside the limits");
        prop_assert!((nearest.q - q).amax() < 1e-7, "nearest {} vs {q}", nearest.q);
    }
}

#[test]
fn nearest_solution_to_the_nominal_pose_shifts_the_elbow_by_two_pi_into_its_range() {
    let arm = arm();
    let pose = arm.base_from_tool(&puma560::QN);
    let solutions = arm.inverse_kinematics(&pose).expect("PUMA geometry");
    let nearest = solutions.nearest(&arm, &puma560::QN).expect("inside the limits");
    assert_eq!(nearest.config.code(), "ruf");
    assert!((nearest.q - puma560::QN).amax() < 1e-9, "{}", nearest.q);
    assert!(arm.check_positions(&nearest.q).is_ok());
}

#[test]
fn unreachable_pose_has_no_solutions() {
    let arm = arm();
    let mut pose = arm.base_from_tool(&puma560::QN);
    pose.translation.vector = Vector3::new(3.0, 0.0, 0.7);
    let solutions = arm.inverse_kinematics(&pose).expect("PUMA geometry");
    assert!(solutions.iter().all(|s| s.q.is_none() && !s.within_limits));
    assert!(solutions.nearest(&arm, &puma560::QN).is_none());
}

#[test]
fn limits_flag_the_first_offending_joint_and_nan() {
    let arm = arm();
    let mut q = puma560::QN;
    q[2] = 1.0; // elbow range is [-225°, 45°]
    let violation = arm.check_positions(&q).expect_err("outside");
    assert_eq!(violation.joint, 2);
    assert!(violation.to_string().contains("joint 3 position"), "{violation}");
    q[2] = f64::NAN;
    assert!(arm.check_positions(&q).is_err());
    let tau = JointVector::from_element(500.0);
    assert!(arm.check_torques(&tau).is_err());
    let saturated = arm.saturate_torques(&tau);
    assert!(arm.check_torques(&saturated).is_ok());
    assert_eq!(saturated[1], 186.4);
}

#[test]
fn forward_dynamics_refuses_a_non_finite_state() {
    let arm = arm();
    let mut qd = JointVector::zeros();
    qd[0] = f64::NAN;
    assert!(arm.forward_dynamics(&puma560::QN, &qd, &JointVector::zeros()).is_err());
}

#[test]
fn gravity_torque_vanishes_without_gravity_and_matches_a_finite_difference_of_potential_energy() {
    let arm = arm();
    // g(q) = ∂V/∂q with V = −Σ m gᵀ c
    let potential = |q: &JointVector| {
        let frames = arm.link_frames(q);
        arm.links
            .iter()
            .zip(frames.iter())
            .map(|(link, frame)| {
                let com = frame * nalgebra::Point3::from(link.inertia.com_in_link);
                -link.inertia.mass_kg * arm.gravity_in_base.dot(&com.coords)
            })
            .sum::<f64>()
    };
    let q = six_joints([0.2, 0.7, -2.5, 0.3, 0.9, 0.1]);
    let g = arm.gravity_torque(&q);
    let h = 1e-6;
    for j in 0..6 {
        let (plus, minus) = nudged(&q, j, h);
        let dv = (potential(&plus) - potential(&minus)) / (2.0 * h);
        assert!((g[j] - dv).abs() < 1e-6, "joint {j}: {} vs {dv}", g[j]);
    }
    assert!(max_abs(g.iter().copied()) > 1.0);
}
