//! The servo node: wakes on each feature vector and answers with the camera twist.
//!
//! What the twist is, and the refusal of marks outside the image, are the servo stage's
//! (`vservo_cell::ServoStage`); this node takes the daemon's gains and cell mode, converts at the message
//! edge, counts a frame with a mark refused, and says each change of what the servo does.

use iceoryx2::port::listener::Listener;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{Node, ipc};
use vservo_cell::{ServoInput, ServoStage, ServoStep, ServoVerdict};
use vservo_control::{LawFlags, Twist};
use vservo_protocol::TakeMessages;
use vservo_protocol::freshness::{self, Issue, Standing};
use vservo_protocol::seal::{sealed_by, sign_with};
use vservo_protocol::stream::{NotTaken, SealedStream};
use vservo_protocol::{
    CameraTwistMsg, FeaturesMsg, GainsMsg, MarkStatus, NodeRole, SCHEMA_VERSION, Topic, Verdict, law_flag,
};
use vservo_scene::FeatureVector;

use super::{CellModeFollower, IDLE_WAIT, ModeInForce, NodeBase, go_realtime, start};
use crate::telemetry::{Counters, CycleSample, LoopMonitor, Note};
use crate::wire::to_array;
use crate::wire::{law_gains, pose_from_wire};
use crate::{NodeContext, RuntimeError};
use vservo_time::monotonic_ns;

/// The law's flags as `camera_twist.law_flags` bits.
fn law_flags_on_wire(flags: LawFlags) -> u32 {
    [
        (flags.barrier, law_flag::BARRIER),
        (flags.fixed_gain_fallback, law_flag::FIXED_GAIN_FALLBACK),
        (flags.feedforward, law_flag::FEEDFORWARD),
        (flags.rate_limited, law_flag::RATE_LIMITED),
    ]
    .into_iter()
    .filter(|(set, _)| *set)
    .fold(0, |bits, (_, bit)| bits | bit)
}

/// The stage's verdict as the wire says it (`camera_twist.verdict`); held while the cell moves its joints,
/// the servo says so (moving) rather than safe stop.
fn verdict_on_wire(servo: ServoVerdict, moving: bool) -> Verdict {
    match servo {
        ServoVerdict::Held if moving => Verdict::Moving,
        ServoVerdict::Waiting => Verdict::Waiting,
        ServoVerdict::Servoing => Verdict::Servoing,
        ServoVerdict::ServoingOnThree(_) => Verdict::ServoingOnThree,
        ServoVerdict::Reacquiring(_) => Verdict::Reacquiring,
        ServoVerdict::MarksMissing(_) => Verdict::MarksMissing,
        ServoVerdict::Held => Verdict::SafeStop,
    }
}

/// The servo's ports.
struct Ports {
    features: Subscriber<ipc::Service, FeaturesMsg, ()>,
    features_listener: Listener<ipc::Service>,
    twists: Publisher<ipc::Service, CameraTwistMsg, ()>,
    /// The daemon's latest design (history 1: a restarted servo takes it at once).
    gains: Subscriber<ipc::Service, GainsMsg, ()>,
    /// The daemon's safe stop: zero twists until it resumes the cell.
    cell_mode: CellModeFollower,
}

impl Ports {
    fn open(node: &Node<ipc::Service>, instance: &str) -> Result<Self, RuntimeError> {
        Ok(Self {
            features: vservo_protocol::subscriber(node, instance, Topic::Features)?,
            features_listener: vservo_protocol::listener(node, instance, Topic::Features)?,
            twists: vservo_protocol::publisher(node, instance, Topic::CameraTwist)?,
            gains: vservo_protocol::subscriber(node, instance, Topic::Gains)?,
            cell_mode: CellModeFollower::open(node, instance, NodeRole::Servo)?,
        })
    }

    /// Sends `message` with the servo's seal.
    fn send(&self, mut message: CameraTwistMsg, key: Option<&vservo_protocol::seal::SealKey>) {
        sign_with(key, &mut message);
        if let Ok(sample) = self.twists.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
    }
}

/// The servo between frames: its stage, the gains in use, and what it last did.
struct Servo {
    stage: ServoStage,
    gains_version: u64,
    /// What the gains in use came with; none taken yet.
    gains_issue: Option<Issue>,
    period_ns: u64,
    /// The pipeline's delay the law predicts through (whole vision periods).
    delay_frames: u64,
    /// The last frame answered: its number and capture tick.
    last: (u64, u64),
    /// (verdict, missing marks) of the last frame, for one log line per change of what the servo does.
    doing: (Verdict, u8),
    /// The cell moves its joints (`cell_mode` moving): held, and saying so.
    moving: bool,
    /// The vision node's features, admitted (sealed, its run's, fresh and later than the last taken).
    features: SealedStream,
    /// A foreign feature vector held the arm (one zero twist sent) since the last one taken.
    held_for_foreign: bool,
}

