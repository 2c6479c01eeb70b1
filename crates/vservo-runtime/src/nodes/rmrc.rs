//! The rmrc node: wakes on each joint state of the robot driver and answers with the command for the
//! driver's next period, in the interface the driver declared (torque, velocity or position).
//!
//! A joint state that is not of this build's schema, not finite, or from a driver that declares another
//! command interface or period than the configuration's is refused and counted: nothing is commanded on it.
//! What the rmrc does with the states it takes is the rmrc stage's (`vservo_cell::RmrcStage::follow`): after
//! a stall or on a new `driver_epoch` its reference starts again at rest from the measured joints, and the
//! ticks it woke too late for are stepped through; this node counts both and reports the reference's start
//! in each command (`reference_since_tick`).

use iceoryx2::port::listener::Listener;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ipc};
use vservo_arm::JointVector;
use vservo_cell::{ActuatorCommand, DriverTick, Following, RmrcStage, TwistLimits};
use vservo_control::Twist;
use vservo_protocol::TakeMessages;
use vservo_protocol::seal::{SealKey, sign_with};
use vservo_protocol::stream::SealedStream;
use vservo_protocol::{
    CameraTwistMsg, CommandMode, DriverStatus, JointCommandMsg, JointStateMsg, MAX_JOINTS, NodeRole,
    SCHEMA_VERSION, Topic, Verdict,
};

use super::{CellModeFollower, IDLE_WAIT, ModeInForce, NodeBase, go_realtime, latest, start};
use crate::telemetry::{Counters, CycleSample};
use crate::wire::{command_mode, joints_from_wire, joints_to_wire, wire_joint_count};
use crate::{NodeContext, RuntimeError};
use vservo_time::monotonic_ns;

/// The rmrc's ports.
struct Ports {
    states: Subscriber<ipc::Service, JointStateMsg, ()>,
    state_listener: Listener<ipc::Service>,
    twists: Subscriber<ipc::Service, CameraTwistMsg, ()>,
    commands: Publisher<ipc::Service, JointCommandMsg, ()>,
    /// The daemon's safe stop (the reference ramps to rest and is held, whatever twist arrives) and joint
    /// moves.
    cell_mode: CellModeFollower,
}

impl Ports {
    fn open(node: &Node<ipc::Service>, instance: &str) -> Result<Self, RuntimeError> {
        Ok(Self {
            states: vservo_protocol::subscriber(node, instance, Topic::JointState)?,
            state_listener: vservo_protocol::listener(node, instance, Topic::JointState)?,
            twists: vservo_protocol::subscriber(node, instance, Topic::CameraTwist)?,
            commands: vservo_protocol::publisher(node, instance, Topic::JointCommand)?,
            cell_mode: CellModeFollower::open(node, instance, NodeRole::Rmrc)?,
        })
    }

    /// Sends a command, sealed with the run's key (the simulated driver applies sealed commands only).
    fn send(&self, mut message: JointCommandMsg, key: Option<&SealKey>) {
        if let Ok(sample) = self.commands.loan_uninit() {
            message.stamp_ns = monotonic_ns();
            sign_with(key, &mut message);
            let _ = sample.write_payload(message).send();
        }
    }
}

/// The daemon gone: when it was first seen gone, and how long the ramp to rest may take before the rmrc
/// gives up (the plant then brakes the arm itself).
struct Orphaned {
    since_ns: Option<u64>,
    timeout_ns: u64,
}

impl Orphaned {
    /// Whether the rmrc should give up now: the daemon gone for longer than the ramp may take.
    fn gives_up(&mut self, orphaned: bool, now_ns: u64) -> bool {
        if !orphaned {
            return false;
        }
        let since = *self.since_ns.get_or_insert_with(|| {
            tracing::warn!(node = "rmrc", "the daemon is gone: ramping the arm to rest, then stopping");
            now_ns
        });
        let late = now_ns.saturating_sub(since) > self.timeout_ns;
        if late {
            tracing::error!(node = "rmrc", "the daemon is gone and the arm did not come to rest in time");
        }
        late
    }

    fn is_orphaned(&self) -> bool {
        self.since_ns.is_some()
    }
}

/// The rmrc between joint states: its stage and what it reports in each command.
struct Rmrc {
    stage: RmrcStage,
    /// The command interface, the period (ns) and the joint count a driver must declare.
    mode: CommandMode,
    period_ns: u64,
    joint_count: u32,
    limits: TwistLimits,
    /// The twist in force: its frame's capture tick and the tick it was taken in (reported in each command).
    twist_in_force: (u64, u64),
    /// The servo's twists, admitted (sealed, its run's, later than the last taken, and fresh: within a vision
    /// period).
    twists: SealedStream,
    orphaned: Orphaned,
    /// The mode in force was a safe stop (a resume releases the collision guard's stop).
    held: bool,
}

