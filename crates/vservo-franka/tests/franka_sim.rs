//! The client against franka-sim 1.1.7 (a simulated FR3 speaking FCI v10), started here on a free port with
//! `--enforce-motion-limits --enforce-comm-constraints`: a smooth 1 s joint-velocity bump finishes cleanly
//! and moves the joint by its integral; a velocity step is aborted with
//! `joint_motion_generator_acceleration_discontinuity` and automatic error recovery brings the robot back to
//! idle. The server is killed when a test ends, also on failure.
//!
//! Needs the venv that `setup-franka-sim.sh` makes (fails, saying so, when it is missing). Run with
//! `--nocapture` to see the latencies and success rates.

mod sim_server;

use std::sync::Mutex;
use std::time::{Duration, Instant};

use sim_server::SimServer;
use vservo_franka::{
    JointVelocityCommand, LatencySummary, MotionOutcome, MotionPhase, MoveStatus, RobotError, RobotMode,
    SmoothVelocityProfile, StartMotionError,
};

const T: Duration = Duration::from_secs(1);
/// One server at a time: two simulations at 1 kHz on a 2-core machine would starve each other.
static SERIAL: Mutex<()> = Mutex::new(());

#[test]
fn a_smooth_joint_velocity_bump_finishes_cleanly_and_moves_the_joint_by_its_integral() {
    let _serial = SERIAL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let mut sim = SimServer::start();
    let mut conn = sim.connect();
    println!("connected to franka-sim on port {}: protocol version {}", sim.port(), conn.server_version());

    let joint = 0;
    let profile = SmoothVelocityProfile::new(0.1, 1.0);
    let mut state = conn.start_joint_velocity_motion(T).expect("the motion starts");
    let (start_id, q0, q_d0) = (state.message_id, state.q[joint], state.q_d[joint]);
    let mut latencies = Vec::with_capacity(1100);
    let (mut min_rate, mut rates, mut gaps, mut last_id) = (f64::INFINITY, Vec::new(), 0u64, start_id);
    let mut commanded_rad = 0.0;
    loop {
        assert_eq!(
            MotionPhase::of(&state),
            MotionPhase::Running,
            "state {}: {:?}",
            state.message_id,
            state.errors
        );
        let t_s = (state.message_id - start_id) as f64 * 1e-3;
        if t_s >= profile.duration_s {
            break;
        }
        if t_s >= 0.1 {
            min_rate = min_rate.min(state.control_command_success_rate);
            rates.push(state.control_command_success_rate);
        }
        let mut dq = [0.0; 7];
        dq[joint] = profile.velocity_at(t_s);
        latencies.push(conn.send_command(&state, &JointVelocityCommand::new(dq)).expect("command sent"));
        commanded_rad += dq[joint] * 1e-3;
        state = conn.recv_state(T).expect("next state");
        gaps += state.message_id - last_id - 1;
        last_id = state.message_id;
    }
    let last_rate = state.control_command_success_rate;
    // franka-sim integrates q_d from each applied dq_c (and extrapolates lost cycles); at the finish its idle
    // hold sets q_d to the measured q, so the reference's displacement is read from the last running state.
    let moved_d = state.q_d[joint] - q_d0;
    let after = conn.finish_motion(&state, [0.0; 7], T).expect("the motion finishes with kSuccess");
    assert!(!conn.motion_active());
    assert!(after.errors.is_empty() && after.reflex_reason.is_empty(), "errors {}", after.errors);
    assert_eq!(after.robot_mode, RobotMode::Idle);

    // Let the arm settle under the idle hold, then measure.
    let settle_until = Instant::now() + Duration::from_millis(300);
    let mut end = after;
    while Instant::now() < settle_until {
        end = conn.recv_state(T).expect("idle state");
    }
    assert!(end.errors.is_empty(), "errors after the motion: {}", end.errors);
    let moved = end.q[joint] - q0;
    let expected = profile.displacement_rad();
    let summary = LatencySummary::of(&mut latencies).expect("latency samples");
    let mean_rate = rates.iter().sum::<f64>() / rates.len().max(1) as f64;
    println!(
        "smooth: {} cycles answered, {gaps} states skipped; joint {} moved {moved:.5} rad, q_d {moved_d:.5} \
         rad, commanded {commanded_rad:.5} rad, profile integral {expected:.5} rad",
        summary.count,
        joint + 1
    );
    println!(
        "smooth: control_command_success_rate min {min_rate:.3} mean {mean_rate:.4} last {last_rate:.3}; \
         state->command latency p50 {:?} p99 {:?} max {:?}",
        summary.p50, summary.p99, summary.max
    );
    // The reference is franka-sim's integral of the commands applied (a skipped cycle is extrapolated): tight.
    assert!((moved_d - expected).abs() < 0.001, "q_d moved {moved_d} rad, profile integral {expected} rad");
    // The measured joint is the simulation's physics thread tracking the latest dq_c step by step, decoupled
    // from the 1 kHz state clock (franka_sim/mujoco_franka_sim.py), and the idle hold at the finish keeps
    // whatever error there is. Seen: 0.0477-0.0484 rad on an idle machine, 0.0515-0.0606 rad with two busy
    // loops on the 2 cores. So 30 % on the measured motion; the reference above is the tight check.
    assert!((moved - expected).abs() < 0.015, "joint moved {moved} rad, profile integral {expected} rad");
    assert!(min_rate.is_finite() && min_rate > 0.5, "success rate fell to {min_rate}");
}

