//! The plant node, the simulated robot driver: the 1 ms tick on absolute deadlines. Each tick: sleep until
//! the deadline, take the rmrc's answer to the last state (or, counted late, follow the previous command's
//! reference with the drive's own servo),
//! advance one tick, publish the new state (and, on the simulation-only `sim_world`, where the board is)
//! and wake the rmrc. It follows the robot driver contract of docs/DRIVERS.md like any external driver.

use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ipc};
use vservo_cell::{ActuatorCommand, CommandReference, PlantStage};
use vservo_driver::{CommandRefused, DriverSettings, DriverSide};
use vservo_protocol::TakeMessages;
use vservo_protocol::freshness::{self, Issue, Standing};
use vservo_protocol::seal::sealed_by;
use vservo_protocol::{
    CommandKind, CommandMode, DriverStatus, JointCommandMsg, JointStateMsg, MAX_JOINTS, NodeRole, ObjectMsg,
    SCHEMA_VERSION, SimWorldMsg, Topic, fault_bits,
};
use vservo_sim::plant::JointState;
use vservo_sim::world::ObjectMotion;

use super::{NodeBase, go_realtime, start};
use crate::clock::PeriodicTimer;
use crate::telemetry::{Counters, CycleSample};
use crate::wire::{joints_from_wire, joints_to_wire, pose_to_wire, wire_joint_count};
use crate::{NodeContext, RuntimeError};
use vservo_time::monotonic_ns;

/// The simulated driver's identity in each joint state: its epoch, period and command interface.
#[derive(Debug, Clone, Copy)]
struct Declared {
    epoch: u64,
    period_ns: u64,
    command_mode: CommandMode,
}

/// The driver's status for a state of the plant.
fn driver_status(stage: &PlantStage, state: &JointState) -> DriverStatus {
    if state.faults.integration_failed {
        DriverStatus::Fault
    } else if stage.is_holding() {
        DriverStatus::Holding
    } else {
        DriverStatus::Following
    }
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
    JointStateMsg {
        schema: SCHEMA_VERSION,
        faults,
        tick: state.tick,
        stamp_ns: monotonic_ns(),
        driver_epoch: declared.epoch,
        period_ns: declared.period_ns,
        command_mode: declared.command_mode.into(),
        driver_status: driver_status(stage, state).into(),
        joint_count: wire_joint_count(stage.arm()),
        driver_error: 0,
        q_rad: joints_to_wire(&state.q),
        qd_rad_s: joints_to_wire(&state.qd),
        torque_nm: joints_to_wire(&state.applied_torque),
        applied_command_tick,
    }
}

/// A commanded torque beyond this many times a joint's torque limit is refused (the plant then holds the
/// arm); up to it, the drives saturate at the limit, as real ones do.
const TORQUE_REFUSED_ABOVE_LIMITS: f64 = 1.5;

/// The command a joint command carries and the reference it was computed on, if it is for an arm of as many
/// joints as `torque_max_nm` has limits, in the interface this driver declared, finite (its reference too) and,
/// for torques, within [`TORQUE_REFUSED_ABOVE_LIMITS`] of the limits.
fn command_of(
    message: &JointCommandMsg,
    declared: CommandMode,
    torque_max_nm: &[f64],
) -> Option<(ActuatorCommand, CommandReference)> {
    // the arm's joints only: the slots past them are not read
    let all_finite = |v: &[f64; MAX_JOINTS]| v.iter().take(torque_max_nm.len()).all(|x| x.is_finite());
    let torque_in_range = message
        .torque_nm
        .iter()
        .zip(torque_max_nm)
        .all(|(t, max)| t.abs() <= TORQUE_REFUSED_ABOVE_LIMITS * max);
    let joint_count = message.joint_count;
    if joint_count as usize != torque_max_nm.len()
        || !all_finite(&message.q_ref_rad)
        || !all_finite(&message.qd_ref_rad_s)
    {
        return None;
    }
    let reference = CommandReference {
        q: joints_from_wire(&message.q_ref_rad, joint_count),
        qd: joints_from_wire(&message.qd_ref_rad_s, joint_count),
    };
    let command = match CommandMode::try_from(message.mode) {
        Ok(mode) if mode != declared => None,
        Ok(CommandMode::Torque) if all_finite(&message.torque_nm) && torque_in_range => {
            Some(ActuatorCommand::Torque(joints_from_wire(&message.torque_nm, joint_count)))
        }
        Ok(CommandMode::Position) => Some(ActuatorCommand::Reference { q: reference.q, qd: reference.qd }),
        _ => None,
    };
    command.map(|command| (command, reference))
}

