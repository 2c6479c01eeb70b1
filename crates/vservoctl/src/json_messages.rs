//! vservo's messages as JSON objects (NaN as null), for `vservoctl echo` and the MCAP recordings of
//! `vservoctl record`.

use serde_json::{Value, json};
use vservo_protocol::{
    CameraTwistMsg, CellModeMsg, DaemonStatusMsg, FeaturesMsg, GainsMsg, JointCommandMsg, JointStateMsg,
    ObjectMsg, SimWorldMsg, TelemetryMsg, TimingMsg,
};

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

/// One message as JSON.
pub fn joint_state(m: &JointStateMsg) -> Value {
    json!({"schema": m.schema, "tick": m.tick, "stamp_ns": m.stamp_ns, "driver_epoch": m.driver_epoch,
        "period_ns": m.period_ns, "command_mode": m.command_mode, "driver_status": m.driver_status, "faults": m.faults,
        "q_rad": numbers(&m.q_rad), "qd_rad_s": numbers(&m.qd_rad_s), "torque_nm": numbers(&m.torque_nm),
        "applied_command_tick": m.applied_command_tick})
}

/// One message as JSON.
pub fn sim_world(m: &SimWorldMsg) -> Value {
    json!({"schema": m.schema, "tick": m.tick, "base_from_board": numbers(&m.base_from_board)})
}

/// One message as JSON.
pub fn joint_command(m: &JointCommandMsg) -> Value {
    json!({"schema": m.schema, "mode": m.mode, "answers_tick": m.answers_tick, "driver_epoch": m.driver_epoch,
        "state_stamp_ns": m.state_stamp_ns, "stamp_ns": m.stamp_ns, "torque_nm": numbers(&m.torque_nm),
        "q_ref_rad": numbers(&m.q_ref_rad), "qd_ref_rad_s": numbers(&m.qd_ref_rad_s),
        "twist_capture_tick": m.twist_capture_tick, "twist_applied_tick": m.twist_applied_tick,
        "reference_since_tick": m.reference_since_tick})
}

/// One message as JSON.
pub fn features(m: &FeaturesMsg) -> Value {
    json!({"schema": m.schema, "frame": m.frame, "capture_tick": m.capture_tick, "capture_stamp_ns": m.capture_stamp_ns,
        "stamp_ns": m.stamp_ns, "valid_mask": m.valid_mask, "features_px": numbers(&m.features_px),
        "mark_status": m.mark_status, "base_from_camera": numbers(&m.base_from_camera)})
}

/// One message as JSON.
pub fn camera_twist(m: &CameraTwistMsg) -> Value {
    json!({"schema": m.schema, "verdict": m.verdict, "frame": m.frame, "capture_tick": m.capture_tick,
        "gains_version": m.gains_version, "stamp_ns": m.stamp_ns, "twist": numbers(&m.twist),
        "feature_error_px": number(m.feature_error_px), "missing_mask": m.missing_mask,
        "law_flags": m.law_flags})
}

/// One message as JSON.
pub fn telemetry(m: &TelemetryMsg) -> Value {
    json!({"schema": m.schema, "node": m.node, "pid": m.pid, "stamp_ns": m.stamp_ns, "window_ns": m.window_ns,
        "cycles": m.cycles, "overruns": m.overruns, "skipped_periods": m.skipped_periods, "late_answers": m.late_answers,
        "rejected_messages": m.rejected_messages, "gains_version": m.gains_version, "progress": m.progress,
        "mode": m.mode, "feature_error_px": number(m.feature_error_px), "wake_latency": timing(&m.wake_latency),
        "execution": timing(&m.execution), "round_trip": timing(&m.round_trip),
        "frame_period": timing(&m.frame_period), "capture_latency": timing(&m.capture_latency)})
}

/// One message as JSON.
pub fn status(m: &DaemonStatusMsg) -> Value {
    let nodes: Vec<Value> = m
        .nodes
        .iter()
        .map(|n| json!({"state": n.state, "pid": n.pid, "restarts": n.restarts, "healthy": n.healthy, "last_exit": n.last_exit}))
        .collect();
    json!({"schema": m.schema, "state": m.state, "stamp_ns": m.stamp_ns, "uptime_ns": m.uptime_ns,
        "gains_version": m.gains_version, "tick_rate_hz": number(m.tick_rate_hz),
        "feature_error_px": number(m.feature_error_px), "pid": m.pid, "robot": m.robot, "nodes": nodes,
        "fault": m.fault, "fault_joints": m.fault_joints, "fault_since_ns": m.fault_since_ns, "safe_stops": m.safe_stops})
}

/// One message as JSON.
pub fn cell_mode(m: &CellModeMsg) -> Value {
    json!({"schema": m.schema, "mode": m.mode, "sequence": m.sequence, "fault": m.fault,
        "fault_joints": m.fault_joints, "stamp_ns": m.stamp_ns})
}

/// One message as JSON.
pub fn gains(m: &GainsMsg) -> Value {
    json!({"schema": m.schema, "version": m.version, "used_past_gains": m.used_past_gains,
        "feature_gain": numbers(&m.feature_gain), "past_input_gains": numbers(&m.past_input_gains),
        "desired_features_px": numbers(&m.desired_features_px), "desired_depths_m": numbers(&m.desired_depths_m),
        "q": numbers(&m.q), "r_si": numbers(&m.r_si), "interaction": m.interaction, "feedforward": m.feedforward,
        "border_margin_px": number(m.border_margin_px)})
}

/// One message as JSON.
pub fn object(m: &ObjectMsg) -> Value {
    json!({"schema": m.schema, "kind": m.kind, "sequence": m.sequence, "translation_m": numbers(&m.translation_m),
        "radius_m": number(m.radius_m), "rev_per_min": number(m.rev_per_min)})
}
