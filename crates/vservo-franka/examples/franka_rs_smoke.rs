//! `fci_smoke`'s run with the `franka-rs` crate (0.4, pure Rust, FCI v10 and v5) in place of this client: a smooth
//! joint-velocity bump on one joint, driven from this loop as vservo's driver drives the robot (each robot state
//! read, a command written back: franka-rs's `start_joint_velocity_control`, `read_once`, `write_once`), and its
//! figures printed as `fci_smoke` prints them (the success rate, the state → command latency, the errors), for
//! docs/BENCHMARKS.md's comparison on franka-sim:
//!
//! ```text
//! cargo run --release -p vservo-franka --example franka_rs_smoke -- 127.0.0.1 [--port 1337] [--joint 1] [--peak 0.02] [--duration 10]
//! ```
//!
//! franka-rs connects to its host on port 1337; `--port` is for a server on another port (franka-sim as
//! scripts/run-franka-sim.sh starts it), given to franka-rs as `HOST:PORT`.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use franka::{JointVelocities, MoveControllerMode, RealtimeConfig, Robot, motion_finished};
use vservo_franka::{LatencySummary, SmoothVelocityProfile};

struct Args {
    host: String,
    port: Option<u16>,
    joint: usize,
    profile: SmoothVelocityProfile,
}

fn parse_args() -> Result<Args, String> {
    let mut args = Args {
        host: "127.0.0.1".into(),
        port: None,
        joint: 0,
        profile: SmoothVelocityProfile::new(0.02, 10.0),
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--port" => args.port = Some(value("--port")?.parse().map_err(|e| format!("--port: {e}"))?),
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
            host => args.host = host.to_string(),
        }
    }
    Ok(args)
}

fn run(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let address = args.port.map_or_else(|| args.host.clone(), |port| format!("{}:{port}", args.host));
    let robot = Robot::new(&address, RealtimeConfig::Ignore)?;
    println!("connected to {address} with franka-rs (FCI version {:?})", robot.fci_version());
    let mut motion = robot.start_joint_velocity_control(MoveControllerMode::JointImpedance)?;
    let (joint, profile) = (args.joint, args.profile);
    let (mut t_s, mut cycle) = (0.0, 0u64);
    let (mut latencies, mut rates): (Vec<Duration>, Vec<f64>) = (Vec::new(), Vec::new());
    let mut errors;
    loop {
        let (state, period) = motion.read_once()?;
        let received = Instant::now();
        t_s += period.as_secs_f64();
        if cycle >= 100 {
            rates.push(state.control_command_success_rate);
        }
        errors = state.current_errors.names().join(", ");
        let mut dq = [0.0; 7];
        dq[joint] = profile.velocity_at(t_s.min(profile.duration_s));
        if t_s >= profile.duration_s {
            motion.write_once(&motion_finished(JointVelocities::new([0.0; 7])), None)?;
            break;
        }
        motion.write_once(&JointVelocities::new(dq), None)?;
        latencies.push(received.elapsed());
        cycle += 1;
    }
    if let Some(s) = LatencySummary::of(&mut latencies) {
        println!(
            "state -> command latency over {} cycles: p50 {:?} p99 {:?} max {:?}",
            s.count, s.p50, s.p99, s.max
        );
    }
    let min = rates.iter().copied().fold(f64::INFINITY, f64::min);
    let mean = rates.iter().sum::<f64>() / rates.len().max(1) as f64;
    println!("control_command_success_rate (from 100 ms on): min {min:.3} mean {mean:.4}");
    println!("errors [{errors}]");
    Ok(())
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(args) => args,
        Err(e) => {
            eprintln!("franka_rs_smoke: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("franka_rs_smoke: {e}");
            ExitCode::FAILURE
        }
    }
}