impl Servo {
    fn new(context: &NodeContext) -> Self {
        Self {
            stage: context.cell.servo(),
            // none taken yet: the version is the one the daemon's gains message names (its history hands the
            // design in force to a servo that starts or restarts), never assumed
            gains_version: 0,
            gains_issue: None,
            period_ns: vservo_time::nanos(context.cell.config().timing.vision_period_s),
            delay_frames: context.cell.config().timing.pipeline_delay_frames as u64,
            last: (0, 0),
            doing: (Verdict::Waiting, 0),
            moving: false,
            features: SealedStream::new(vservo_time::nanos(context.cell.config().timing.vision_period_s)),
            held_for_foreign: false,
        }
    }

    /// Takes the daemon's designs that came, each judged (a refused one after a good one does not hide it): one
    /// sealed with the run's key and newer than the one in use is taken, another is refused and counted; it takes
    /// effect at a frame boundary, before the next feature vector.
    fn take_gains(&mut self, ports: &Ports, context: &NodeContext, counters: &Counters) {
        let refused = ports.gains.each_message(|message| self.take_design(&message, context, counters));
        (0..refused).for_each(|_| counters.rejected());
    }

    /// One design of the daemon's: taken when sealed and newer than the one in use.
    fn take_design(&mut self, message: &GainsMsg, context: &NodeContext, counters: &Counters) {
        let issue = Issue { stamp_ns: message.stamp_ns, counter: message.version };
        let standing = freshness::standing(self.gains_issue, issue, monotonic_ns());
        if standing == Standing::Same {
            return;
        }
        let sealed = sealed_by(context.seal_key.as_ref(), message);
        match law_gains(message).filter(|_| sealed && standing.is_newer()) {
            Some(gains) => {
                self.stage.set_gains(&gains);
                self.gains_version = message.version;
                self.gains_issue = Some(issue);
                counters.set_gains_version(self.gains_version);
            }
            None => counters.rejected(),
        }
    }

    /// The stage's answer to a feature vector: held in a safe stop, else the law's.
    fn answer(&mut self, message: &FeaturesMsg, mode: ModeInForce) -> ServoStep {
        self.moving = matches!(mode, ModeInForce::Moving { .. });
        let held = mode != ModeInForce::Servoing;
        let features = FeatureVector::from(message.features_px);
        let base_from_camera = pose_from_wire(&message.base_from_camera);
        let input = ServoInput {
            frame: message.frame,
            features: &features,
            holder_from_camera: base_from_camera.as_ref(),
            unseen_s: self.unseen_s(message.capture_stamp_ns),
        };
        if held { self.stage.held(input) } else { self.stage.step(Some(input)) }
    }

    /// How long since the capture at `capture_stamp_ns` beyond the pipeline's whole frames of delay (s): the
    /// camera's motion its image cannot show, which the law predicts for an arm that lags its twist. Capture
    /// stamps are on this machine's monotonic clock (docs/PROTOCOL.md).
    fn unseen_s(&self, capture_stamp_ns: u64) -> f64 {
        let since_capture_ns = monotonic_ns().saturating_sub(capture_stamp_ns);
        let pipeline_ns = self.period_ns * self.delay_frames;
        vservo_time::Nanos(since_capture_ns.saturating_sub(pipeline_ns)).seconds()
    }

    /// The twist message for a step of the stage on `message`'s frame.
    fn twist_message(&self, message: &FeaturesMsg, step: &ServoStep) -> CameraTwistMsg {
        // the law's flags with the law's twist only
        let law_flags = match step.verdict {
            ServoVerdict::Servoing | ServoVerdict::ServoingOnThree(_) => {
                law_flags_on_wire(self.stage.law_flags())
            }
            _ => 0,
        };
        CameraTwistMsg {
            schema: SCHEMA_VERSION,
            verdict: verdict_on_wire(step.verdict, self.moving).into(),
            frame: message.frame,
            capture_tick: message.capture_tick,
            gains_version: self.gains_version,
            stamp_ns: monotonic_ns(),
            twist: to_array(&step.twist),
            feature_error_px: step.error_px,
            missing_mask: u32::from(step.verdict.missing_mask()),
            law_flags,
            writer_pid: std::process::id(),
            reserved: 0,
            seal: 0,
        }
    }

    /// Says a change of what the servo does (after the twist is sent, and only when it changes).
    fn note_change(&mut self, step: &ServoStep, message: &FeaturesMsg, monitor: &LoopMonitor) {
        let now = (verdict_on_wire(step.verdict, self.moving), step.verdict.missing_mask());
        if now != self.doing {
            let mark_status = message.mark_status.map(|code| MarkStatus::try_from(code).ok());
            monitor.note(Note::ServoVerdict { before: self.doing, now, mark_status });
            self.doing = now;
        }
    }

    /// The zero twist marked STOPPING the servo leaves with (the rmrc ramps to rest on it at its
    /// acceleration limits).
    fn stopping_message(&self) -> CameraTwistMsg {
        self.zero_twist(Verdict::Stopping)
    }