fn object_motion(message: &ObjectMsg) -> Option<ObjectMotion> {
    let finite =
        message.translation_m.iter().chain([&message.radius_m, &message.rev_per_min]).all(|v| v.is_finite());
    match CommandKind::try_from(message.kind) {
        _ if !finite => None,
        Ok(CommandKind::ObjectHold) => Some(ObjectMotion::Hold),
        Ok(CommandKind::ObjectStep) => Some(ObjectMotion::Step {
            at_s: 0.0,
            translation_m: nalgebra::Vector3::from(message.translation_m),
        }),
        Ok(CommandKind::ObjectCircle) => {
            Some(ObjectMotion::Circle { radius_m: message.radius_m, rev_per_min: message.rev_per_min })
        }
        _ => None,
    }
}

/// The plant's ports.
struct Ports {
    states: Publisher<ipc::Service, JointStateMsg, ()>,
    state_notifier: Notifier<ipc::Service>,
    world: Publisher<ipc::Service, SimWorldMsg, ()>,
    objects: Subscriber<ipc::Service, ObjectMsg, ()>,
    commands: Subscriber<ipc::Service, JointCommandMsg, ()>,
}

impl Ports {
    fn open(node: &Node<ipc::Service>, instance: &str) -> Result<Self, RuntimeError> {
        Ok(Self {
            states: vservo_protocol::publisher(node, instance, Topic::JointState)?,
            state_notifier: vservo_protocol::notifier(node, instance, Topic::JointState)?,
            world: vservo_protocol::publisher(node, instance, Topic::SimWorld)?,
            objects: vservo_protocol::subscriber(node, instance, Topic::Object)?,
            commands: vservo_protocol::subscriber(node, instance, Topic::JointCommand)?,
        })
    }

    fn send_state(&self, message: JointStateMsg) {
        if let Ok(sample) = self.states.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
    }
}

/// What the plant makes of one of the rmrc's commands.
#[derive(Debug, Clone, Copy, PartialEq)]
#[expect(
    clippy::large_enum_variant,
    reason = "on the stack, once per command: a box would allocate on the 1 ms path"
)]
enum Reply {
    /// The answer to the tick just published, to apply.
    Answer((ActuatorCommand, CommandReference)),
    /// Not the rmrc's (unsealed), not this run's, or not one the plant can apply: counted.
    Refused,
    /// An answer to another tick than the one just published: came too late (already counted as late).
    Late,
}

/// Judges a command that came while the state of `tick` was the last published: admitted by the driver side of
/// the contract (`vservo_driver::DriverSide::take_command`: the rmrc's seal, schema, run, mode, joint count, age,
/// finite), then applied only as the answer to `tick` itself (the lockstep's replay of a run is tick for tick)
/// and when `command_of` takes it (its reference finite, its torque within the bound).
fn judge(
    side: &mut DriverSide,
    reply: &JointCommandMsg,
    tick: u64,
    torque_max_nm: &[f64],
    now_ns: u64,
) -> Reply {
    match side.take_command(reply, now_ns) {
        // not the rmrc's, or another run's (a restarted plant's predecessor's), whatever tick it answers
        Err(CommandRefused::Unsealed | CommandRefused::Epoch { .. }) => Reply::Refused,
        _ if reply.answers_tick != tick => Reply::Late,
        Ok(()) => {
            command_of(reply, side.settings().mode, torque_max_nm).map_or(Reply::Refused, Reply::Answer)
        }
        Err(_) => Reply::Refused,
    }
}

/// The rmrc's answer to the state of a tick, as the plant took it.
#[derive(Debug, Clone, Copy, Default)]
struct Answer {
    command: Option<(ActuatorCommand, CommandReference)>,
    /// State published → answer in the plant's queue (the rmrc stamps it as it sends); 0 if none.
    round_trip_ns: u64,
}

