//! `[runtime]`: scheduling, memory locking and supervision of the real-time shell, in ranges that keep the
//! daemon working: telemetry well inside the 0.5 s health window, waits that std::time can hold and a user
//! would still call a restart or a stop.

use std::time::Duration;

use super::checker::Checker;
use crate::raw::{RawNodeRealtime, RawRuntime};
use crate::{ConfigError, NodeRealtime, Runtime};

/// The runtime settings and each node's scheduling.
pub fn runtime(check: &Checker, r: &RawRuntime) -> Result<Runtime, ConfigError> {
    let timer_slack_ns = check.whole(
        "runtime.timer_slack_ns",
        r.timer_slack_ns,
        1u64,
        vservo_time::NANOS_PER_SECOND,
        "must be from 1 ns to 1 s",
    )?;
    let hold_after_missed_ticks = check.whole(
        "runtime.hold_after_missed_ticks",
        r.hold_after_missed_ticks,
        1u32,
        10_000,
        "must be from 1 to 10000",
    )?;
    let telemetry_period = check.duration("runtime.telemetry_period_s", r.telemetry_period_s, 0.01, 0.2)?;
    let (restart_backoff_initial, restart_backoff_max) = restart_backoff(check, r)?;
    let stop_timeout = check.duration("runtime.stop_timeout_s", r.stop_timeout_s, 0.1, 60.0)?;
    let least_hang_s = (3.0 * telemetry_period.as_secs_f64()).max(0.3);
    let hang_timeout = check
        .within(
            "runtime.hang_timeout_s",
            r.hang_timeout_s,
            least_hang_s,
            60.0,
            "s (at least three telemetry periods)",
        )
        .map(Duration::from_secs_f64)?;
    Ok(Runtime {
        lock_memory: r.lock_memory,
        timer_slack_ns,
        telemetry_period,
        restart_backoff_initial,
        restart_backoff_max,
        hold_after_missed_ticks,
        stop_timeout,
        hang_timeout,
        plant: node(check, "plant", &r.plant)?,
        rmrc: node(check, "rmrc", &r.rmrc)?,
        servo: node(check, "servo", &r.servo)?,
        vision: node(check, "vision", &r.vision)?,
    })
}

/// The first restart's wait and the longest, in that order.
fn restart_backoff(check: &Checker, r: &RawRuntime) -> Result<(Duration, Duration), ConfigError> {
    let initial =
        check.duration("runtime.restart_backoff_initial_s", r.restart_backoff_initial_s, 0.01, 60.0)?;
    let max = check.duration("runtime.restart_backoff_max_s", r.restart_backoff_max_s, 0.01, 600.0)?;
    if max < initial {
        return Err(check.invalid(
            "runtime.restart_backoff_max_s",
            r.restart_backoff_max_s,
            "must be at least runtime.restart_backoff_initial_s",
        ));
    }
    Ok((initial, max))
}

/// `runtime.<role>`: a SCHED_FIFO priority (0 for normal scheduling) and CPU numbers.
fn node(check: &Checker, role: &str, n: &RawNodeRealtime) -> Result<NodeRealtime, ConfigError> {
    let fifo_priority = check.whole(
        &format!("runtime.{role}.fifo_priority"),
        n.fifo_priority,
        0u8,
        99,
        "must be 0 (normal scheduling) or 1–99",
    )?;
    let cpus = n
        .cpus
        .iter()
        .map(|&c| usize::try_from(c).ok().filter(|c| *c < 1024))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            check.invalid(
                &format!("runtime.{role}.cpus"),
                format!("{:?}", n.cpus),
                "CPU numbers must be 0–1023",
            )
        })?;
    Ok(NodeRealtime { fifo_priority, cpus })
}