impl Rmrc {
    fn new(context: &NodeContext) -> Self {
        let config = context.cell.config();
        Self {
            // at rest at the starting joints until the first joint state says where the arm is
            stage: context.cell.rmrc(context.cell.start_joints()),
            mode: command_mode(config.command_interface()),
            period_ns: vservo_time::nanos(config.robot.period_s),
            joint_count: wire_joint_count(context.cell.arm()),
            limits: TwistLimits::of(config),
            twist_in_force: (u64::MAX, u64::MAX),
            twists: SealedStream::new(vservo_time::nanos(config.timing.vision_period_s)),
            orphaned: Orphaned {
                since_ns: None,
                timeout_ns: (context.runtime.stop_timeout + std::time::Duration::from_secs(1)).as_nanos()
                    as u64,
            },
            held: false,
        }
    }

    /// The measured joints of a state from a driver that declares this configuration's interface, period and
    /// joint count, if they are finite.
    fn admit(&self, state: &JointStateMsg) -> Option<(JointVector, JointVector)> {
        let declared_ok = CommandMode::try_from(state.command_mode) == Ok(self.mode)
            && state.period_ns.abs_diff(self.period_ns) <= self.period_ns / 100
            && state.joint_count == self.joint_count;
        let q = joints_from_wire(&state.q_rad, self.joint_count);
        let qd = joints_from_wire(&state.qd_rad_s, self.joint_count);
        let finite = q.iter().chain(qd.iter()).all(|v| v.is_finite());
        (declared_ok && finite).then_some((q, qd))
    }

    /// Follows the state (the stage decides a restart at rest or a catch-up; both counted).
    fn follow(&mut self, state: &JointStateMsg, q: &JointVector, qd: &JointVector, counters: &Counters) {
        let holding = DriverStatus::try_from(state.driver_status) == Ok(DriverStatus::Holding);
        let at =
            DriverTick { epoch: state.driver_epoch, tick: state.tick, stamp_ns: state.stamp_ns, holding };
        match self.stage.follow(at, q, qd) {
            // logged by the telemetry thread, off this path
            Following::Resynced => counters.resynced(),
            Following::Continued { missed_ticks } if missed_ticks > 0 => counters.skipped(missed_ticks),
            Following::Continued { .. } => {}
        }
    }

    /// Takes in the twists that came (refused ones counted). Only the servo's are taken: sealed, sent by the
    /// servo process the daemon announces and sealed in its run now (`Origin`), and fresh. A twist of another
    /// schema, or from another process in the servo's slot (the stream taken), brings the arm to rest at once;
    /// an unsealed, stale or repeated one leaves the twist in force.
    fn take_twists(&mut self, ports: &mut Ports, tick: u64, context: &NodeContext, counters: &Counters) {
        let key = context.seal_key.as_ref();
        let servo = ports.cell_mode.writer(NodeRole::Servo);
        while let Some(taken) = ports.twists.next_sent() {
            let taken = match self.twists.admit(taken, key, servo, monotonic_ns()) {
                Ok(sample) => self.take_fresh(&sample, tick),
                // another schema, or not the servo's now (the stream is taken): the arm brought to rest, as for a
                // twist out of range, not left moving
                Err(not_taken) if not_taken.stream_taken() => {
                    self.stage.set_twist(Twist::zeros(), tick);
                    None
                }
                // unsealed, a recording played again, a repeat: refused, the twist in force stays
                Err(_) => None,
            };
            match taken {
                Some(capture_tick) => self.twist_in_force = (capture_tick, tick),
                None => counters.rejected(),
            }
        }
    }

    /// Takes a fresh twist of the servo's (a verdict that does not move the arm, or a twist out of range, brings
    /// it to rest): its frame's capture tick, if the twist is taken.
    fn take_fresh(&mut self, sample: &CameraTwistMsg, tick: u64) -> Option<u64> {
        let moves = Verdict::try_from(sample.verdict).is_ok_and(Verdict::moves);
        let twist = Twist::from(sample.twist);
        let taken = self.stage.take_twist(&twist, moves, &self.limits, tick);
        taken.then_some(sample.capture_tick)
    }

    /// Acts on the cell mode: a safe stop or the daemon gone gives a zero twist (and ends a joint move), a joint
    /// move takes the reference to its goal instead of the twists (a goal outside the limits refused and
    /// counted), servoing ends a joint move.
    fn apply_mode(&mut self, mode: ModeInForce, tick: u64, counters: &Counters) {
        // no daemon and so no servo to trust: as a safe stop
        let mode = if self.orphaned.is_orphaned() { ModeInForce::SafeStop } else { mode };
        // the cell resumed (the daemon left a safe stop): the guard's own stop goes with it
        let resumed = self.held && !matches!(mode, ModeInForce::SafeStop);
        self.held = matches!(mode, ModeInForce::SafeStop);
        if resumed {
            self.stage.release_guard();
        }
        match mode {
            ModeInForce::Servoing => self.stage.end_joint_move(),
            // a zero twist, which the interpolator ramps to at its acceleration limits and then holds
            ModeInForce::SafeStop => {
                self.stage.end_joint_move();
                self.stage.set_twist(Twist::zeros(), tick);
            }
            ModeInForce::Moving { goal, speed_fraction } => {
                if !self.stage.move_joints_to(goal, speed_fraction, tick) {
                    counters.rejected();
                }
            }
        }
    }

