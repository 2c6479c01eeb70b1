//! The rmrc node: wakes on each joint state of the robot driver and answers with the command for the
//! driver's next period, in the interface the driver declared (torque, velocity or position).
//!
//! A joint state that is not of this build's schema, not finite, or from a driver that declares another
//! command interface or period than the configuration's is refused and counted: nothing is commanded on it.
//! After a gap of more than `robot.state_timeout_periods` between the stamps of two joint states (a stalled
//! driver), or on a new `driver_epoch` (a restarted one), the reference
//! starts again at rest from the measured joints, so nothing accumulated while the driver was away moves
//! the arm when it comes back.

use vservo_arm::JointVector;
use vservo_cell::{ActuatorCommand, RmrcStage};
use vservo_control::Twist;
use vservo_protocol::{CameraTwistMsg, JointCommandMsg, JointStateMsg, NodeRole, SCHEMA_VERSION, Topic};

use super::{CellModeFollower, IDLE_WAIT, NodeBase, go_realtime, latest, start};
use crate::clock::monotonic_ns;
use crate::telemetry::CycleSample;
use crate::wire::{command_mode_code, to_array};
use crate::{NodeContext, RuntimeError, schema_ok};

/// Whether a twist is finite and inside the configured limits: linear speed (m/s), angular speed (rad/s).
fn twist_within(twist: &Twist, (linear_m_s, angular_rad_s): (f64, f64)) -> bool {
    twist.iter().all(|v| v.is_finite())
        && twist.fixed_rows::<3>(0).norm() <= linear_m_s
        && twist.fixed_rows::<3>(3).norm() <= angular_rad_s
}

/// The stage and the driver state it follows.
struct Following {
    epoch: u64,
    last_tick: u64,
    last_stamp_ns: u64,
    /// The tick of the state it last started at rest from.
    since_tick: u64,
    stage: RmrcStage,
}