#[test]
fn a_velocity_step_is_aborted_as_an_acceleration_discontinuity_and_recovery_returns_to_idle() {
    let _serial = SERIAL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let mut sim = SimServer::start();
    let mut conn = sim.connect();

    let joint = 0;
    let mut state = conn.start_joint_velocity_motion(T).expect("the motion starts");
    let start_id = state.message_id;
    let errors = loop {
        match MotionPhase::of(&state) {
            MotionPhase::Running => {}
            MotionPhase::Aborted { errors } => break errors,
            MotionPhase::Ended => panic!("the motion ended without errors at state {}", state.message_id),
        }
        let t_s = (state.message_id - start_id) as f64 * 1e-3;
        assert!(t_s < 2.0, "no abort 2 s into the step");
        let mut dq = [0.0; 7];
        dq[joint] = if t_s >= 0.2 { 0.1 } else { 0.0 }; // 0.1 rad/s in 1 ms: 100 rad/s² > 10
        conn.send_command(&state, &JointVelocityCommand::new(dq)).expect("command sent");
        state = conn.recv_state(T).expect("next state");
    };
    let t_abort = (state.message_id - start_id) as f64 * 1e-3;
    println!("step: aborted at t = {t_abort:.3} s, robot mode {}, errors {errors}", state.robot_mode);
    assert!(errors.contains(RobotError::JointMotionGeneratorAccelerationDiscontinuity), "errors {errors}");
    assert!(errors.names().contains(&"joint_motion_generator_acceleration_discontinuity"));
    assert_eq!(state.robot_mode, RobotMode::Reflex);

    let outcome = conn.motion_result(T).expect("the Move's final response");
    println!("step: Move outcome: {outcome}");
    match outcome {
        MotionOutcome::Aborted { status, errors, .. } => {
            assert_eq!(status, MoveStatus::ReflexAborted);
            assert!(errors.contains(RobotError::JointMotionGeneratorAccelerationDiscontinuity));
        }
        other => panic!("expected kReflexAborted, got {other}"),
    }

    match conn.start_joint_velocity_motion(T) {
        Err(StartMotionError::Rejected { status, .. }) => {
            println!("step: Move in reflex refused: {status}");
            assert_eq!(status, MoveStatus::CommandNotPossibleRejected);
        }
        other => panic!("a Move in reflex must be refused, got {other:?}"),
    }

    let t0 = Instant::now();
    conn.automatic_error_recovery(Duration::from_secs(3)).expect("automatic error recovery succeeds");
    let recovery_ms = t0.elapsed().as_secs_f64() * 1e3;
    let deadline = Instant::now() + Duration::from_secs(1);
    let idle = loop {
        let s = conn.recv_state(T).expect("state after recovery");
        if s.robot_mode == RobotMode::Idle && s.errors.is_empty() {
            break s;
        }
        assert!(Instant::now() < deadline, "not idle 1 s after recovery: {} {}", s.robot_mode, s.errors);
    };
    println!(
        "step: recovery took {recovery_ms:.1} ms; robot mode {}, errors {}, reflex_reason {}",
        idle.robot_mode, idle.errors, idle.reflex_reason
    );
}

#[test]
fn stop_move_preempts_a_running_motion_without_errors() {
    let _serial = SERIAL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let mut sim = SimServer::start();
    let mut conn = sim.connect();

    let joint = 1;
    let profile = SmoothVelocityProfile::new(0.05, 1.0);
    let mut state = conn.start_joint_velocity_motion(T).expect("the motion starts");
    let start_id = state.message_id;
    while state.message_id - start_id < 300 {
        assert_eq!(MotionPhase::of(&state), MotionPhase::Running);
        let mut dq = [0.0; 7];
        dq[joint] = profile.velocity_at((state.message_id - start_id) as f64 * 1e-3);
        conn.send_command(&state, &JointVelocityCommand::new(dq)).expect("command sent");
        state = conn.recv_state(T).expect("next state");
    }
    let outcome = conn.stop_motion(T).expect("StopMove succeeds");
    println!("stop: StopMove at t = 0.3 s, Move outcome: {outcome:?}");
    assert_eq!(outcome, Some(MotionOutcome::Preempted { status: MoveStatus::Preempted }));
    assert!(!conn.motion_active());
    let after = conn.recv_state(T).expect("state after the stop");
    assert_eq!(after.robot_mode, RobotMode::Idle);
    assert!(after.errors.is_empty(), "errors after StopMove: {}", after.errors);
}
