//! The rmrc node: wakes on each joint state and answers with the command for the next tick.

use vservo_arm::JointVector;
use vservo_cell::{ActuatorCommand, RmrcStage};
use vservo_control::Twist;
use vservo_protocol::{
    CameraTwistMsg, JointStateMsg, JointTorqueMsg, NodeRole, SCHEMA_VERSION, Topic, actuator_mode,
};

use super::{IDLE_WAIT, NodeBase, go_realtime, latest, start};
use crate::clock::monotonic_ns;
use crate::telemetry::CycleSample;
use crate::wire::to_array;
use crate::{NodeContext, RuntimeError, schema_ok};

/// Runs the rmrc until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let config = context.cell.config();
    let instance = &context.instance;
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Rmrc)?;
    let state_subscriber = vservo_protocol::subscriber::<JointStateMsg>(&node, instance, Topic::JointState)?;
    let state_listener = vservo_protocol::listener(&node, instance, Topic::JointState)?;
    let twist_subscriber =
        vservo_protocol::subscriber::<CameraTwistMsg>(&node, instance, Topic::CameraTwist)?;
    let torque_publisher = vservo_protocol::publisher::<JointTorqueMsg>(&node, instance, Topic::JointTorque)?;
    go_realtime(context, NodeRole::Rmrc);
    let dt = config.timing.control_period_s;
    let period_ns = (dt * 1e9).round() as u64;
    let counters = monitor.counters();
    // the stage starts at the plant's joints, at rest, on the first state of each plant epoch
    let mut stage: Option<(u64, RmrcStage)> = None;

    while !context.stopping() {
        let _ = state_listener.timed_wait(|_| {}, IDLE_WAIT);
        let woke_at = monotonic_ns();
        let latest = latest(&state_subscriber, |m: &JointStateMsg| m.schema, counters);
        let Some(state) = latest else { continue };
        let q = JointVector::from(state.q_rad);
        let qd = JointVector::from(state.qd_rad_s);
        if !(q.iter().all(|v| v.is_finite()) && qd.iter().all(|v| v.is_finite())) {
            counters.rejected();
            continue;
        }
        let now_s = state.tick as f64 * dt;
        let rmrc = match &mut stage {
            Some((epoch, rmrc)) if *epoch == state.plant_epoch => rmrc,
            _ => {
                // logged by the telemetry thread, off this path
                counters.resynced();
                &mut stage.insert((state.plant_epoch, context.cell.rmrc(&q))).1
            }
        };
        while let Ok(Some(sample)) = twist_subscriber.receive() {
            let twist = Twist::from(sample.twist);
            if schema_ok(sample.schema) && twist.iter().all(|v| v.is_finite()) {
                rmrc.set_twist(twist, now_s);
            } else {
                counters.rejected();
            }
        }
        let command = rmrc.step(now_s + dt, &q, &qd);
        let reference = rmrc.reference();
        let (mode, torque) = match command {
            ActuatorCommand::Torque(torque) => (actuator_mode::TORQUE, to_array(&torque)),
            ActuatorCommand::Kinematic { .. } => (actuator_mode::KINEMATIC, [0.0; 6]),
        };
        let mut message = JointTorqueMsg {
            schema: SCHEMA_VERSION,
            mode,
            answers_tick: state.tick,
            plant_epoch: state.plant_epoch,
            state_stamp_ns: state.stamp_ns,
            stamp_ns: monotonic_ns(),
            torque_nm: torque,
            q_ref_rad: to_array(&reference.q),
            qd_ref_rad_s: to_array(&reference.qd),
        };
        if let Ok(sample) = torque_publisher.loan_uninit() {
            message.stamp_ns = monotonic_ns();
            let _ = sample.write_payload(message).send();
        }
        let done = monotonic_ns();
        let wake_latency_ns = woke_at.saturating_sub(state.stamp_ns);
        if done.saturating_sub(state.stamp_ns) > period_ns {
            counters.overrun();
        }
        counters.set_progress(state.tick);
        monitor.record(CycleSample { wake_latency_ns, execution_ns: done - woke_at, round_trip_ns: 0 });
    }
    tracing::info!(node = "rmrc", "stopped");
    Ok(())
}
