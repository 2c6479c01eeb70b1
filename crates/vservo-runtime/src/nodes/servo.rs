//! The servo node: wakes on each feature vector and answers with the camera twist.

use vservo_cell::{ServoInput, ServoVerdict};
use vservo_control::{LawFlags, Twist};
use vservo_protocol::{
    CameraTwistMsg, FeaturesMsg, GainsMsg, NodeRole, SCHEMA_VERSION, Topic, law_flag, verdict,
};
use vservo_scene::FeatureVector;

use super::{CellModeFollower, IDLE_WAIT, NodeBase, go_realtime, latest, start};
use crate::clock::monotonic_ns;
use crate::telemetry::{CycleSample, Note};
use crate::wire::to_array;
use crate::wire::{law_gains, pose_from_wire};
use crate::{NodeContext, RuntimeError, schema_ok};

/// RMS of ξ − ξ_d over the finite features (px); NaN when none is.
pub fn feature_error_px(features: &FeatureVector, desired: &FeatureVector) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (f, d) in features.iter().zip(desired.iter()) {
        if f.is_finite() {
            sum += (f - d) * (f - d);
            n += 1;
        }
    }
    if n == 0 { f64::NAN } else { (sum / n as f64).sqrt() }
}

/// The law's flags as `camera_twist.law_flags` bits.
fn law_flags_on_wire(flags: LawFlags) -> u32 {
    [
        (flags.barrier, law_flag::BARRIER),
        (flags.fixed_gain_fallback, law_flag::FIXED_GAIN_FALLBACK),
        (flags.feedforward, law_flag::FEEDFORWARD),
    ]
    .into_iter()
    .filter(|(set, _)| *set)
    .fold(0, |bits, (_, bit)| bits | bit)
}

