//! Through the UR5e's wrist singularity (issue 47: MoveIt Servo scales its command down near a singularity; what
//! does vservo need?). The UR5e of config/arms/ur5e.toml, its camera given a constant twist from its own frame
//! that carries wrist 2 (joint 5) through zero, where wrist 1's and wrist 3's axes line up:
//!
//! - **a pitch**: the twist joint 5 alone gives at the start, which stays in the Jacobian's range all the way;
//! - **a pitch and a roll**: that twist with the roll joint 4 gives at the start added, which near the
//!   singularity asks wrist 1 and wrist 3 to turn against each other without bound (the "wrist flip").
//!
//! Each run steps the rmrc stage (damped least squares below the manipulability threshold, then the joints'
//! speed, acceleration and jerk limits) for 2.5 s, the arm following its reference, and prints what it measured:
//! the lowest manipulability, the ticks damped, each limit's peak share, how far the camera's twist strayed from
//! the one asked. Both runs must keep every limit; the second must show the damped inverse giving up the twist
//! rather than the joints (docs/SAFETY.md, "Singularities").

use nalgebra::{IsometryMatrix3, Vector6};
use vservo_arm::JointVector;
use vservo_cell::{Cell, DriverTick};
use vservo_config::Config;

/// How long each run lasts (s).
const RUN_S: f64 = 2.5;
/// Wrist 2 (joint 5) starts here and is asked to turn at `WRIST_RATE_RAD_S`: it crosses zero 1 s into the run.
const WRIST_START_RAD: f64 = 0.3;
const WRIST_RATE_RAD_S: f64 = -0.3;

