//! The redundancy resolution on a seven-joint arm (the Franka Panda of PyBullet's pybullet_data, read from
//! its URDF where scripts/setup.sh links it, target/pybullet_data): the twist is met exactly away from
//! singularities, the null-space motion moves no part of the tool, and a joint started near its limit is
//! moved away from it while the tool reaches its goal.

use std::path::PathBuf;

use nalgebra::Vector6;
use proptest::prelude::*;
use vservo_arm::JointVector;
use vservo_arm::chain::Chain;
use vservo_arm::{JointLimits, Transform, urdf};
use vservo_sim::redundancy::{Damping, NullSpaceTask, resolve};

const DAMPING: Damping = Damping { manipulability_threshold: 0.01, max_damping: 0.05 };
/// The tick (s).
const DT: f64 = 0.001;

fn panda() -> (Chain, Vec<JointLimits>) {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/pybullet_data/franka_panda/panda.urdf");
    assert!(
        path.exists(),
        "{}: missing; scripts/setup.sh links PyBullet's pybullet_data there",
        path.display()
    );
    let arm = urdf::read(&path, None, Some("panda_link8")).expect("the Panda");
    let limits = arm
        .position_limits
        .iter()
        .zip(&arm.velocity_limits)
        .map(|(range, speed)| {
            let [low, high] = range.expect("the Panda's URDF has ranges");
            JointLimits {
                position_min: low,
                position_max: high,
                velocity_max: speed.expect("speeds"),
                torque_max: 1.0,
            }
        })
        .collect();
    (arm.chain, limits)
}

/// A pose well inside the Panda's ranges (its "ready" pose).
fn ready() -> JointVector {
    JointVector::from_column_slice(&[0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
}

/// The twist that takes `from` towards `to` at `gain` (1/s), base frame.
fn twist_towards(from: &Transform, to: &Transform, gain: f64) -> Vector6<f64> {
    let translation = to.translation.vector - from.translation.vector;
    let rotation = (to.rotation * from.rotation.inverse()).scaled_axis();
    Vector6::new(translation.x, translation.y, translation.z, rotation.x, rotation.y, rotation.z) * gain
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Away from singularities J q̇ = v, whatever the null-space task does, and the null-space part moves
    /// no part of the tool.
    #[test]
    fn the_twist_is_met_and_the_null_space_motion_does_not_move_the_tool(
        offsets in prop::array::uniform7(-0.4f64..0.4),
        twist in prop::array::uniform6(-0.3f64..0.3),
    ) {
        let (chain, limits) = panda();
        let q = ready() + JointVector::from_column_slice(&offsets);
        let frames = chain.frames(q.as_slice());
        let twist = Vector6::from_column_slice(&twist);
        let task = NullSpaceTask { posture: Some(ready()), ..NullSpaceTask::default() };
        let rates = resolve(&frames.jacobian_base(), &q, &limits, &twist, &DAMPING, &task);
        prop_assume!(!rates.damped);
        let jacobian = frames.jacobian_base();
        prop_assert!((jacobian * rates.qd - twist).amax() < 1e-9, "{}", (jacobian * rates.qd - twist).amax());
        prop_assert!((jacobian * rates.null_space).amax() < 1e-9);
    }
}

/// No twist, one joint 0.05 rad from its limit: the null-space motion turns it away from the limit, and the
/// tool stays put.
#[test]
fn a_joint_near_its_limit_is_turned_away_from_it_without_moving_the_tool() {
    let (chain, limits) = panda();
    let mut q = ready();
    q[0] = limits[0].position_max - 0.05; // panda_joint1, upper limit 2.9671
    let frames = chain.frames(q.as_slice());
    let rates =
        resolve(&frames.jacobian_base(), &q, &limits, &Vector6::zeros(), &DAMPING, &NullSpaceTask::default());
    assert!(!rates.damped);
    assert!(rates.qd[0] < -0.01, "joint 1 turns down, away from its upper limit: {}", rates.qd[0]);
    assert!((frames.jacobian_base() * rates.qd).amax() < 1e-9);
}

/// The case in the arm's own terms: a seven-joint start within 0.1 rad of a joint limit, the tool
/// steered to a goal 5 cm and 10° away at 1 kHz: it gets there, and the joint ends farther from its limit than
/// it started and never comes closer.
#[test]
fn the_tool_reaches_its_goal_while_the_null_space_moves_a_joint_away_from_its_limit() {
    let (chain, limits) = panda();
    // panda_joint1 (the base; the elbow, joint 4, has no part in the Panda's self-motion at this pose)
    let mut q = ready();
    q[0] = limits[0].position_max - 0.06;
    let start_margin = limits[0].position_max - q[0];
    assert!(start_margin < 0.1, "the premise: joint 1 starts within 0.1 rad of its limit");
    let start = chain.frames(q.as_slice()).tool;
    let goal = start
        * Transform::from_parts(
            nalgebra::Translation3::new(0.03, -0.02, 0.035),
            nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::x_axis(), 10f64.to_radians()),
        );
    let task = NullSpaceTask::default();
    let mut closest = start_margin;
    for _ in 0..4000 {
        let frames = chain.frames(q.as_slice());
        let twist = twist_towards(&frames.tool, &goal, 2.0);
        let rates = resolve(&frames.jacobian_base(), &q, &limits, &twist, &DAMPING, &task);
        q += rates.qd * DT;
        closest = closest.min(limits[0].position_max - q[0]);
    }
    let end = chain.frames(q.as_slice()).tool;
    let position_error = (end.translation.vector - goal.translation.vector).norm();
    let rotation_error = (end.rotation.inverse() * goal.rotation).angle();
    assert!(position_error < 1e-4 && rotation_error < 1e-3, "{position_error} m, {rotation_error} rad");
    let end_margin = limits[0].position_max - q[0];
    assert!(end_margin > start_margin + 0.1, "joint 1 moved away: {start_margin} → {end_margin} rad");
    assert!(closest >= start_margin - 1e-3, "joint 1 never came closer than it started: {closest}");
    for (j, limit) in limits.iter().enumerate() {
        assert!(q[j] > limit.position_min && q[j] < limit.position_max, "joint {} inside its range", j + 1);
    }
}

/// A six-joint chain has no null space: the rates are the damped least-squares solution alone.
#[test]
fn a_six_joint_chain_has_no_null_space_motion() {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/pybullet_data/xarm/xarm6_robot.urdf");
    let arm = urdf::read(&path, None, Some("link6")).expect("the xArm6");
    let limits: Vec<JointLimits> = arm
        .position_limits
        .iter()
        .map(|r| {
            let [low, high] = r.expect("ranges");
            JointLimits { position_min: low, position_max: high, velocity_max: 3.0, torque_max: 1.0 }
        })
        .collect();
    let mut q = JointVector::zeros();
    q.fixed_rows_mut::<6>(0).copy_from_slice(&[0.0, -0.443, -1.048, 0.0, 1.491, 0.0]);
    q[4] = limits[4].position_min + 0.05; // near a limit: the push away would act if there were a null space
    let frames = arm.chain.frames(q.as_slice());
    let twist = Vector6::new(0.01, 0.0, -0.02, 0.0, 0.1, 0.0);
    let rates = resolve(&frames.jacobian_base(), &q, &limits, &twist, &DAMPING, &NullSpaceTask::default());
    assert!(!rates.damped, "manipulability {}", rates.manipulability);
    assert!(rates.null_space.amax() < 1e-9, "{}", rates.null_space);
    assert_eq!(rates.qd[6], 0.0);
    assert!((frames.jacobian_base() * rates.qd - twist).amax() < 1e-9);
}