    /// A zero twist with `verdict` (one that does not move the arm), for the last frame answered.
    fn zero_twist(&self, verdict: Verdict) -> CameraTwistMsg {
        CameraTwistMsg {
            schema: SCHEMA_VERSION,
            verdict: verdict.into(),
            frame: self.last.0,
            capture_tick: self.last.1,
            gains_version: self.gains_version,
            stamp_ns: monotonic_ns(),
            twist: to_array(&Twist::zeros()),
            feature_error_px: f64::NAN,
            missing_mask: 0,
            law_flags: 0,
            writer_pid: std::process::id(),
            reserved: 0,
            seal: 0,
        }
    }
}

/// Runs the servo until the stop flag is set; then sends one zero twist marked STOPPING.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Servo)?;
    let mut ports = Ports::open(&node, &context.instance)?;
    go_realtime(context, NodeRole::Servo);
    let counters = monitor.counters();
    let mut servo = Servo::new(context);
    counters.set_gains_version(servo.gains_version);
    // the daemon gone: stop, with a zero twist, so that the rmrc ramps the arm to rest
    while !context.stopping() && !context.orphaned() {
        let _ = ports.features_listener.timed_wait(|_| {}, IDLE_WAIT);
        let woke_at = monotonic_ns();
        servo.take_gains(&ports, context, counters);
        while let Some(taken) = ports.features.next_sent() {
            let key = context.seal_key.as_ref();
            // the mode first: it announces the vision node's process, whose features alone are taken
            let mode = ports.cell_mode.mode(key, counters);
            // the twist shaped to the share of the arm's limits the reference keeps now
            servo.stage.set_speed_scale(ports.cell_mode.speed_scale());
            // sealed, the vision node's of its run now, and fresh: a recording of sealed features played again
            // (from the vision node's slot taken while it restarts) is not the vision node's now
            let announced = ports.cell_mode.writer(NodeRole::Vision);
            let message = match servo.features.admit(taken, key, announced, monotonic_ns()) {
                Ok(message) => message,
                Err(not_taken) => {
                    counters.rejected();
                    // another process's features in the vision node's slot: the arm held at once (a zero
                    // twist), before the daemon's safe stop
                    if not_taken == NotTaken::Standing(Standing::Foreign) && !servo.held_for_foreign {
                        servo.held_for_foreign = true;
                        ports.send(servo.zero_twist(Verdict::SafeStop), key);
                    }
                    continue;
                }
            };
            servo.held_for_foreign = false;
            let step = servo.answer(&message, mode);
            // a mark outside the image is no measurement: taken as missing, the message counted refused
            if step.outside != 0 {
                counters.rejected();
            }
            let sent = servo.twist_message(&message, &step);
            ports.send(sent, context.seal_key.as_ref());
            servo.note_change(&step, &message, &monitor);
            servo.last = (message.frame, message.capture_tick);
            counters.set_progress(message.frame);
            counters.set_mode(sent.verdict);
            counters.set_feature_error_px(step.error_px);
            let done = monotonic_ns();
            if done.saturating_sub(message.stamp_ns) > servo.period_ns {
                counters.overrun();
            }
            monitor.record(CycleSample {
                wake_latency_ns: woke_at.saturating_sub(message.stamp_ns),
                execution_ns: done.saturating_sub(woke_at),
                capture_latency_ns: done.saturating_sub(message.capture_stamp_ns),
                ..CycleSample::default()
            });
        }
    }
    ports.send(servo.stopping_message(), context.seal_key.as_ref());
    tracing::info!(node = "servo", "stopped");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wire_verdict_moves_the_arm_exactly_when_the_stages_does() {
        let all = [
            ServoVerdict::Waiting,
            ServoVerdict::Servoing,
            ServoVerdict::ServoingOnThree(1),
            ServoVerdict::Reacquiring(3),
            ServoVerdict::MarksMissing(15),
            ServoVerdict::Held,
        ];
        for verdict in all {
            assert_eq!(verdict_on_wire(verdict, false).moves(), verdict.moves(), "{verdict:?}");
        }
        assert_eq!(verdict_on_wire(ServoVerdict::Held, false), Verdict::SafeStop);
        assert_eq!(verdict_on_wire(ServoVerdict::Held, true), Verdict::Moving);
    }

    #[test]
    fn each_law_flag_has_its_own_bit() {
        let none = LawFlags::default();
        assert_eq!(law_flags_on_wire(none), 0);
        assert_eq!(law_flags_on_wire(LawFlags { barrier: true, ..none }), law_flag::BARRIER);
        assert_eq!(law_flags_on_wire(LawFlags { feedforward: true, ..none }), law_flag::FEEDFORWARD);
        assert_eq!(law_flags_on_wire(LawFlags { rate_limited: true, ..none }), law_flag::RATE_LIMITED);
        let all =
            LawFlags { barrier: true, fixed_gain_fallback: true, feedforward: true, rate_limited: true };
        assert_eq!(
            law_flags_on_wire(all),
            law_flag::BARRIER
                | law_flag::FIXED_GAIN_FALLBACK
                | law_flag::FEEDFORWARD
                | law_flag::RATE_LIMITED
        );
    }
}