/// The simulated driver between ticks: the stage, what it declares, and the command it follows.
struct Plant {
    stage: PlantStage,
    declared: Declared,
    /// The driver side of the contract: which commands it admits.
    side: DriverSide,
    /// The arm's torque limits, one per joint.
    torque_max_nm: [f64; MAX_JOINTS],
    /// The arm's speed limits, one per joint (zero past its joints, where the speed is zero).
    speed_max_rad_s: [f64; MAX_JOINTS],
    joint_count: usize,
    /// Ticks without an answer after which the previous command is no longer kept: the arm is held.
    hold_after: u64,
    /// The reference of the command applied and the tick it answered (reported in the next joint state): what
    /// the drive's own servo follows while answers are late.
    last_command: Option<(CommandReference, u64)>,
    applied_command_tick: u64,
    missed_in_a_row: u64,
    /// What the object command in force came with; none taken yet.
    object_issue: Option<Issue>,
    /// The daemon gone: since when (the plant goes last, once the rmrc has stopped answering and the arm is
    /// at rest), and how long it waits for that.
    orphaned_since_ns: Option<u64>,
    orphan_timeout_ns: u64,
}

impl Plant {
    fn new(context: &NodeContext) -> Self {
        let config = context.cell.config();
        let limits = |j: usize| context.cell.arm().links[j].limits;
        let declared = Declared {
            // an epoch no earlier plant of this host has used: consumers re-synchronise when it changes
            epoch: monotonic_ns(),
            period_ns: vservo_time::nanos(config.timing.control_period_s),
            command_mode: crate::wire::command_mode(config.command_interface()),
        };
        let hold_after = u64::from(context.runtime.hold_after_missed_ticks);
        let settings = DriverSettings {
            mode: declared.command_mode,
            joint_count: context.cell.arm().joint_count(),
            period_ns: declared.period_ns,
            // the plant counts missed ticks itself (`advance`); its simulated periods are not checked
            hold_after_ns: hold_after * declared.period_ns,
            position_min_rad: std::array::from_fn(|j| limits(j).position_min),
            position_max_rad: std::array::from_fn(|j| limits(j).position_max),
            velocity_max_rad_s: std::array::from_fn(|j| limits(j).velocity_max),
            // a torque driver: the held cell's ramp to rest is the rmrc's to keep (the rule is for velocities)
            braking_gain_rad_s: [0.0; MAX_JOINTS],
        };
        Self {
            stage: match context.resume {
                Some((q, tick)) => context.cell.plant_resumed(&q, tick),
                None => context.cell.plant(),
            },
            declared,
            side: DriverSide::new(settings, declared.epoch, context.seal_key.clone()),
            torque_max_nm: std::array::from_fn(|j| limits(j).torque_max),
            speed_max_rad_s: std::array::from_fn(|j| limits(j).velocity_max),
            joint_count: context.cell.arm().joint_count(),
            hold_after,
            last_command: None,
            applied_command_tick: u64::MAX,
            missed_in_a_row: 0,
            object_issue: None,
            orphaned_since_ns: None,
            orphan_timeout_ns: (context.runtime.stop_timeout + std::time::Duration::from_secs(2)).as_nanos()
                as u64,
        }
    }

    /// Publishes where the board is and the state, and wakes the rmrc; the state's stamp.
    fn publish(&mut self, ports: &Ports, counters: &Counters) -> u64 {
        let state = *self.stage.state();
        let message = state_message(&self.stage, &state, &self.declared, self.applied_command_tick);
        if let Ok(sample) = ports.world.loan_uninit() {
            let world = SimWorldMsg {
                schema: SCHEMA_VERSION,
                reserved: 0,
                tick: state.tick,
                base_from_board: pose_to_wire(&self.stage.base_from_board()),
            };
            let _ = sample.write_payload(world).send();
        }
        ports.send_state(message);
        self.side.published(state.tick, message.stamp_ns);
        let _ = ports.state_notifier.notify();
        counters.set_progress(state.tick);
        counters.set_mode(u32::from(self.stage.is_holding()));
        message.stamp_ns
    }

