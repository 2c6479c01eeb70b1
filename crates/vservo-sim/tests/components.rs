//! The plant, the interpolator and the joint servo on their own.

use nalgebra::Point3;
use vservo_arm::{JointVector, SerialArm, puma560, six_joints};
use vservo_config::Config;
use vservo_control::Twist;
use vservo_sim::interpolator::{Interpolator, InterpolatorSettings};
use vservo_sim::plant::{KinematicFollows, KinematicResponse, Plant, PlantMode};

fn frictionless() -> SerialArm {
    let mut arm = puma560::puma560();
    for link in &mut arm.links {
        link.drive = link.drive.without_friction();
    }
    arm
}

fn energy(arm: &SerialArm, q: &JointVector, qd: &JointVector) -> (f64, f64) {
    let kinetic = 0.5 * qd.dot(&arm.inertia_torque(q, qd));
    let frames = arm.link_frames(q);
    let potential: f64 = arm
        .links
        .iter()
        .zip(frames.iter())
        .map(|(link, frame)| {
            let com = frame * Point3::from(link.inertia.com_in_link);
            -link.inertia.mass_kg * arm.gravity_in_base.dot(&com.coords)
        })
        .sum();
    (kinetic, potential)
}

#[test]
fn a_free_swinging_arm_without_friction_keeps_its_energy() {
    let arm = frictionless();
    // from the stretched-out pose the arm falls and swings; no torque at all
    let q0 = six_joints([0.3, 0.0, -1.2, 0.5, 0.8, 0.0]);
    let mut plant = Plant::new(arm.clone(), PlantMode::Dynamic, 1, q0);
    let (k0, v0) = energy(&arm, &q0, &JointVector::zeros());
    let mut largest_kinetic: f64 = 0.0;
    let mut worst_drift: f64 = 0.0;
    for _ in 0..10_000 {
        let state = *plant.step_dynamic(&JointVector::zeros(), 0.001);
        let (k, v) = energy(&arm, &state.q, &state.qd);
        largest_kinetic = largest_kinetic.max(k);
        worst_drift = worst_drift.max(((k + v) - (k0 + v0)).abs());
    }
    assert!(largest_kinetic > 10.0, "the arm really swings: {largest_kinetic} J");
    let relative = worst_drift / largest_kinetic;
    println!(
        "energy drift over 10 s: {worst_drift:.2e} J, {:.4} % of the swing's {largest_kinetic:.1} J",
        100.0 * relative
    );
    assert!(relative < 1e-3, "drift {relative}");
}

#[test]
fn torques_are_saturated_and_limits_reported() {
    let mut plant = Plant::new(puma560::puma560(), PlantMode::Dynamic, 1, puma560::QN);
    let state = *plant.step_dynamic(&JointVector::from_element(1000.0), 0.001);
    assert_eq!(state.faults.torque_saturated, 0b11_1111);
    assert_eq!(state.applied_torque[1], 186.4);
    // push the elbow past its upper limit (45°) in the kinematic mode
    let mut q = puma560::QN;
    q[2] = 1.0;
    let state = *plant.step_kinematic(&q, &JointVector::zeros(), 0.001);
    assert_eq!(state.faults.position_limit, 0b100);
    assert!(state.faults.any_limit());
}

/// The kinematic plant through a first-order lag follows a held reference as the lag's closed form says:
/// a position step as q_ref(1 − e^(−t/τ)), a velocity step as q̇ = q̇_ref(1 − e^(−t/τ)) with
/// q = q̇_ref(t − τ(1 − e^(−t/τ))); without a lag a velocity reference is integrated.
#[test]
fn the_kinematic_plant_follows_through_its_lag() {
    let tau = 0.02;
    let t = 0.1;
    let ticks = 100;
    let dt = t / f64::from(ticks);
    let fade = 1.0 - (-t / tau).exp();
    let start = puma560::QN;
    let step = six_joints([0.1, -0.05, 0.02, 0.0, 0.03, -0.04]);
    let plant_with = |follows, lag_s| {
        Plant::new(puma560::puma560(), PlantMode::Kinematic, 1, start)
            .with_kinematic_response(KinematicResponse { follows, lag_s })
    };
    let mut plant = plant_with(KinematicFollows::Position, tau);
    for _ in 0..ticks {
        plant.step_kinematic(&(start + step), &JointVector::zeros(), dt);
    }
    let moved = plant.state().q - start;
    assert!((moved - step * fade).amax() < 1e-12, "{moved}");

    let mut plant = plant_with(KinematicFollows::Velocity, tau);
    for _ in 0..ticks {
        plant.step_kinematic(&start, &step, dt);
    }
    assert!((plant.state().qd - step * fade).amax() < 1e-12);
    let moved = plant.state().q - start;
    assert!((moved - step * (t - tau * fade)).amax() < 1e-12, "{moved}");

    let mut plant = plant_with(KinematicFollows::Velocity, 0.0);
    for _ in 0..ticks {
        plant.step_kinematic(&start, &step, dt);
    }
    assert!((plant.state().q - start - step * t).amax() < 1e-12);
    assert_eq!(plant.state().qd, step);
}