    /// The command answering `state`.
    fn command(&mut self, state: &JointStateMsg, q: &JointVector, qd: &JointVector) -> JointCommandMsg {
        let command = self.stage.step(state.tick, q, qd);
        let reference = self.stage.reference();
        let torque = match command {
            ActuatorCommand::Torque(torque) => joints_to_wire(&torque),
            ActuatorCommand::Reference { .. } => [0.0; MAX_JOINTS],
        };
        JointCommandMsg {
            schema: SCHEMA_VERSION,
            mode: self.mode.into(),
            joint_count: self.joint_count,
            guard: guard_word(&self.stage),
            answers_tick: state.tick,
            driver_epoch: state.driver_epoch,
            state_stamp_ns: state.stamp_ns,
            stamp_ns: monotonic_ns(),
            torque_nm: torque,
            q_ref_rad: joints_to_wire(&reference.q),
            qd_ref_rad_s: joints_to_wire(&reference.qd),
            twist_capture_tick: self.twist_in_force.0,
            twist_applied_tick: self.twist_in_force.1,
            reference_since_tick: self.stage.since_tick(),
            seal: 0,
        }
    }
}

/// The collision guard's word for `joint_command.guard`: slowing, holding, and the distance it holds the arm for
/// (else the nearest within the slowdown distance).
fn guard_word(stage: &vservo_cell::RmrcStage) -> u32 {
    use vservo_protocol::guard_bits::{Distance, word};
    let named = |between: vservo_collision::Between| match between {
        vservo_collision::Between::Pair(pair) => Distance::Pair(pair as u32),
        vservo_collision::Between::Workspace { point } => Distance::WorkspacePoint(point as u32),
    };
    let assessed = stage.assessed();
    let slowing = assessed.is_some_and(|a| a.speed_share < 1.0);
    let holding = stage.guard_stop();
    let distance = holding.map(|stop| stop.between).or(assessed.and_then(|a| a.nearest).map(|n| n.between));
    word(slowing, holding.is_some(), distance.map(named))
}

/// Runs the rmrc until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Rmrc)?;
    let mut ports = Ports::open(&node, &context.instance)?;
    go_realtime(context, NodeRole::Rmrc);
    let counters = monitor.counters();
    let mut rmrc = Rmrc::new(context);
    while !context.stopping() {
        let _ = ports.state_listener.timed_wait(|_| {}, IDLE_WAIT);
        let woke_at = monotonic_ns();
        if rmrc.orphaned.gives_up(context.orphaned(), woke_at) {
            break;
        }
        let Some(state) = latest(&ports.states, counters) else { continue };
        let Some((q, qd)) = rmrc.admit(&state) else {
            counters.rejected();
            continue;
        };
        rmrc.follow(&state, &q, &qd, counters);
        // the mode first: it announces the servo's process, whose twists alone are taken
        let mode = ports.cell_mode.mode(context.seal_key.as_ref(), counters);
        rmrc.stage.set_speed_scale(ports.cell_mode.speed_scale());
        rmrc.take_twists(&mut ports, state.tick, context, counters);
        rmrc.apply_mode(mode, state.tick, counters);
        let message = rmrc.command(&state, &q, &qd);
        ports.send(message, context.seal_key.as_ref());
        let done = monotonic_ns();
        if done.saturating_sub(state.stamp_ns) > rmrc.period_ns {
            counters.overrun();
        }
        counters.set_progress(state.tick);
        monitor.record(CycleSample {
            wake_latency_ns: woke_at.saturating_sub(state.stamp_ns),
            execution_ns: done - woke_at,
            ..CycleSample::default()
        });
        // the arm's joints only: the slots past them are not the arm's
        let joints = rmrc.joint_count as usize;
        let at_rest = message.qd_ref_rad_s[..joints].iter().all(|v| *v == 0.0)
            && state.qd_rad_s[..joints].iter().all(|v| v.abs() < crate::AT_REST_RAD_S);
        if rmrc.orphaned.is_orphaned() && at_rest {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn with_the_daemon_gone_the_rmrc_gives_up_only_after_the_ramp_may_have_ended() {
        let mut orphaned = Orphaned { since_ns: None, timeout_ns: 1_000 };
        assert!(!orphaned.gives_up(false, 10) && !orphaned.is_orphaned());
        assert!(!orphaned.gives_up(true, 100) && orphaned.is_orphaned());
        assert!(!orphaned.gives_up(true, 1_100), "at the timeout, not beyond it");
        assert!(orphaned.gives_up(true, 1_101));
    }
}