    /// The rmrc's answer to the state of `tick`, from the commands waiting ([`judge`]): a refused one counted;
    /// an answer to an older tick came too late (already counted).
    fn answer(&mut self, ports: &Ports, tick: u64, published_at: u64, counters: &Counters) -> Answer {
        let mut answer = Answer::default();
        let torque_max_nm = &self.torque_max_nm[..self.joint_count];
        let now_ns = monotonic_ns();
        while let Some(taken) = ports.commands.next_message() {
            let Ok(reply) = taken else {
                counters.rejected();
                continue;
            };
            match judge(&mut self.side, &reply, tick, torque_max_nm, now_ns) {
                Reply::Answer(command) => {
                    answer.command = Some(command);
                    answer.round_trip_ns = reply.stamp_ns.saturating_sub(published_at).max(1);
                }
                Reply::Refused => counters.rejected(),
                Reply::Late => {}
            }
        }
        answer
    }

    /// Object commands (from vservod; rare) change the board's motion from this tick on: the daemon's only
    /// (sealed with the run's key; the daemon has checked its limits), each judged as it came.
    fn take_object_motion(&mut self, ports: &Ports, context: &NodeContext, counters: &Counters) {
        let refused =
            ports.objects.each_message(|message| self.take_object_command(&message, context, counters));
        (0..refused).for_each(|_| counters.rejected());
    }

    /// One object command: taken when sealed, newer than the one in force and a motion.
    fn take_object_command(&mut self, message: &ObjectMsg, context: &NodeContext, counters: &Counters) {
        let issue = Issue { stamp_ns: message.stamp_ns, counter: message.sequence };
        let standing = freshness::standing(self.object_issue, issue, monotonic_ns());
        if standing == Standing::Same {
            return;
        }
        let sealed = sealed_by(context.seal_key.as_ref(), message);
        match object_motion(message).filter(|_| sealed && standing.is_newer()) {
            Some(motion) => {
                self.stage.set_object_motion(motion);
                self.object_issue = Some(issue);
            }
            None => counters.rejected(),
        }
    }

    /// A joint over its speed limit: the drives brake the arm, whatever is commanded (an overspeed trip);
    /// the answer refused.
    fn overspeed_trip(&mut self, answer: &mut Answer, counters: &Counters) {
        let qd = self.stage.state().qd;
        let overspeed =
            qd.iter().zip(&self.speed_max_rad_s).take(self.joint_count).any(|(v, max)| v.abs() > *max);
        if overspeed && answer.command.is_some() {
            counters.rejected();
            answer.command = None;
            self.missed_in_a_row = self.hold_after;
        }
    }

    /// Advances one tick (a late tick too) on the answer, else for up to `hold_after` ticks on the previous
    /// command's reference, followed by the drive's own servo (never its torque again), else holding the arm.
    fn advance(
        &mut self,
        tick: u64,
        answer: Option<(ActuatorCommand, CommandReference)>,
        counters: &Counters,
    ) {
        if let Some((command, reference)) = answer {
            self.missed_in_a_row = 0;
            self.last_command = Some((reference, tick));
            self.applied_command_tick = tick;
            self.stage.apply(&command);
            return;
        }
        counters.late_answer();
        self.missed_in_a_row += 1;
        match self.last_command {
            Some((reference, answered)) if self.missed_in_a_row <= self.hold_after => {
                self.applied_command_tick = answered;
                self.stage.follow_late(&reference, tick.saturating_sub(answered));
            }
            _ => {
                self.applied_command_tick = u64::MAX;
                self.stage.hold();
            }
        }
    }

    /// With the daemon gone: whether to stop now (the rmrc has stopped answering and the arm is at rest, or
    /// it did not come to rest in time).
    fn orphan_stops(&mut self, now_ns: u64) -> bool {
        let since = *self.orphaned_since_ns.get_or_insert_with(|| {
            tracing::warn!(
                node = "plant",
                "the daemon is gone: holding the arm once the rmrc has brought it to rest"
            );
            now_ns
        });
        let rmrc_gone = self.missed_in_a_row > self.hold_after;
        let at_rest = self.stage.state().qd.iter().all(|v| v.abs() < crate::AT_REST_RAD_S);
        let tick = self.stage.state().tick;
        if rmrc_gone && at_rest {
            tracing::info!(
                node = "plant",
                tick,
                "the arm is at rest and held; stopping (the daemon is gone)"
            );
            return true;
        }
        let late = now_ns.saturating_sub(since) > self.orphan_timeout_ns;
        if late {
            tracing::error!(
                node = "plant",
                "the daemon is gone and the arm did not come to rest in time; stopping"
            );
        }
        late
    }
}

