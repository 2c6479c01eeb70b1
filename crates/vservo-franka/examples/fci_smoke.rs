//! A smoke run of the FCI v10 client: connect, run a smooth 1 s joint-velocity bump on one joint (peak
//! 0.1 rad/s) at 1 kHz, finish, and print states, commands, errors, success rate and the client's
//! state → command latency.
//!
//! Against franka-sim (after `scripts/setup-franka-sim.sh`; see tests/sim_server/mod.rs for the model
//! symlinks that `FR3_MJCF` needs):
//!
//! ```text
//! target/franka-sim-venv/bin/python -m franka_sim.run_server --no-gripper \
//!     --enforce-motion-limits --enforce-comm-constraints &
//! cargo run --example fci_smoke -- 127.0.0.1:1337 [--joint 1] [--peak 0.1] [--duration 1] [--every 100]
//! ```
//!
//! On a real FR3 (system ≥ 5.9.0, FCI activated, brakes open, user stop in hand), give its address.

use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::Duration;

use vservo_franka::{
    Connection, JointVelocityCommand, LatencySummary, MotionPhase, RobotState, SmoothVelocityProfile,
};

const T: Duration = Duration::from_secs(1);

struct Args {
    robot: SocketAddr,
    joint: usize,
    profile: SmoothVelocityProfile,
    every: u64,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        robot: SocketAddr::from(([127, 0, 0, 1], vservo_franka::FCI_PORT)),
        joint: 0,
        profile: SmoothVelocityProfile::new(0.1, 1.0),
        every: 100,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--joint" => {
                let j: usize = value("--joint")?.parse().map_err(|e| format!("--joint: {e}"))?;
                args.joint = j.checked_sub(1).filter(|j| *j < 7).ok_or("--joint is 1..=7")?;
            }
            "--peak" => {
                args.profile.peak_rad_per_s = value("--peak")?.parse().map_err(|e| format!("--peak: {e}"))?
            }
            "--duration" => {
                args.profile.duration_s =
                    value("--duration")?.parse().map_err(|e| format!("--duration: {e}"))?
            }
            "--every" => args.every = value("--every")?.parse().map_err(|e| format!("--every: {e}"))?,
            addr => args.robot = addr.parse().map_err(|e| format!("robot address {addr:?}: {e}"))?,
        }
    }
    Ok(args)
}

fn print_state(label: &str, s: &RobotState, joint: usize) {
    println!(
        "{label} id {:>6} mode {} gen {} ctrl {} q {:+.5} q_d {:+.5} dq {:+.5} dq_d {:+.5} tau_J {:+.3} \
         rate {:.2} errors {}",
        s.message_id,
        s.robot_mode,
        s.motion_generator_mode,
        s.controller_mode,
        s.q[joint],
        s.q_d[joint],
        s.dq[joint],
        s.dq_d[joint],
        s.tau_J[joint],
        s.control_command_success_rate,
        s.errors
    );
}

fn run(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let mut conn = Connection::connect(args.robot, T)?;
    println!(
        "connected to {} (protocol version {}), states on UDP port {}",
        conn.robot_addr(),
        conn.server_version(),
        conn.udp_port()
    );
    print_state("first", conn.first_state(), args.joint);
    let (joint, profile) = (args.joint, args.profile);
    println!(
        "joint {}: sin² bump, peak {} rad/s over {} s: integral {:.5} rad, max |ddq| {:.3} rad/s², max |dddq| {:.3} rad/s³",
        joint + 1,
        profile.peak_rad_per_s,
        profile.duration_s,
        profile.displacement_rad(),
        profile.max_acceleration_rad_per_s2(),
        profile.max_jerk_rad_per_s3()
    );
    let mut state = conn.start_joint_velocity_motion(T)?;
    print_state("start", &state, joint);
    let (start_id, q0) = (state.message_id, state.q[joint]);
    let (mut latencies, mut rates, mut commanded_rad) = (Vec::new(), Vec::new(), 0.0);
    loop {
        if let MotionPhase::Aborted { errors } = MotionPhase::of(&state) {
            print_state("abort", &state, joint);
            println!("motion aborted, errors {errors}; Move: {}", conn.motion_result(T)?);
            return Err("the motion was aborted".into());
        }
        let cycle = state.message_id - start_id;
        let t_s = cycle as f64 * 1e-3;
        if t_s >= profile.duration_s {
            break;
        }
        let mut dq = [0.0; 7];
        dq[joint] = profile.velocity_at(t_s);
        latencies.push(conn.send_command(&state, &JointVelocityCommand::new(dq))?);
        commanded_rad += dq[joint] * 1e-3;
        if cycle >= 100 {
            rates.push(state.control_command_success_rate);
        }
        if args.every > 0 && cycle % args.every == 0 {
            print_state(&format!("t {t_s:.3} dq_c {:+.5} ->", dq[joint]), &state, joint);
        }
        state = conn.recv_state(T)?;
    }
    let end = conn.finish_motion(&state, [0.0; 7], T)?;
    print_state("end", &end, joint);
    let mut settled = end;
    for _ in 0..300 {
        settled = conn.recv_state(T)?;
    }
    print_state("settled", &settled, joint);
    println!(
        "moved {:+.5} rad (commanded integral {commanded_rad:+.5} rad, profile {:+.5} rad)",
        settled.q[joint] - q0,
        profile.displacement_rad()
    );
    if let Some(s) = LatencySummary::of(&mut latencies) {
        println!(
            "state -> command latency over {} cycles: p50 {:?} p99 {:?} max {:?}",
            s.count, s.p50, s.p99, s.max
        );
    }
    let min = rates.iter().copied().fold(f64::INFINITY, f64::min);
    let mean = rates.iter().sum::<f64>() / rates.len().max(1) as f64;
    println!("control_command_success_rate (from 100 ms on): min {min:.3} mean {mean:.4}");
    println!("errors {} reflex_reason {}", settled.errors, settled.reflex_reason);
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(args) => args,
        Err(e) => {
            eprintln!("fci_smoke: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fci_smoke: {e}");
            ExitCode::FAILURE
        }
    }
}
