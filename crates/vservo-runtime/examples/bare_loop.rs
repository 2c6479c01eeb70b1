//! The floor for the plant's timing: a bare 1 ms `clock_nanosleep(TIMER_ABSTIME)` loop with the plant's
//! real-time settings, nothing else. Prints its lateness percentiles as JSON (ns) on stdout.
//!
//! `cargo run --release -p vservo-runtime --example bare_loop -- SECONDS [CONFIG]`
//! (scripts/latency.sh runs it beside vservod, on the same machine in the same run.)

use std::process::ExitCode;

use vservo_runtime::clock::PeriodicTimer;
use vservo_runtime::realtime;
use vservo_runtime::telemetry::{new_histogram, totals_json};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let Some(seconds) = args.get(1).and_then(|s| s.parse::<f64>().ok()).filter(|s| *s > 0.0) else {
        eprintln!("usage: bare_loop SECONDS [CONFIG]");
        return ExitCode::from(2);
    };
    let config_path = args.get(2).map_or("config/vservo.toml", String::as_str);
    let config = match vservo_config::Config::load(config_path) {
        Ok(config) => config,
        Err(e) => {
            eprintln!("bare_loop: {e}");
            return ExitCode::from(2);
        }
    };
    for warning in realtime::apply(&config.runtime.plant, &config.runtime) {
        eprintln!("bare_loop: {warning}");
    }
    let Some(mut lateness) = new_histogram() else {
        return ExitCode::FAILURE;
    };
    let period_ns = vservo_time::nanos(config.cell.timing.control_period_s);
    let ticks = vservo_time::nanos(seconds) / period_ns.max(1);
    let mut skipped = 0;
    let mut timer = PeriodicTimer::start(period_ns);
    for _ in 0..ticks {
        let wake = timer.wait();
        lateness.saturating_record(wake.lateness_ns.max(1));
        skipped += wake.skipped_periods;
    }
    println!("{}", totals_json(&[("wake_latency", &lateness)]));
    eprintln!("bare_loop: {ticks} ticks, {skipped} periods skipped");
    ExitCode::SUCCESS
}
