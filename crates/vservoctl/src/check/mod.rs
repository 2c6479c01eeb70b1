//! `vservoctl check`: the preflight before a cell's first motion. It watches a running instance for a
//! moment — it only reads: nothing moves — and judges, each with the value it measured:
//! - `held`: the cell is held (at its start, or stopped safely);
//! - `joint_states`: joint states arrive, at the period the driver declares and the configuration has;
//! - `joints`: the driver's joints are the arm's in count, and in name where the driver names them (the
//!   URDF's, `[ros2] joint_names` and the ROS 2 arm's own joint states); every angle inside its limits;
//! - `kinematics`: the board the camera sees, placed by the forward kinematics of the measured joints, is
//!   where the configuration places it;
//! - `camera`: frames arrive and the target is found (all four marks);
//! - `desired_pose`: joints inside the limits reach the desired camera pose (before the board as seen), away
//!   from a singularity;
//! - `first_twist`: the law's twist on the frame now is one the rmrc takes, and over its frame the cell's own
//!   interpolator keeps every joint's speed, acceleration and jerk limit and the tool's speed cap;
//! - `clearance`: with the collision guard, every checked distance is above its stop distance where the arm is
//!   and along the first twist's frame.
//!
//! Each check prints a line, PASS or FAIL with what it measured; `--json` prints one object. Exit code 0 when
//! every check passes, 1 when one fails.

mod clearance;
mod first_twist;
mod observe;
mod ros_names;
pub mod verdicts;
mod view;

use std::time::Duration;

use clap::Args;
use serde_json::{Value, json};

use crate::UsageError;
use crate::instance::{Connection, InstanceArg};
use crate::output::print_stdout;
use verdicts::Line;

/// Arguments of `vservoctl check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    #[command(flatten)]
    instance: InstanceArg,
    /// How long to watch the cell (s).
    #[arg(long, default_value_t = 1.0, value_parser = crate::seconds_arg::seconds)]
    duration_s: f64,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

/// Some checks failed (exit code 1); each said why on its line.
#[derive(Debug, thiserror::Error)]
#[error("{failed} of {total} checks failed")]
pub struct ChecksFailed {
    failed: usize,
    total: usize,
}

/// Runs the command.
pub fn run(args: &CheckArgs) -> anyhow::Result<()> {
    let connection = Connection::open_when_there(&args.instance, || true)?;
    let config = args.instance.configuration_in_force(&connection.instance)?;
    let cell =
        vservo_cell::Cell::new(&config.cell).map_err(|e| UsageError(format!("{}: {e}", config.origin)))?;
    let window = Duration::from_secs_f64(args.duration_s.max(0.2));
    // the ROS 2 arm's own joint names, heard beside the instance's services
    let names = ros_names::listen(&config, window);
    let mut observed = observe::watch(&connection, window, config.cell.arm.joint_count())?;
    observed.ros_joint_names = names.join();
    let lines = [
        verdicts::held(&observed),
        verdicts::joint_states(&observed, &config),
        verdicts::joints(&observed, &config),
        view::kinematics(&observed, &config),
        view::camera(&observed, &config),
        view::desired_pose(&observed, &config),
        first_twist::first_twist(&observed, &cell),
        clearance::clearance(&observed, &cell),
    ];
    if args.json {
        print_stdout(&format!("{}\n", as_json(&connection.instance, &config.origin, &lines)))?;
    } else {
        print_stdout(&as_text(&connection.instance, &config.origin, &lines))?;
    }
    let failed = lines.iter().filter(|line| !line.pass).count();
    if failed > 0 {
        return Err(ChecksFailed { failed, total: lines.len() }.into());
    }
    Ok(())
}

/// One line per check, then the tally.
fn as_text(instance: &str, origin: &str, lines: &[Line]) -> String {
    let mut out = format!("vservoctl check: instance {instance:?} ({origin}); nothing moves\n");
    for line in lines {
        let verdict = match (line.pass, &line.warning) {
            (false, _) => "FAIL",
            (true, None) => "PASS",
            (true, Some(_)) => "WARN",
        };
        out += &format!("{verdict} {:<13} {}\n", line.name, line.text);
        if let Some(warning) = &line.warning {
            out += &format!("     {:<13} {warning}\n", "");
        }
    }
    let passed = lines.iter().filter(|line| line.pass).count();
    let warned = lines.iter().filter(|line| line.pass && line.warning.is_some()).count();
    let with_warnings = if warned > 0 { format!(" ({warned} with a warning)") } else { String::new() };
    out += &format!("{passed} of {} checks passed{with_warnings}\n", lines.len());
    out
}

/// `{"instance", "configuration", "passed", "checks": {name: {"pass", "text", values…}}}`.
fn as_json(instance: &str, origin: &str, lines: &[Line]) -> Value {
    let checks: serde_json::Map<String, Value> = lines
        .iter()
        .map(|line| {
            let mut entry = json!({ "pass": line.pass, "text": line.text, "warning": line.warning });
            if let (Value::Object(entry), Value::Object(values)) = (&mut entry, &line.values) {
                entry.extend(values.clone());
            }
            (line.name.to_string(), entry)
        })
        .collect();
    json!({
        "instance": instance,
        "configuration": origin,
        "passed": lines.iter().all(|line| line.pass),
        "checks": checks,
    })
}
