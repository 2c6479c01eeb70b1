//! A joint move through the cell's own stages (the rmrc's joint move driving the simulated dynamic PUMA 560
//! through its joint servo, as the daemon's nodes do): the arm follows the reference to the goal near its share
//! of the speed limits, never asking the drives for more than their torque (the simulated driver refuses a
//! command beyond 1.5 times it and holds the arm), and comes to rest there.

use vservo_arm::JointVector;
use vservo_cell::{Cell, DriverTick};

#[test]
fn the_dynamic_arm_follows_a_joint_move_to_its_goal_within_its_speed_limits() {
    let config = vservo_config::Config::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/vservo-apriltag.toml"
    ))
    .expect("the AprilTag cell loads");
    let cell = Cell::simulated(&config.cell).expect("the cell");
    let mut plant = cell.plant();
    let start = plant.state().q;
    let mut rmrc = cell.rmrc(&start);
    let mut goal = start;
    for (j, step) in [-0.2, 0.07, 0.04, 0.1, -0.08, 0.2].iter().enumerate() {
        goal[j] += step;
    }
    let period_ns = (config.cell.robot.period_s * 1e9).round() as u64;
    let arm = cell.arm().clone();
    let mut worst_speed_share: f64 = 0.0;
    let mut worst_torque_share: f64 = 0.0;
    let ticks = 8000;
    for tick in 0..ticks {
        let state = *plant.state();
        rmrc.follow(
            DriverTick { epoch: 1, tick, stamp_ns: tick * period_ns, holding: false },
            &state.q,
            &state.qd,
        );
        assert!(rmrc.move_joints_to(goal, 0.2, tick));
        let command = rmrc.step(tick, &state.q, &state.qd);
        if let vservo_cell::ActuatorCommand::Torque(torque) = command {
            for j in 0..6 {
                worst_torque_share = worst_torque_share.max(torque[j].abs() / arm.links[j].limits.torque_max);
            }
        }
        plant.apply(&command);
        for j in 0..6 {
            worst_speed_share =
                worst_speed_share.max(plant.state().qd[j].abs() / arm.links[j].limits.velocity_max);
        }
    }
    let error: JointVector = goal - plant.state().q;
    eprintln!(
        "worst speed share {worst_speed_share:.3}, torque {worst_torque_share:.3}, error {:.2e}",
        error.amax()
    );
    assert!(worst_speed_share < 0.25, "moved at {worst_speed_share} of a speed limit (share 0.2)");
    assert!(worst_torque_share < 1.0, "asked for {worst_torque_share} of a torque limit");
    // at rest as the daemon counts it (the joint servo holds the arm in a small limit cycle against friction)
    assert!(plant.state().qd.amax() < 0.01, "at rest: {}", plant.state().qd);
    // the joint servo's steady error under the PUMA's friction, as when servoing
    assert!(error.amax() < 1e-3, "{error}");
}

/// Issue 37: a far joint move asked at full speed on the dynamic PUMA is planned within the drives' torque (the
/// simulated driver refuses a command beyond 1.5 times a limit): no command beyond a limit, and the arm arrives.
#[test]
fn a_far_joint_move_at_full_speed_stays_within_the_drives_torque() {
    let config =
        vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
            .expect("the default cell loads");
    let cell = Cell::simulated(&config.cell).expect("the cell");
    let mut plant = cell.plant();
    let start = plant.state().q;
    let mut rmrc = cell.rmrc(&start);
    let goal = vservo_arm::six_joints([2.6, -0.6, 0.6, -1.8, -1.6, 4.5]);
    let period_ns = (config.cell.robot.period_s * 1e9).round() as u64;
    let arm = cell.arm().clone();
    let mut worst_torque_share: f64 = 0.0;
    for tick in 0..8000 {
        let state = *plant.state();
        rmrc.follow(
            DriverTick { epoch: 1, tick, stamp_ns: tick * period_ns, holding: false },
            &state.q,
            &state.qd,
        );
        assert!(rmrc.move_joints_to(goal, 1.0, tick));
        let command = rmrc.step(tick, &state.q, &state.qd);
        if let vservo_cell::ActuatorCommand::Torque(torque) = command {
            for j in 0..6 {
                worst_torque_share = worst_torque_share.max(torque[j].abs() / arm.links[j].limits.torque_max);
            }
        }
        plant.apply(&command);
    }
    let error: JointVector = goal - plant.state().q;
    eprintln!("full speed: worst torque {worst_torque_share:.3} of a limit, error {:.2e}", error.amax());
    assert!(worst_torque_share < 1.0, "asked for {worst_torque_share} of a torque limit");
    assert!(plant.state().qd.amax() < 0.01, "at rest: {}", plant.state().qd);
    assert!(error.amax() < 1e-3, "{error}");
}