fn interpolator(q: JointVector) -> Interpolator {
    interpolator_with(q, InterpolatorSettings::new(0.085, 0.001))
}

fn interpolator_with(q: JointVector, settings: InterpolatorSettings) -> Interpolator {
    let config =
        Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml").expect("valid");
    Interpolator::new(settings, puma560::puma560(), config.cell.mount(), q)
}

#[test]
fn the_camera_moves_as_the_twist_says() {
    let config =
        Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml").expect("valid");
    let arm = puma560::puma560();
    let mut rmrc = interpolator(config.cell.desired.joints);
    let twist = Twist::new(0.02, -0.01, 0.03, 0.05, -0.02, 0.04);
    rmrc.set_twist(twist, 0.0);
    let camera_at = |q: &JointVector| arm.base_from_tool(q) * config.cell.tool_from_camera;
    let start = camera_at(&config.cell.desired.joints);
    // let the acceleration limit settle, then compare one tick's motion with the twist
    for tick in 1..=100 {
        rmrc.step(tick as f64 * 0.001);
    }
    let before = camera_at(&rmrc.reference().q);
    rmrc.step(0.101);
    let after = camera_at(&rmrc.reference().q);
    let velocity_in_camera =
        before.rotation.inverse() * (after.translation.vector - before.translation.vector) / 0.001;
    let expected = twist.fixed_rows::<3>(0).into_owned();
    assert!((velocity_in_camera - expected).norm() < 1e-3, "{velocity_in_camera} vs {expected}");
    assert!((start.translation.vector - before.translation.vector).norm() > 1e-3);
}