/// Runs the plant until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Plant)?;
    let ports = Ports::open(&node, &context.instance)?;
    let mut plant = Plant::new(context);
    go_realtime(context, NodeRole::Plant);
    let counters = monitor.counters();
    let first = plant.stage.state().tick;
    tracing::info!(
        node = "plant",
        tick = first,
        mode = plant.stage.mode().name(),
        "the arm at rest, first tick"
    );
    let mut timer = PeriodicTimer::start(plant.declared.period_ns);
    while !context.stopping() {
        let tick = plant.stage.state().tick;
        let published_at = plant.publish(&ports, counters);
        // the rmrc answers within the tick; the answer is read at the deadline, not waited for: a timed wait
        // on an iceoryx2 listener that times out overshoots by several milliseconds (measured 7.8 ms here)
        let wake = timer.wait();
        let started = monotonic_ns();
        let mut answer = plant.answer(&ports, tick, published_at, counters);
        if wake.skipped_periods > 0 {
            counters.overrun();
            counters.skipped(wake.skipped_periods);
        }
        plant.take_object_motion(&ports, context, counters);
        plant.overspeed_trip(&mut answer, counters);
        plant.advance(tick, answer.command, counters);
        monitor.record(CycleSample {
            wake_latency_ns: wake.lateness_ns,
            execution_ns: monotonic_ns().saturating_sub(started),
            round_trip_ns: answer.round_trip_ns,
            ..CycleSample::default()
        });
        if context.orphaned() && plant.orphan_stops(started) {
            break;
        }
    }
    // the last word: the state the arm stopped in
    let state = *plant.stage.state();
    ports.send_state(state_message(&plant.stage, &state, &plant.declared, plant.applied_command_tick));
    tracing::info!(node = "plant", tick = state.tick, "stopped");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_arm::{JointVector, six_joints};

    const LIMITS_NM: [f64; 6] = [100.0; 6];

    fn command(mode: u32) -> JointCommandMsg {
        JointCommandMsg { schema: SCHEMA_VERSION, mode, ..JointCommandMsg::default() }
    }

    /// The command `command_of` takes, without its reference.
    fn taken(
        message: &JointCommandMsg,
        declared: CommandMode,
        torque_max_nm: &[f64],
    ) -> Option<ActuatorCommand> {
        command_of(message, declared, torque_max_nm).map(|(command, _)| command)
    }

    #[test]
    fn a_command_is_taken_only_in_the_declared_interface_finite_and_within_the_torque_bound() {
        let torque = JointCommandMsg { torque_nm: [150.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0], ..command(0) };
        let expected = ActuatorCommand::Torque(six_joints([150.0, 0.0, 0.0, 0.0, 0.0, -1.0]));
        assert_eq!(taken(&torque, CommandMode::Torque, &LIMITS_NM), Some(expected));
        // beyond 1.5 times a joint's limit, not finite, or another interface than declared: refused
        let beyond = JointCommandMsg { torque_nm: [150.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], ..torque };
        assert_eq!(taken(&beyond, CommandMode::Torque, &LIMITS_NM), None);
        let nan = JointCommandMsg { torque_nm: [f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], ..torque };
        assert_eq!(taken(&nan, CommandMode::Torque, &LIMITS_NM), None);
        // the reference a torque was computed on comes with it (what the drive follows when answers are late),
        // and must be finite too
        let with_reference = JointCommandMsg { q_ref_rad: [0.3; 7], qd_ref_rad_s: [-0.1; 7], ..torque };
        let (_, reference) =
            command_of(&with_reference, CommandMode::Torque, &LIMITS_NM).expect("taken with its reference");
        assert_eq!((reference.q, reference.qd), (six_joints([0.3; 6]), six_joints([-0.1; 6])));
        let nan_reference =
            JointCommandMsg { qd_ref_rad_s: [0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0], ..torque };
        assert_eq!(taken(&nan_reference, CommandMode::Torque, &LIMITS_NM), None);
        assert_eq!(taken(&torque, CommandMode::Position, &LIMITS_NM), None);
        let position = JointCommandMsg { q_ref_rad: [0.1; 7], qd_ref_rad_s: [0.2; 7], ..command(2) };
        // the slots past the arm's joints are not taken
        let reference = ActuatorCommand::Reference { q: six_joints([0.1; 6]), qd: six_joints([0.2; 6]) };
        assert_eq!(taken(&position, CommandMode::Position, &LIMITS_NM), Some(reference));
        // a command for another arm's joint count is refused
        let seven = JointCommandMsg { joint_count: 7, ..position };
        assert_eq!(taken(&seven, CommandMode::Position, &LIMITS_NM), None);
        // and taken by a seven-joint arm's driver
        let reference =
            ActuatorCommand::Reference { q: JointVector::from([0.1; 7]), qd: JointVector::from([0.2; 7]) };
        assert_eq!(taken(&seven, CommandMode::Position, &[100.0; 7]), Some(reference));
        // the simulated driver takes torques or positions; an unknown code is no interface at all
        assert_eq!(taken(&command(1), CommandMode::Velocity, &LIMITS_NM), None);
        assert_eq!(taken(&command(9), CommandMode::Torque, &LIMITS_NM), None);
    }

    #[test]
    fn a_command_is_applied_as_the_answer_to_the_tick_just_published_only() {
        let settings = DriverSettings {
            mode: CommandMode::Torque,
            joint_count: 6,
            period_ns: 1_000_000,
            hold_after_ns: 20_000_000,
            position_min_rad: [-3.0; MAX_JOINTS],
            position_max_rad: [3.0; MAX_JOINTS],
            velocity_max_rad_s: [2.0; MAX_JOINTS],
            braking_gain_rad_s: [0.0; MAX_JOINTS],
        };
        let key = vservo_protocol::seal::SealKey::random().expect("a key");
        let mut side = DriverSide::new(settings, 5, Some(key.clone()));
        side.published(10, 1_000);
        let answer = JointCommandMsg { answers_tick: 10, driver_epoch: 5, ..command(0) };
        // `sealed`: the rmrc's seal, or another's
        let mut judged = |reply: &JointCommandMsg, sealed: bool| {
            let mut reply = *reply;
            key.sign(&mut reply);
            reply.seal ^= u64::from(!sealed);
            judge(&mut side, &reply, 10, &LIMITS_NM, 0)
        };
        assert!(matches!(judged(&answer, true), Reply::Answer(_)));
        // not the rmrc's, another run's (whatever tick it answers), beyond the torque bound: refused
        assert_eq!(judged(&answer, false), Reply::Refused);
        assert_eq!(
            judged(&JointCommandMsg { driver_epoch: 6, answers_tick: 9, ..answer }, true),
            Reply::Refused
        );
        let beyond = JointCommandMsg { torque_nm: [150.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], ..answer };
        assert_eq!(judged(&beyond, true), Reply::Refused);
        // an answer to an earlier tick (within the contract's window or not), or to one not published: late
        for answers_tick in [9, 8, 6, 11] {
            assert_eq!(
                judged(&JointCommandMsg { answers_tick, ..answer }, true),
                Reply::Late,
                "{answers_tick}"
            );
        }
    }

    #[test]
    fn an_object_command_is_a_motion_of_its_kind_when_finite() {
        let object = |kind: CommandKind| ObjectMsg {
            schema: SCHEMA_VERSION,
            kind: kind.into(),
            translation_m: [0.01, 0.0, 0.0],
            radius_m: 0.05,
            rev_per_min: 6.0,
            ..ObjectMsg::default()
        };
        assert_eq!(object_motion(&object(CommandKind::ObjectHold)), Some(ObjectMotion::Hold));
        assert!(matches!(object_motion(&object(CommandKind::ObjectStep)), Some(ObjectMotion::Step { .. })));
        assert!(matches!(
            object_motion(&object(CommandKind::ObjectCircle)),
            Some(ObjectMotion::Circle { .. })
        ));
        assert_eq!(object_motion(&object(CommandKind::Reload)), None);
        assert_eq!(object_motion(&ObjectMsg { kind: 99, ..object(CommandKind::ObjectHold) }), None);
        assert_eq!(
            object_motion(&ObjectMsg { radius_m: f64::NAN, ..object(CommandKind::ObjectCircle) }),
            None
        );
    }
}