/// Runs the rmrc until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let config = context.cell.config();
    let instance = &context.instance;
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Rmrc)?;
    let state_subscriber = vservo_protocol::subscriber::<JointStateMsg>(&node, instance, Topic::JointState)?;
    let state_listener = vservo_protocol::listener(&node, instance, Topic::JointState)?;
    let twist_subscriber =
        vservo_protocol::subscriber::<CameraTwistMsg>(&node, instance, Topic::CameraTwist)?;
    let command_publisher =
        vservo_protocol::publisher::<JointCommandMsg>(&node, instance, Topic::JointCommand)?;
    // the daemon's safe stop: the reference ramps to rest and is held, whatever twist arrives
    let mut cell_mode = CellModeFollower::open(&node, instance)?;
    go_realtime(context, NodeRole::Rmrc);
    let dt = config.robot.period_s;
    let period_ns = (dt * 1e9).round() as u64;
    let mode = command_mode_code(config.command_interface());
    // the driver's stall deadline; the rmrc's own lateness (states it drained at once) is no gap
    let gap_periods = u64::from(config.robot.state_timeout_periods);
    let gap_ns = period_ns * gap_periods;
    let counters = monitor.counters();
    let limits = (config.robot.max_camera_speed_m_s, config.robot.max_camera_rotation_rad_s);
    let mut following: Option<Following> = None;
    // the twist in force: its frame's capture tick and the tick it was taken in (reported in each command)
    let mut twist_in_force = (u64::MAX, u64::MAX);
    // the daemon gone: when, and how long the ramp to rest may take before the rmrc gives up (the plant then
    // brakes the arm itself)
    let mut orphaned_at: Option<u64> = None;
    let orphan_timeout_ns = ((config.runtime.stop_timeout_s + 1.0) * 1e9) as u64;

    while !context.stopping() {
        let _ = state_listener.timed_wait(|_| {}, IDLE_WAIT);
        let woke_at = monotonic_ns();
        if context.orphaned() {
            let since = *orphaned_at.get_or_insert_with(|| {
                tracing::warn!(node = "rmrc", "the daemon is gone: ramping the arm to rest, then stopping");
                woke_at
            });
            if woke_at.saturating_sub(since) > orphan_timeout_ns {
                tracing::error!(node = "rmrc", "the daemon is gone and the arm did not come to rest in time");
                break;
            }
        }
        let latest = latest(&state_subscriber, |m: &JointStateMsg| m.schema, counters);
        let Some(state) = latest else { continue };
        let q = JointVector::from(state.q_rad);
        let qd = JointVector::from(state.qd_rad_s);
        let declared_ok =
            state.command_mode == mode && state.period_ns.abs_diff(period_ns) <= period_ns / 100;
        if !(declared_ok && q.iter().all(|v| v.is_finite()) && qd.iter().all(|v| v.is_finite())) {
            counters.rejected();
            continue;
        }
        let now_s = state.tick as f64 * dt;
        // a new driver, or the same one back after a gap: start again at rest from where the arm is
        let resync = match &following {
            Some(f) => {
                f.epoch != state.driver_epoch
                    || state.tick <= f.last_tick
                    || state.stamp_ns.saturating_sub(f.last_stamp_ns) > gap_ns
                    // a jump of more ticks than a gap allows (the catch-up below stays bounded)
                    || state.tick - f.last_tick > gap_periods
            }
            None => true,
        };
        if resync {
            // logged by the telemetry thread, off this path
            counters.resynced();
            following = Some(Following {
                epoch: state.driver_epoch,
                last_tick: state.tick,
                last_stamp_ns: state.stamp_ns,
                since_tick: state.tick,
                stage: context.cell.rmrc(&q),
            });
        }
        let Some(f) = following.as_mut() else { continue };
        // states this node woke too late to answer (it takes the newest): the reference is a function of
        // time, so it advances through those ticks too, as the lockstep simulator's does, instead of lagging
        // one tick behind the arm's clock for every state missed
        let missed = state.tick.saturating_sub(f.last_tick + 1);
        if missed > 0 {
            counters.skipped(missed);
            for tick in f.last_tick + 1..state.tick {
                f.stage.step((tick + 1) as f64 * dt, &q, &qd);
            }
        }
        f.last_tick = state.tick;
        f.last_stamp_ns = state.stamp_ns;
        let rmrc = &mut f.stage;
        while let Ok(Some(sample)) = twist_subscriber.receive() {
            let twist = Twist::from(sample.twist);
            // any verdict but servoing (on four or three marks) or reacquiring means stop, whatever the
            // numbers say
            let servoing = vservo_protocol::verdict::moves(sample.verdict);
            let twist = if servoing { twist } else { Twist::zeros() };
            if schema_ok(sample.schema) && twist_within(&twist, limits) {
                rmrc.set_twist(twist, now_s);
                twist_in_force = (sample.capture_tick, state.tick);
            } else {
                // out of range: refused, counted, and the arm is brought to rest rather than left on the
                // last good twist
                counters.rejected();
                rmrc.set_twist(Twist::zeros(), now_s);
            }
        }
        // a safe stop, or no daemon and so no servo to trust: a zero twist, which the interpolator ramps to at
        // its acceleration limits and then holds
        if orphaned_at.is_some() || cell_mode.safe_stop(context.seal_key.as_ref(), counters) {
            rmrc.set_twist(Twist::zeros(), now_s);
        }
        let command = rmrc.step(now_s + dt, &q, &qd);
        let reference = rmrc.reference();
        let torque = match command {
            ActuatorCommand::Torque(torque) => to_array(&torque),
            ActuatorCommand::Reference { .. } => [0.0; 6],
        };
        let mut message = JointCommandMsg {
            schema: SCHEMA_VERSION,
            mode,
            answers_tick: state.tick,
            driver_epoch: state.driver_epoch,
            state_stamp_ns: state.stamp_ns,
            stamp_ns: monotonic_ns(),
            torque_nm: torque,
            q_ref_rad: to_array(&reference.q),
            qd_ref_rad_s: to_array(&reference.qd),
            twist_capture_tick: twist_in_force.0,
            twist_applied_tick: twist_in_force.1,
            reference_since_tick: f.since_tick,
            seal: 0,
        };
        if let Ok(sample) = command_publisher.loan_uninit() {
            message.stamp_ns = monotonic_ns();
            // the simulated driver applies sealed commands only
            message.seal = context.seal_key.as_ref().map_or(0, |key| key.seal_joint_command(&message));
            let _ = sample.write_payload(message).send();
        }
        let done = monotonic_ns();
        let wake_latency_ns = woke_at.saturating_sub(state.stamp_ns);
        if done.saturating_sub(state.stamp_ns) > period_ns {
            counters.overrun();
        }
        counters.set_progress(state.tick);
        monitor.record(CycleSample {
            wake_latency_ns,
            execution_ns: done - woke_at,
            ..CycleSample::default()
        });
        let at_rest = message.qd_ref_rad_s.iter().all(|v| *v == 0.0)
            && state.qd_rad_s.iter().all(|v| v.abs() < crate::AT_REST_RAD_S);
        if orphaned_at.is_some() && at_rest {
            tracing::info!(
                node = "rmrc",
                tick = state.tick,
                "the arm is at rest; stopping (the daemon is gone)"
            );
            break;
        }
    }
    tracing::info!(node = "rmrc", "stopped");
    Ok(())
}
