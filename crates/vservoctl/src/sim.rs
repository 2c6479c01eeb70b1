//! `vservoctl sim`: a scenario in the lockstep simulator, with the numbers and the data to judge it by.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, ValueEnum};
use serde_json::json;
use vservo_lockstep::summary::summarize;
use vservo_lockstep::{Lockstep, Trace};
use vservo_sim::plant::PlantMode;

use crate::UsageError;
use crate::config_arg::{ConfigArg, LawArg};

/// Arguments of `vservoctl sim`.
#[derive(Args)]
pub struct SimArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Simulated time (s); default: the configuration's `scenario.duration_s`.
    #[arg(long)]
    duration: Option<f64>,
    /// The control law, overriding `controller.law`.
    #[arg(long, value_enum)]
    controller: Option<LawArg>,
    /// The plant, overriding `plant.mode`.
    #[arg(long, value_enum)]
    plant: Option<PlantArg>,
    /// Where to write summary.json, features.csv, joints.csv and the plots.
    #[arg(long, value_name = "DIR", default_value = "sim-out")]
    out: PathBuf,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum PlantArg {
    Dynamic,
    Kinematic,
}

/// Runs the command.
pub fn run(args: &SimArgs) -> Result<()> {
    let mut config = args.config.load()?;
    if let Some(duration) = args.duration {
        if !(duration.is_finite() && duration > 0.0) {
            return Err(
                UsageError(format!("--duration {duration}: must be a positive number of seconds")).into()
            );
        }
        config.cell.scenario.duration_s = duration;
    }
    if let Some(controller) = args.controller {
        config.cell.controller.law = controller.law();
    }
    if let Some(plant) = args.plant {
        // the configuration's own rule: only the PUMA 560 has a dynamics model
        if plant == PlantArg::Dynamic && config.cell.arm != vservo_arm::puma560::puma560() {
            return Err(UsageError(format!(
                "--plant dynamic: {} has no dynamics model in vservo (only the PUMA 560 has one); it is simulated kinematically",
                config.origin
            ))
            .into());
        }
        config.cell.plant.mode = match plant {
            PlantArg::Dynamic => PlantMode::Dynamic,
            PlantArg::Kinematic => PlantMode::Kinematic,
        };
    }
    let mut lockstep = Lockstep::new(&config).map_err(|e| UsageError(format!("{}: {e}", config.origin)))?;
    let duration = config.cell.scenario.duration_s;
    let started = std::time::Instant::now();
    // a progress bar on a terminal only (never in a pipe or a log); indicatif redraws at most 20 times a second
    let bar = std::io::IsTerminal::is_terminal(&std::io::stderr()).then(|| {
        let bar = indicatif::ProgressBar::new((duration * 1000.0).round() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template("simulating {bar:40} {msg} ({elapsed}, {eta} left)")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    let trace = lockstep.run(|t| {
        if let Some(bar) = &bar {
            bar.set_position((t * 1000.0).round() as u64);
            bar.set_message(format!("{t:.1} of {duration:.1} s"));
        }
    });
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    if duration >= 10.0 {
        eprintln!("simulated {duration:.1} s in {:.2} s of wall time", started.elapsed().as_secs_f64());
    }
    vservo_config::new_file::folder(&args.out)?;
    let summary = summarize(&trace, &config.cell.scenario.object);
    let mut summary_json = json!({
        "config": config.origin,
        "law": config.cell.controller.law.name(),
        "plant": config.cell.plant.mode.name(),
        "duration_s": duration,
        "settling_time_s": summary.settling_time_s,
        "overshoot_percent": summary.overshoot_percent,
        "final_error_px": summary.final_error_px,
        "max_error_x_px": summary.max_error_x_px,
        "max_error_y_px": summary.max_error_y_px,
        "camera_amplitude_y_m": summary.camera_amplitude_y_m,
        "camera_amplitude_z_m": summary.camera_amplitude_z_m,
        "faults": {
            "position_limit": trace.faults.position_limit,
            "velocity_limit": trace.faults.velocity_limit,
            "torque_saturated": trace.faults.torque_saturated,
            "integration_failed": trace.faults.integration_failed,
        },
    });
    if let (Some(clearance), Some(object)) = (&trace.clearance, summary_json.as_object_mut()) {
        object
            .insert("collision".to_string(), clearance_json(clearance, config.cell.timing.control_period_s));
    }
    let out = &args.out;
    crate::output::write_in(out, "summary.json", format!("{summary_json:#}\n").as_bytes())?;
    crate::output::write_in(out, "features.csv", features_csv(&trace).as_bytes())?;
    crate::output::write_in(out, "joints.csv", joints_csv(&trace, config.cell.arm.joint_count()).as_bytes())?;
    crate::plots::draw(&trace, &config, &args.out)?;
    println!("{summary_json}");
    Ok(())
}

fn features_csv(trace: &Trace) -> String {
    let mut out = String::from("t");
    for prefix in ["", "true_"] {
        for m in 1..=4 {
            let _ = write!(out, ",{prefix}x{m},{prefix}y{m}");
        }
    }
    out.push('\n');
    for f in &trace.frames {
        let _ = write!(out, "{:.3}", f.t_s);
        for v in f.measured.iter().chain(f.truth.iter()) {
            if v.is_finite() {
                let _ = write!(out, ",{v:.4}");
            } else {
                out.push(',');
            }
        }
        out.push('\n');
    }
    out
}

/// The joints over time: a column per joint of the arm for q, q̇ and the torque.
fn joints_csv(trace: &Trace, joint_count: usize) -> String {
    let mut out = String::from("t");
    for name in ["q", "qd", "tau"] {
        for j in 1..=joint_count {
            let _ = write!(out, ",{name}{j}");
        }
    }
    out.push('\n');
    for r in &trace.joints {
        let _ = write!(out, "{:.3}", r.t_s);
        let (q, qd, torque) =
            (r.q.rows(0, joint_count), r.qd.rows(0, joint_count), r.torque.rows(0, joint_count));
        for v in q.iter().chain(qd.iter()).chain(torque.iter()) {
            let _ = write!(out, ",{v:.6}");
        }
        out.push('\n');
    }
    out
}

/// What the collision guard saw and did (summary.json's `collision`, written only where `[collision]` is given).
fn clearance_json(clearance: &vservo_lockstep::Clearance, period_s: f64) -> serde_json::Value {
    json!({
        "nearest_m": clearance.nearest.as_ref().map(|(d, _, _)| d),
        "nearest_between": clearance.nearest.as_ref().map(|(_, a, b)| [a, b]),
        "slowed_s": clearance.slowed_ticks as f64 * period_s,
        "stop": clearance.stop.as_ref().map(|stop| json!({
            "t_s": stop.t_s,
            "between": [&stop.between.0, &stop.between.1],
            "distance_m": stop.distance_m,
            "braking_m": stop.braking_m,
            "closest_after_m": stop.closest_after_m,
        })),
    })
}
