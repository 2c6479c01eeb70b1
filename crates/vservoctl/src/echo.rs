//! `vservoctl echo TOPIC`: prints a running instance's messages as JSON lines.

use std::time::{Duration, Instant};

use clap::Args;
use serde_json::{Value, json};
use vservo_protocol::{
    CameraTwistMsg, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointStateMsg, JointTorqueMsg, ObjectMsg,
    TelemetryMsg, TimingMsg, Topic,
};

use crate::instance::{Connection, InstanceArg};
use crate::output::print_stdout;

/// Arguments of `vservoctl echo`.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// Which service: joint_state, joint_torque, features, camera_twist, telemetry, status, gains or object (joint_state and
    /// joint_torque come at 1 kHz: a slow terminal drops samples).
    #[arg(value_parser = topic_name)]
    topic: Topic,
    #[command(flatten)]
    instance: InstanceArg,
    /// Stop after this many messages.
    #[arg(long)]
    count: Option<u64>,
    /// Stop after this long (s).
    #[arg(long)]
    duration_s: Option<f64>,
}

fn timing(t: &TimingMsg) -> Value {
    json!({"count": t.count, "p50_ns": t.p50_ns, "p99_ns": t.p99_ns, "p999_ns": t.p999_ns, "max_ns": t.max_ns})
}

/// NaN is not JSON: null.
fn numbers(values: &[f64]) -> Value {
    Value::from(values.iter().map(|v| if v.is_finite() { json!(v) } else { Value::Null }).collect::<Vec<_>>())
}

fn number(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

fn joint_state(m: &JointStateMsg) -> Value {
    json!({"schema": m.schema, "tick": m.tick, "stamp_ns": m.stamp_ns, "plant_epoch": m.plant_epoch, "faults": m.faults,
        "q_rad": numbers(&m.q_rad), "qd_rad_s": numbers(&m.qd_rad_s), "applied_torque_nm": numbers(&m.applied_torque_nm),
        "base_from_board": numbers(&m.base_from_board)})
}

fn joint_torque(m: &JointTorqueMsg) -> Value {
    json!({"schema": m.schema, "mode": m.mode, "answers_tick": m.answers_tick, "plant_epoch": m.plant_epoch,
        "state_stamp_ns": m.state_stamp_ns, "stamp_ns": m.stamp_ns, "torque_nm": numbers(&m.torque_nm),
        "q_ref_rad": numbers(&m.q_ref_rad), "qd_ref_rad_s": numbers(&m.qd_ref_rad_s)})
}

fn features(m: &FeaturesMsg) -> Value {
    json!({"schema": m.schema, "frame": m.frame, "capture_tick": m.capture_tick, "capture_stamp_ns": m.capture_stamp_ns,
        "stamp_ns": m.stamp_ns, "valid_mask": m.valid_mask, "features_px": numbers(&m.features_px),
        "mark_status": m.mark_status})
}

fn camera_twist(m: &CameraTwistMsg) -> Value {
    json!({"schema": m.schema, "verdict": m.verdict, "frame": m.frame, "capture_tick": m.capture_tick,
        "gains_version": m.gains_version, "stamp_ns": m.stamp_ns, "twist": numbers(&m.twist),
        "feature_error_px": number(m.feature_error_px), "missing_mask": m.missing_mask})
}

fn telemetry(m: &TelemetryMsg) -> Value {
    json!({"schema": m.schema, "node": m.node, "pid": m.pid, "stamp_ns": m.stamp_ns, "window_ns": m.window_ns,
        "cycles": m.cycles, "overruns": m.overruns, "skipped_periods": m.skipped_periods, "late_answers": m.late_answers,
        "rejected_messages": m.rejected_messages, "gains_version": m.gains_version, "progress": m.progress,
        "mode": m.mode, "feature_error_px": number(m.feature_error_px), "wake_latency": timing(&m.wake_latency),
        "execution": timing(&m.execution), "round_trip": timing(&m.round_trip)})
}

fn status(m: &DaemonStatusMsg) -> Value {
    let nodes: Vec<Value> = m
        .nodes
        .iter()
        .map(|n| json!({"state": n.state, "pid": n.pid, "restarts": n.restarts, "healthy": n.healthy, "last_exit": n.last_exit}))
        .collect();
    json!({"schema": m.schema, "state": m.state, "stamp_ns": m.stamp_ns, "uptime_ns": m.uptime_ns,
        "gains_version": m.gains_version, "tick_rate_hz": number(m.tick_rate_hz),
        "feature_error_px": number(m.feature_error_px), "pid": m.pid, "nodes": nodes})
}

fn gains(m: &GainsMsg) -> Value {
    json!({"schema": m.schema, "version": m.version, "used_past_gains": m.used_past_gains,
        "feature_gain": numbers(&m.feature_gain), "past_input_gains": numbers(&m.past_input_gains),
        "desired_features_px": numbers(&m.desired_features_px)})
}

fn object(m: &ObjectMsg) -> Value {
    json!({"schema": m.schema, "kind": m.kind, "sequence": m.sequence, "translation_m": numbers(&m.translation_m),
        "radius_m": number(m.radius_m), "rev_per_min": number(m.rev_per_min)})
}

fn echo<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static>(
    connection: &Connection,
    topic: Topic,
    args: &EchoArgs,
    render: fn(&T) -> Value,
) -> anyhow::Result<()> {
    let subscriber = connection.subscriber::<T>(topic)?;
    let until = args.duration_s.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    let mut printed = 0u64;
    loop {
        while let Some(sample) = subscriber.receive()? {
            print_stdout(&format!("{}\n", render(&sample)))?;
            printed += 1;
            if args.count.is_some_and(|n| printed >= n) {
                return Ok(());
            }
        }
        if until.is_some_and(|u| Instant::now() >= u) {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn topic_name(name: &str) -> Result<Topic, String> {
    Topic::ALL.into_iter().find(|t| t.name() == name).ok_or_else(|| {
        let names: Vec<&str> = Topic::ALL.iter().map(|t| t.name()).collect();
        format!("expected one of {}", names.join(", "))
    })
}

pub fn run(args: &EchoArgs) -> anyhow::Result<()> {
    let connection = Connection::open(&args.instance)?;
    let topic = args.topic;
    match topic {
        Topic::JointState => echo(&connection, topic, args, joint_state),
        Topic::JointTorque => echo(&connection, topic, args, joint_torque),
        Topic::Features => echo(&connection, topic, args, features),
        Topic::CameraTwist => echo(&connection, topic, args, camera_twist),
        Topic::Telemetry => echo(&connection, topic, args, telemetry),
        Topic::Status => echo(&connection, topic, args, status),
        Topic::Gains => echo(&connection, topic, args, gains),
        Topic::Object => echo(&connection, topic, args, object),
    }
}
