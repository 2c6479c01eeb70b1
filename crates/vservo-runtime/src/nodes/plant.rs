//! The plant node, the simulated robot driver: the 1 ms tick on absolute deadlines. Each tick: sleep until
//! the deadline, take the rmrc's answer to the last state (or hold the previous command, counted late),
//! advance one tick, publish the new state (and, on the simulation-only `sim_world`, where the board is)
//! and wake the rmrc. It follows the robot driver contract of docs/DRIVERS.md like any external driver.

use vservo_arm::JointVector;
use vservo_cell::{ActuatorCommand, PlantStage};
use vservo_protocol::{
    JointCommandMsg, JointStateMsg, NodeRole, ObjectMsg, SCHEMA_VERSION, SimWorldMsg, Topic, command_kind,
    command_mode, driver_status, fault_bits,
};
use vservo_sim::plant::JointState;
use vservo_sim::world::ObjectMotion;

use super::{NodeBase, go_realtime, latest, start};
use crate::clock::{PeriodicTimer, monotonic_ns};
use crate::telemetry::CycleSample;
use crate::wire::{pose_to_wire, to_array};
use crate::{NodeContext, RuntimeError, schema_ok};

/// The simulated driver's identity in each joint state: its epoch, period and command interface.
#[derive(Debug, Clone, Copy)]
struct Declared {
    epoch: u64,
    period_ns: u64,
    command_mode: u32,
}

fn state_message(
    stage: &PlantStage,
    state: &JointState,
    declared: &Declared,
    applied_command_tick: u64,
) -> JointStateMsg {
    let f = &state.faults;
    let mut faults = u32::from(f.position_limit) << fault_bits::POSITION_LIMIT_SHIFT
        | u32::from(f.velocity_limit) << fault_bits::VELOCITY_LIMIT_SHIFT
        | u32::from(f.torque_saturated) << fault_bits::TORQUE_SATURATED_SHIFT;
    if f.integration_failed {
        faults |= fault_bits::DRIVER_FAILED;
    }
    let status = if f.integration_failed {
        driver_status::FAULT
    } else if stage.is_holding() {
        driver_status::HOLDING
    } else {
        driver_status::FOLLOWING
    };
    JointStateMsg {
        schema: SCHEMA_VERSION,
        faults,
        tick: state.tick,
        stamp_ns: monotonic_ns(),
        driver_epoch: declared.epoch,
        period_ns: declared.period_ns,
        command_mode: declared.command_mode,
        driver_status: status,
        q_rad: to_array(&state.q),
        qd_rad_s: to_array(&state.qd),
        torque_nm: to_array(&state.applied_torque),
        applied_command_tick,
    }
}

/// A commanded torque beyond this many times a joint's torque limit is refused (the plant then holds the
/// arm); up to it, the drives saturate at the limit, as real ones do.
const TORQUE_REFUSED_ABOVE_LIMITS: f64 = 1.5;

/// The command a joint command carries, if it is in the interface this driver declared, finite and, for
/// torques, within [`TORQUE_REFUSED_ABOVE_LIMITS`] of the limits.
fn command_of(message: &JointCommandMsg, declared: u32, torque_max_nm: &[f64; 6]) -> Option<ActuatorCommand> {
    let all_finite = |v: &[f64; 6]| v.iter().all(|x| x.is_finite());
    let torque_in_range = message
        .torque_nm
        .iter()
        .zip(torque_max_nm)
        .all(|(t, max)| t.abs() <= TORQUE_REFUSED_ABOVE_LIMITS * max);
    match message.mode {
        _ if message.mode != declared => None,
        command_mode::TORQUE if all_finite(&message.torque_nm) && torque_in_range => {
            Some(ActuatorCommand::Torque(JointVector::from(message.torque_nm)))
        }
        command_mode::POSITION if all_finite(&message.q_ref_rad) && all_finite(&message.qd_ref_rad_s) => {
            Some(ActuatorCommand::Reference {
                q: JointVector::from(message.q_ref_rad),
                qd: JointVector::from(message.qd_ref_rad_s),
            })
        }
        _ => None,
    }
}