fn ur5e() -> Config {
    let path = format!("{}/../../config/arms/ur5e.toml", env!("CARGO_MANIFEST_DIR"));
    Config::load(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The camera's pose at `q`.
fn base_from_camera(cell: &Cell, config: &Config, q: &JointVector) -> IsometryMatrix3<f64> {
    cell.arm().base_from_tool(q) * config.cell.tool_from_camera
}

/// The camera's twist in its own frame ([v; ω]) that moving from `from` to `to` in `dt_s` gives.
fn camera_twist(before: &IsometryMatrix3<f64>, after: &IsometryMatrix3<f64>, dt_s: f64) -> Vector6<f64> {
    let step = before.inverse() * after;
    let mut twist = Vector6::zeros();
    twist.fixed_rows_mut::<3>(0).copy_from(&(step.translation.vector / dt_s));
    twist.fixed_rows_mut::<3>(3).copy_from(&(step.rotation.scaled_axis() / dt_s));
    twist
}

/// What a run measured.
#[derive(Debug)]
struct Measured {
    wrist_end_rad: f64,
    lowest_manipulability: f64,
    damped_ticks: u64,
    speed_share: f64,
    acceleration_share: f64,
    jerk_share: f64,
    /// The largest |achieved − asked| / |asked| of the camera's twist, and when (s).
    strayed: (f64, f64),
    /// How long the twist strayed by more than 5 % (s).
    strayed_over_5_percent_s: f64,
}

/// 2.5 s of the rmrc stage from the UR5e's desired joints with wrist 2 at +0.3 rad, the camera given the twist
/// that `joint_rates` (rad/s per joint) give at the start, the arm at its reference.
fn run(joint_rates: &[(usize, f64)]) -> Measured {
    let config = ur5e();
    let cell = Cell::new(&config.cell).expect("the cell");
    let mut start = config.cell.desired.joints;
    start[4] = WRIST_START_RAD;
    let mut nudged = start;
    for (joint, rate) in joint_rates {
        nudged[*joint] += rate * 1e-6;
    }
    let asked = camera_twist(
        &base_from_camera(&cell, &config, &start),
        &base_from_camera(&cell, &config, &nudged),
        1e-6,
    );
    let mut rmrc = cell.rmrc(&start);
    let period_s = config.cell.robot.period_s;
    let period_ns = (period_s * 1e9).round() as u64;
    let vision_ticks = (config.cell.timing.vision_period_s / period_s).round() as u64;
    let limits: Vec<_> = cell.arm().limits().collect();
    let interpolator = &config.cell.interpolator;
    let jerk = interpolator.jerk_limit.expect("the UR5e file's jerk limits");
    let (mut q, mut qd) = (start, JointVector::zeros());
    let mut measured = Measured {
        wrist_end_rad: 0.0,
        lowest_manipulability: f64::INFINITY,
        damped_ticks: 0,
        speed_share: 0.0,
        acceleration_share: 0.0,
        jerk_share: 0.0,
        strayed: (0.0, 0.0),
        strayed_over_5_percent_s: 0.0,
    };
    let mut qdd_before = JointVector::zeros();
    for tick in 0..(RUN_S / period_s).round() as u64 {
        rmrc.follow(DriverTick { epoch: 1, tick, stamp_ns: tick * period_ns, holding: false }, &q, &qd);
        // the servo's twist, once a vision period
        if tick % vision_ticks == 0 {
            rmrc.set_twist(asked, tick);
        }
        rmrc.step(tick, &q, &qd);
        let reference = *rmrc.reference();
        let before = base_from_camera(&cell, &config, &q);
        (q, qd) = (reference.q, reference.qd);
        let achieved = camera_twist(&before, &base_from_camera(&cell, &config, &q), period_s);
        let t_s = tick as f64 * period_s;
        measured.lowest_manipulability = measured.lowest_manipulability.min(cell.arm().manipulability(&q));
        measured.damped_ticks += u64::from(reference.damped);
        for (j, limit) in limits.iter().enumerate() {
            measured.speed_share = measured.speed_share.max(qd[j].abs() / limit.velocity_max);
            measured.acceleration_share =
                measured.acceleration_share.max(reference.qdd[j].abs() / interpolator.acceleration_limit[j]);
            let jerk_now = (reference.qdd[j] - qdd_before[j]).abs() / period_s;
            measured.jerk_share = measured.jerk_share.max(jerk_now / jerk[j]);
        }
        qdd_before = reference.qdd;
        // once the reference has reached the twist (its ramp up under the jerk limits)
        if t_s >= 0.3 {
            let strayed = (achieved - asked).norm() / asked.norm();
            if strayed > measured.strayed.0 {
                measured.strayed = (strayed, t_s);
            }
            if strayed > 0.05 {
                measured.strayed_over_5_percent_s += period_s;
            }
        }
    }
    measured.wrist_end_rad = q[4];
    measured
}

fn assert_every_limit_kept(measured: &Measured) {
    let kept = 1.0 + 1e-9;
    assert!(measured.speed_share <= kept, "{measured:?}");
    assert!(measured.acceleration_share <= kept, "{measured:?}");
    assert!(measured.jerk_share <= kept, "{measured:?}");
}

#[test]
fn a_pitch_through_the_wrist_singularity_is_followed_and_keeps_every_limit() {
    let measured = run(&[(4, WRIST_RATE_RAD_S)]);
    eprintln!("UR5e, a pitch through wrist 2 = 0: {measured:?}");
    assert_every_limit_kept(&measured);
    assert!(measured.lowest_manipulability < 1e-3, "it went through the singularity: {measured:?}");
    assert!(measured.damped_ticks > 0, "{measured:?}");
    // the twist is in the Jacobian's range all the way: wrist 2 turns on through zero to about −0.4 rad
    assert!(measured.wrist_end_rad < -0.3, "{measured:?}");
}

#[test]
fn a_pitch_and_a_roll_through_the_wrist_singularity_give_up_the_twist_not_the_limits() {
    let measured = run(&[(3, 0.3), (4, WRIST_RATE_RAD_S)]);
    eprintln!("UR5e, a pitch and a roll through wrist 2 = 0: {measured:?}");
    assert_every_limit_kept(&measured);
    // near the singularity the damped inverse and the speed limits give up the twist asked
    assert!(measured.strayed.0 > 0.05, "{measured:?}");
}