#[test]
fn a_stale_twist_ramps_the_arm_to_a_stop() {
    let mut rmrc = interpolator(puma560::QN);
    rmrc.set_twist(Twist::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
    let mut t = 0.0;
    let mut moving_at_stale = 0.0;
    for _ in 0..500 {
        t += 0.001;
        let reference = *rmrc.step(t);
        if (t - 0.171).abs() < 5e-4 {
            assert!(reference.stopping, "stale after two vision periods");
            moving_at_stale = reference.qd.amax();
        }
        if t < 0.169 {
            assert!(!reference.stopping);
        }
    }
    assert!(moving_at_stale > 0.01, "still moving when it goes stale");
    let reference = rmrc.reference();
    assert_eq!(reference.qd.amax(), 0.0, "stopped 0.2 s after going stale: {}", reference.qd);
    // and it stays put
    let q = reference.q;
    rmrc.step(t + 0.001);
    assert_eq!(rmrc.reference().q, q);
}

/// Largest joint speed and least manipulability while the camera is pushed through the wrist singularity.
fn through_the_wrist_singularity(settings: InterpolatorSettings) -> (f64, f64, bool) {
    // the wrist singularity: q5 = 0. Start just off it and push the camera so that q5 heads through 0.
    let mut q = puma560::QN;
    q[4] = 0.02;
    let mut rmrc = interpolator_with(q, settings);
    let arm = puma560::puma560();
    let mut largest: f64 = 0.0;
    let mut least_manipulability = f64::INFINITY;
    let mut damped = false;
    for frame in 0..30 {
        rmrc.set_twist(Twist::new(0.0, 0.02, 0.0, 0.2, 0.1, 0.0), frame as f64 * 0.085);
        for tick in 1..=85 {
            let reference = *rmrc.step(frame as f64 * 0.085 + tick as f64 * 0.001);
            largest = largest.max(reference.qd.amax());
            least_manipulability = least_manipulability.min(arm.manipulability(&reference.q));
            damped |= reference.damped;
        }
    }
    (largest, least_manipulability, damped)
}

#[test]
fn passing_near_a_singularity_gives_no_joint_velocity_spike() {
    let settings = InterpolatorSettings::new(0.085, 0.001);
    let (largest, least, damped) = through_the_wrist_singularity(settings);
    assert!(damped, "the path came within the damping threshold (least manipulability {least})");
    // without damping the same path asks for the joint speed limit
    let undamped = InterpolatorSettings { manipulability_threshold: 0.0, ..settings };
    let (largest_undamped, _, _) = through_the_wrist_singularity(undamped);
    println!(
        "through the wrist singularity: least manipulability {least:.2e}, largest joint speed {largest:.3} rad/s \
         damped, {largest_undamped:.3} rad/s undamped"
    );
    assert!(largest < 1.5, "joint speed {largest} rad/s near the singularity");
    assert!(largest_undamped > 2.0 * largest, "damping made no difference: {largest_undamped} vs {largest}");
}

/// A joint move (what `vservoctl calibrate` asks between its views) ends at rest on its goal, each joint
/// within its share of the speed limit and the square of that share of its acceleration limit (the move
/// scaled in time); ended half way, the reference ramps to rest as after a safe stop.
#[test]
fn a_joint_move_stops_on_its_goal_and_ends_at_rest_when_ended_half_way() {
    let settings = InterpolatorSettings::new(0.085, 0.001);
    let start = puma560::QN;
    let distance = [0.3, -0.2, 0.25, -0.8, 0.5, 1.2];
    let goal = start + six_joints(distance);
    let limits: Vec<_> = puma560::puma560().limits().collect();
    let share = 0.3;
    let mut interpolator = interpolator_with(start, settings);
    interpolator.move_joints_to(goal, share);
    let mut ticks = 0;
    let mut previous = *interpolator.reference();
    while !interpolator.joint_move_arrived() {
        ticks += 1;
        assert!(ticks < 20_000, "still moving after 20 s: {}", interpolator.reference().q);
        let reference = *interpolator.step(ticks as f64 * 0.001);
        for (j, limit) in limits.iter().enumerate() {
            assert!(reference.qd[j].abs() <= share * limit.velocity_max + 1e-12, "joint {j}");
            let change = (reference.qd[j] - previous.qd[j]).abs();
            assert!(change <= share * share * settings.acceleration_limit[j] * 0.001 + 1e-12, "joint {j}");
        }
        previous = reference;
    }
    assert!((interpolator.reference().q - goal).amax() < 1e-6);
    // the slowest joint sets the time: a trapezoid (or a triangle) of its speed and acceleration
    let seconds = ticks as f64 * 0.001;
    let slowest = (0..6)
        .map(|j| {
            let (d, v, a) = (
                f64::abs(distance[j]),
                share * limits[j].velocity_max,
                share * share * settings.acceleration_limit[j],
            );
            if d >= v * v / a { d / v + v / a } else { 2.0 * (d / a).sqrt() }
        })
        .fold(0.0, f64::max);
    assert!(seconds >= slowest - 0.01 && seconds < slowest + 0.1, "{seconds} s against {slowest} s");

    // a new move ended half way: the reference comes to rest and stays there
    interpolator.move_joints_to(start, 0.3);
    for k in 0..500 {
        interpolator.step(seconds + k as f64 * 0.001);
    }
    assert!(interpolator.reference().qd.amax() > 0.1, "moving");
    interpolator.end_joint_move();
    for k in 0..3000 {
        interpolator.step(seconds + 0.5 + k as f64 * 0.001);
    }
    let rest = interpolator.reference().q;
    assert_eq!(interpolator.reference().qd.amax(), 0.0, "at rest");
    interpolator.step(seconds + 4.0);
    assert_eq!(interpolator.reference().q, rest, "and held");
}

/// A slow joint move asked for while the reference moves fast (servoing, or a faster move before it) brakes each
/// joint at its full acceleration limit, as a safe stop does, not at the slow move's share of it; and it still
/// stops on its goal.
#[test]
fn a_slow_joint_move_begun_while_moving_brakes_at_the_full_limit_and_stops_on_its_goal() {
    let settings = InterpolatorSettings::new(0.085, 0.001);
    let start = puma560::QN;
    let limits: Vec<_> = puma560::puma560().limits().collect();
    let mut interpolator = interpolator_with(start, settings);
    // moving fast: joint 6 at 0.8 of its speed limit on a move towards a far goal
    interpolator.move_joints_to(start + six_joints([0.0, 0.0, 0.0, 0.0, 0.0, 3.0]), 0.8);
    let mut tick = 0;
    while interpolator.reference().qd[5] < 0.79 * limits[5].velocity_max {
        tick += 1;
        assert!(tick < 5000, "never up to speed");
        interpolator.step(tick as f64 * 0.001);
    }
    let speed = interpolator.reference().qd[5];
    let here = interpolator.reference().q;
    // a slow move to where the arm is now
    interpolator.move_joints_to(here, 0.05);
    let mut ticks_to_rest = 0;
    while interpolator.reference().qd[5] > 0.0 {
        ticks_to_rest += 1;
        assert!(ticks_to_rest < 20_000, "never slowed down");
        interpolator.step((tick + ticks_to_rest) as f64 * 0.001);
    }
    let full_limit_ticks = speed / (settings.acceleration_limit[5] * 0.001);
    assert!(
        f64::from(ticks_to_rest) <= full_limit_ticks.ceil() + 1.0,
        "{ticks_to_rest} ticks to slow down, {full_limit_ticks:.0} at the full limit"
    );
    let mut more = 0;
    while !interpolator.joint_move_arrived() {
        more += 1;
        assert!(more < 60_000, "never arrived: {}", interpolator.reference().q);
        interpolator.step((tick + ticks_to_rest + more) as f64 * 0.001);
    }
    assert!((interpolator.reference().q - here).amax() < 1e-6);
}