/// Runs the servo until the stop flag is set; then sends one zero twist marked STOPPING.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let config = context.cell.config();
    let instance = &context.instance;
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Servo)?;
    let features_subscriber = vservo_protocol::subscriber::<FeaturesMsg>(&node, instance, Topic::Features)?;
    let features_listener = vservo_protocol::listener(&node, instance, Topic::Features)?;
    let twist_publisher = vservo_protocol::publisher::<CameraTwistMsg>(&node, instance, Topic::CameraTwist)?;
    // the daemon's latest design (history 1: a restarted servo takes it at once)
    let gains_subscriber = vservo_protocol::subscriber::<GainsMsg>(&node, instance, Topic::Gains)?;
    // the daemon's safe stop: zero twists until it resumes the cell
    let mut cell_mode = CellModeFollower::open(&node, instance)?;
    go_realtime(context, NodeRole::Servo);
    let mut stage = context.cell.servo();
    // none taken yet: the version is the one the daemon's gains message names (its history hands the
    // design in force to a servo that starts or restarts), never assumed
    let mut gains_version = 0;
    let counters = monitor.counters();
    counters.set_gains_version(gains_version);
    let period_ns = (config.timing.vision_period_s * 1e9).round() as u64;
    let send = |message: CameraTwistMsg| {
        if let Ok(sample) = twist_publisher.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
    };
    let mut last = (0u64, 0u64);
    // (verdict, missing marks) of the last frame, for one log line per change of what the servo does
    let mut doing = (verdict::WAITING, 0u32);

    // the daemon gone: stop, with a zero twist, so that the rmrc ramps the arm to rest
    while !context.stopping() && !context.orphaned() {
        let _ = features_listener.timed_wait(|_| {}, IDLE_WAIT);
        let woke_at = monotonic_ns();
        // new gains take effect at a frame boundary, before the next feature vector
        if let Some(message) = latest(&gains_subscriber, |m: &GainsMsg| m.schema, counters)
            && message.version != gains_version
        {
            // the daemon's design only: sealed with the run's key, and newer than the one in use
            let sealed = context.seal_key.is_some_and(|key| key.seal_gains(&message) == message.seal);
            match law_gains(&message).filter(|_| sealed && message.version > gains_version) {
                Some(gains) => {
                    stage.set_gains(&gains);
                    gains_version = message.version;
                    counters.set_gains_version(gains_version);
                }
                None => counters.rejected(),
            }
        }
        while let Ok(Some(sample)) = features_subscriber.receive() {
            let message = *sample;
            if !schema_ok(message.schema) {
                counters.rejected();
                continue;
            }
            // a mark outside the image is no measurement: taken as missing, the message counted refused
            let mut features = FeatureVector::from(message.features_px);
            let (width, height) = (f64::from(config.camera.width_px()), f64::from(config.camera.height_px()));
            let mut outside = false;
            for mark in 0..vservo_scene::MARKS {
                let (x, y) = (features[2 * mark], features[2 * mark + 1]);
                if x.is_finite()
                    && y.is_finite()
                    && !((0.0..=width).contains(&x) && (0.0..=height).contains(&y))
                {
                    features[2 * mark] = f64::NAN;
                    features[2 * mark + 1] = f64::NAN;
                    outside = true;
                }
            }
            if outside {
                counters.rejected();
            }
            let error_px = feature_error_px(&features, stage.desired_features());
            let (twist, verdict_code, missing_mask, flags) = if cell_mode
                .safe_stop(context.seal_key.as_ref(), counters)
            {
                (stage.hold(), verdict::SAFE_STOP, 0, 0)
            } else {
                let base_from_camera = pose_from_wire(&message.base_from_camera);
                let input = ServoInput {
                    frame: message.frame,
                    features: &features,
                    base_from_camera: base_from_camera.as_ref(),
                };
                let (twist, verdict) = stage.step(Some(input));
                let flags = law_flags_on_wire(stage.law_flags());
                match verdict {
                    ServoVerdict::Waiting => (twist, verdict::WAITING, 0, 0),
                    ServoVerdict::Servoing => (twist, verdict::SERVOING, 0, flags),
                    ServoVerdict::ServoingOnThree(mask) => {
                        (twist, verdict::SERVOING_ON_THREE, u32::from(mask), flags)
                    }
                    ServoVerdict::Reacquiring(mask) => (twist, verdict::REACQUIRING, u32::from(mask), 0),
                    ServoVerdict::MarksMissing(mask) => (twist, verdict::MARKS_MISSING, u32::from(mask), 0),
                }
            };
            send(CameraTwistMsg {
                schema: SCHEMA_VERSION,
                verdict: verdict_code,
                frame: message.frame,
                capture_tick: message.capture_tick,
                gains_version,
                stamp_ns: monotonic_ns(),
                twist: to_array(&twist),
                feature_error_px: error_px,
                missing_mask,
                law_flags: flags,
            });
            // said after the twist is sent, and only when it changes
            if (verdict_code, missing_mask) != doing {
                monitor.note(Note::ServoVerdict {
                    before: doing,
                    now: (verdict_code, missing_mask),
                    mark_status: message.mark_status,
                });
                doing = (verdict_code, missing_mask);
            }
            last = (message.frame, message.capture_tick);
            counters.set_progress(message.frame);
            counters.set_mode(verdict_code);
            counters.set_feature_error_px(error_px);
            let done = monotonic_ns();
            if done.saturating_sub(message.stamp_ns) > period_ns {
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
    // the rmrc ramps to rest on a zero twist at its acceleration limits
    send(CameraTwistMsg {
        schema: SCHEMA_VERSION,
        verdict: verdict::STOPPING,
        frame: last.0,
        capture_tick: last.1,
        gains_version,
        stamp_ns: monotonic_ns(),
        twist: to_array(&Twist::zeros()),
        feature_error_px: f64::NAN,
        missing_mask: 0,
        law_flags: 0,
    });
    tracing::info!(node = "servo", "stopped: zero twist sent");
    Ok(())
}