fn object_motion(message: &ObjectMsg) -> Option<ObjectMotion> {
    let finite =
        message.translation_m.iter().chain([&message.radius_m, &message.rev_per_min]).all(|v| v.is_finite());
    match message.kind {
        _ if !finite => None,
        command_kind::OBJECT_HOLD => Some(ObjectMotion::Hold),
        command_kind::OBJECT_STEP => Some(ObjectMotion::Step {
            at_s: 0.0,
            translation_m: nalgebra::Vector3::from(message.translation_m),
        }),
        command_kind::OBJECT_CIRCLE => {
            Some(ObjectMotion::Circle { radius_m: message.radius_m, rev_per_min: message.rev_per_min })
        }
        _ => None,
    }
}

/// Runs the plant until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let config = context.cell.config();
    let instance = &context.instance;
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Plant)?;
    let state_publisher = vservo_protocol::publisher::<JointStateMsg>(&node, instance, Topic::JointState)?;
    let state_notifier = vservo_protocol::notifier(&node, instance, Topic::JointState)?;
    let world_publisher = vservo_protocol::publisher::<SimWorldMsg>(&node, instance, Topic::SimWorld)?;
    let object_subscriber = vservo_protocol::subscriber::<ObjectMsg>(&node, instance, Topic::Object)?;
    let command_subscriber =
        vservo_protocol::subscriber::<JointCommandMsg>(&node, instance, Topic::JointCommand)?;

    let mut stage = match context.resume {
        Some((q, tick)) => context.cell.plant_resumed(&q, tick),
        None => context.cell.plant(),
    };
    go_realtime(context, NodeRole::Plant);
    let period_ns = (config.timing.control_period_s * 1e9).round() as u64;
    let declared = Declared {
        // an epoch no earlier plant of this host has used: consumers re-synchronise when it changes
        epoch: monotonic_ns(),
        period_ns,
        command_mode: crate::wire::command_mode_code(config.command_interface()),
    };
    let torque_max_nm: [f64; 6] = std::array::from_fn(|j| context.cell.arm().links[j].limits.torque_max);
    let speed_max_rad_s: [f64; 6] = std::array::from_fn(|j| context.cell.arm().links[j].limits.velocity_max);
    let hold_after = u64::from(config.runtime.hold_after_missed_ticks);
    let counters = monitor.counters();
    tracing::info!(
        node = "plant",
        tick = stage.state().tick,
        mode = stage.mode().name(),
        "the arm at rest, first tick"
    );

    // the daemon gone: the plant goes last, once the rmrc has stopped answering and the arm is at rest
    let mut orphaned_at: Option<u64> = None;
    let orphan_timeout_ns = ((config.runtime.stop_timeout_s + 2.0) * 1e9) as u64;
    // the command applied and the tick it answered (reported in the next joint state)
    let mut last_command: Option<(ActuatorCommand, u64)> = None;
    let mut applied_command_tick = u64::MAX;
    let mut object_sequence = 0;
    let mut missed_in_a_row: u64 = 0;
    let mut timer = PeriodicTimer::start(period_ns);
    while !context.stopping() {
        // publish the state, wake the rmrc
        let state = *stage.state();
        let message = state_message(&stage, &state, &declared, applied_command_tick);
        let published_at = message.stamp_ns;
        if let Ok(sample) = world_publisher.loan_uninit() {
            let world = SimWorldMsg {
                schema: SCHEMA_VERSION,
                reserved: 0,
                tick: state.tick,
                base_from_board: pose_to_wire(&stage.base_from_board()),
            };
            let _ = sample.write_payload(world).send();
        }
        if let Ok(sample) = state_publisher.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
        let _ = state_notifier.notify();
        counters.set_progress(state.tick);
        counters.set_mode(u32::from(stage.is_holding()));

        // the rmrc answers within the tick; the answer is read at the deadline, not waited for: a timed wait
        // on an iceoryx2 listener that times out overshoots by several milliseconds (measured 7.8 ms here)
        let wake = timer.wait();
        let started = monotonic_ns();
        let mut answer = None;
        let mut round_trip_ns = 0;
        while let Ok(Some(sample)) = command_subscriber.receive() {
            let reply = *sample;
            // the rmrc's commands only: sealed with the run's key
            let sealed = context.seal_key.is_some_and(|key| key.seal_joint_command(&reply) == reply.seal);
            if !schema_ok(reply.schema) || reply.driver_epoch != declared.epoch || !sealed {
                counters.rejected();
            } else if reply.answers_tick == state.tick {
                match command_of(&reply, declared.command_mode, &torque_max_nm) {
                    Some(command) => {
                        answer = Some(command);
                        // state published → answer in the plant's queue (the rmrc stamps it as it sends)
                        round_trip_ns = reply.stamp_ns.saturating_sub(published_at).max(1);
                    }
                    None => counters.rejected(),
                }
            }
            // an answer to an older tick came too late: already counted
        }
        if wake.skipped_periods > 0 {
            counters.overrun();
            counters.skipped(wake.skipped_periods);
        }
        // an object command (from vservod; rare) changes the board's motion from this tick on
        if let Some(message) = latest(&object_subscriber, |m: &ObjectMsg| m.schema, counters)
            && message.sequence != object_sequence
        {
            object_sequence = message.sequence;
            // the daemon's command only: sealed with the run's key (the daemon has checked its limits)
            let sealed = context.seal_key.is_some_and(|key| key.seal_object(&message) == message.seal);
            match object_motion(&message).filter(|_| sealed) {
                Some(motion) => stage.set_object_motion(motion),
                None => counters.rejected(),
            }
        }
        // a joint over its speed limit: the drives brake the arm, whatever is commanded (an overspeed trip)
        let overspeed = stage.state().qd.iter().zip(&speed_max_rad_s).any(|(v, max)| v.abs() > *max);
        if overspeed && answer.is_some() {
            counters.rejected();
            answer = None;
            missed_in_a_row = hold_after;
        }
        // a late tick still advances one tick of simulated time
        match answer {
            Some(command) => {
                missed_in_a_row = 0;
                last_command = Some((command, state.tick));
                applied_command_tick = state.tick;
                stage.apply(&command);
            }
            None => {
                counters.late_answer();
                missed_in_a_row += 1;
                match last_command {
                    Some((command, answered)) if missed_in_a_row <= hold_after => {
                        applied_command_tick = answered;
                        stage.apply(&command);
                    }
                    _ => {
                        applied_command_tick = u64::MAX;
                        stage.hold();
                    }
                }
            }
        }
        monitor.record(CycleSample {
            wake_latency_ns: wake.lateness_ns,
            execution_ns: monotonic_ns().saturating_sub(started),
            round_trip_ns,
            ..CycleSample::default()
        });
        if context.orphaned() {
            let since = *orphaned_at.get_or_insert_with(|| {
                tracing::warn!(
                    node = "plant",
                    "the daemon is gone: holding the arm once the rmrc has brought it to rest"
                );
                started
            });
            let rmrc_gone = missed_in_a_row > hold_after;
            let at_rest = stage.state().qd.iter().all(|v| v.abs() < crate::AT_REST_RAD_S);
            if rmrc_gone && at_rest {
                tracing::info!(
                    node = "plant",
                    tick = stage.state().tick,
                    "the arm is at rest and held; stopping (the daemon is gone)"
                );
                break;
            }
            if started.saturating_sub(since) > orphan_timeout_ns {
                tracing::error!(
                    node = "plant",
                    "the daemon is gone and the arm did not come to rest in time; stopping"
                );
                break;
            }
        }
    }
    // the last word: the state the arm stopped in
    let state = *stage.state();
    if let Ok(sample) = state_publisher.loan_uninit() {
        let _ = sample.write_payload(state_message(&stage, &state, &declared, applied_command_tick)).send();
    }
    tracing::info!(node = "plant", tick = stage.state().tick, "stopped");
    Ok(())
}
