//! `vservoctl status`: the nodes, their restarts and loop timing, the feature error and gains version of
//! a running instance.

use std::time::{Duration, Instant};

use clap::Args;
use vservo_client::{StatusView, TimingUs};
use vservo_protocol::{DaemonStatusMsg, NodeRole, TakeMessages, TelemetryMsg, Topic};

use crate::instance::{Connection, InstanceArg, wait_for};
use crate::output::print_stdout;

/// Arguments of `vservoctl status`.
#[derive(Args, Debug)]
pub struct StatusArgs {
    #[command(flatten)]
    instance: InstanceArg,
    /// Print JSON.
    #[arg(long)]
    json: bool,
    /// How long to wait for the daemon (s).
    #[arg(long, default_value_t = 2.0, value_parser = crate::seconds_arg::seconds)]
    timeout_s: f64,
}

pub fn run(args: &StatusArgs) -> anyhow::Result<()> {
    let connection = Connection::open(&args.instance)?;
    let timeout = Duration::from_secs_f64(args.timeout_s);
    let no_daemon = || {
        anyhow::anyhow!(
            "no vservod of instance {:?} answered within {} s (is it running, as the same user?)",
            connection.instance,
            args.timeout_s
        )
    };
    // a client opens the daemon's services, never creates them: until the timeout, a daemon may be starting
    let started = Instant::now();
    let status = loop {
        match connection.subscriber::<DaemonStatusMsg>(Topic::Status) {
            Ok(subscriber) => break subscriber,
            Err(_) if started.elapsed() < timeout => std::thread::sleep(Duration::from_millis(20)),
            Err(_) => return Err(no_daemon()),
        }
    };
    let telemetry = connection.subscriber::<TelemetryMsg>(Topic::Telemetry).map_err(|_| no_daemon())?;
    let latest = wait_for(timeout.saturating_sub(started.elapsed()), || status.newest_message(&mut 0));
    let Some(daemon) = latest else {
        return Err(no_daemon());
    };
    // each node's latest telemetry (its history) arrives with its next publication, within one period
    let mut nodes: [Option<TelemetryMsg>; 4] = [None; 4];
    let until = Instant::now() + Duration::from_millis(250);
    while Instant::now() < until && nodes.iter().any(Option::is_none) {
        telemetry.each_message(|sample| {
            if let Some(role) = NodeRole::from_index(sample.node)
                && daemon.nodes[role as usize].pid == sample.pid
            {
                nodes[role as usize] = Some(sample);
            }
        });
        std::thread::sleep(Duration::from_millis(5));
    }
    let view = StatusView::new(&connection.instance, &daemon, &nodes);
    if args.json {
        print_stdout(&format!("{}\n", serde_json::to_string_pretty(&view)?))?;
    } else {
        print_stdout(&text(&view))?;
    }
    Ok(())
}

fn text(view: &StatusView) -> String {
    let timing = |t: Option<TimingUs>| {
        t.map_or("-".to_string(), |t| format!("{:.0}/{:.0}/{:.0}/{:.0}", t.p50, t.p99, t.p999, t.max))
    };
    let mut out = format!(
        "instance {}: {} (daemon pid {}, up {:.1} s)\n  robot driver {}, joint states {:.1}/s, feature error {} px, gains version {}, speed scale {}\n",
        view.instance,
        view.state,
        view.daemon_pid,
        view.uptime_s,
        view.robot,
        view.tick_rate_hz,
        view.feature_error_px.map_or("-".to_string(), |e| format!("{e:.3}")),
        view.gains_version,
        view.speed_scale
    );
    if let Some(fault) = &view.fault {
        let joints = if fault.joints.is_empty() {
            String::new()
        } else {
            format!(", joint {}", fault.joints.iter().map(u32::to_string).collect::<Vec<_>>().join(", "))
        };
        out.push_str(&format!(
            "  {} {}{joints}, found {:.1} s ago (at uptime {:.1} s); safe stops {}{}\n",
            if fault.active { "fault" } else { "last fault" },
            fault.name,
            fault.since_s,
            fault.at_uptime_s,
            view.safe_stops,
            if fault.active { "; `vservoctl resume` once its cause is gone" } else { "" }
        ));
    }
    if let Some(clearance) = view.clearance_text() {
        out.push_str(&format!("  {clearance}\n"));
    }
    out.push_str(
        "  node     up  restarts  pid       overruns  skipped  late   wake µs p50/p99/p99.9/max   exec µs p50/p99/p99.9/max   round trip µs\n",
    );
    for role in NodeRole::ALL {
        let Some(n) = view.nodes.get(role.name()) else { continue };
        out.push_str(&format!(
            "  {:<8} {:<3} {:>8}  {:<8} {:>9} {:>8} {:>5}   {:<27} {:<27} {}\n",
            role.name(),
            match n.state {
                "running" => "yes",
                "hung" => "HUNG",
                _ => "no",
            },
            n.restarts,
            n.pid,
            n.overruns,
            n.skipped_periods,
            n.late_answers,
            timing(n.wake_latency_us),
            timing(n.execution_us),
            timing(n.round_trip_us),
        ));
    }
    let ms = |t: Option<TimingUs>| {
        t.map_or("-".to_string(), |t| format!("{:.1}/{:.1}/{:.1}", t.p50 / 1e3, t.p99 / 1e3, t.max / 1e3))
    };
    let vision = view.nodes.get("vision").and_then(|n| n.frame_period_us);
    let servo = view.nodes.get("servo").and_then(|n| n.capture_latency_us);
    out.push_str(&format!(
        "  camera frame period ms p50/p99/max {}, capture → twist ms p50/p99/max {}\n",
        ms(vision),
        ms(servo)
    ));
    out
}
