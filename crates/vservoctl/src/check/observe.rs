//! What the preflight reads of a running instance: its joint states and frames over a window, the daemon's
//! state and the target in force. It only reads: nothing is published, so nothing moves.

use std::time::{Duration, Instant};

use vservo_arm::JointVector;
use vservo_protocol::{
    DaemonState, DaemonStatusMsg, Fault, FeaturesMsg, GainsMsg, JointStateMsg, TakeMessages, Topic,
};
use vservo_scene::FeatureVector;

use super::verdicts::{FrameSample, Observed, StateSample};
use crate::instance::{Connection, when_there};

/// How long the check waits for a service of a daemon that may still be starting.
const WAIT_FOR_SERVICES: Duration = Duration::from_secs(3);

/// Opens a subscriber, retrying while the daemon may still be making its services.
fn subscriber<T: std::fmt::Debug + iceoryx2::prelude::ZeroCopySend + 'static>(
    connection: &Connection,
    topic: Topic,
) -> anyhow::Result<iceoryx2::port::subscriber::Subscriber<iceoryx2::prelude::ipc::Service, T, ()>> {
    when_there(Some(Instant::now() + WAIT_FOR_SERVICES), || connection.subscriber::<T>(topic))
        .map_err(|error| error.context(format!("no {} service: is vservod running?", topic.name())))
}

/// Watches the instance for `window`.
pub fn watch(connection: &Connection, window: Duration, joint_count: usize) -> anyhow::Result<Observed> {
    let states = subscriber::<JointStateMsg>(connection, Topic::JointState)?;
    let features = subscriber::<FeaturesMsg>(connection, Topic::Features)?;
    let status = subscriber::<DaemonStatusMsg>(connection, Topic::Status)?;
    let gains = subscriber::<GainsMsg>(connection, Topic::Gains)?;
    let mut observed = Observed { window_s: window.as_secs_f64(), ..Observed::default() };
    let started = Instant::now();
    let mut refused = 0;
    while started.elapsed() < window {
        states.each_message(|state| observed.states.push(state_sample(&state, joint_count)));
        features.each_message(|frame| observed.frames.push(frame_sample(&frame)));
        if let Some(daemon) = status.newest_message(&mut refused) {
            let state = DaemonState::try_from(daemon.state).unwrap_or(DaemonState::Degraded);
            let fault = Fault::try_from(daemon.fault).unwrap_or(Fault::None);
            observed.daemon = Some((state, fault));
            observed.speed_scale = Some(daemon.speed_scale);
        }
        if let Some(gains) = gains.newest_message(&mut refused) {
            observed.desired_features = Some(FeatureVector::from(gains.desired_features_px));
        }
        std::thread::sleep(Duration::from_micros(200));
    }
    Ok(observed)
}

fn state_sample(state: &JointStateMsg, joint_count: usize) -> StateSample {
    let mut q = JointVector::zeros();
    for (j, value) in state.q_rad.iter().enumerate().take(joint_count.min(q.len())) {
        q[j] = *value;
    }
    StateSample {
        tick: state.tick,
        stamp_ns: state.stamp_ns,
        period_ns: state.period_ns,
        joint_count: state.joint_count,
        q,
    }
}

fn frame_sample(frame: &FeaturesMsg) -> FrameSample {
    FrameSample {
        capture_stamp_ns: frame.capture_stamp_ns,
        features: FeatureVector::from(frame.features_px),
        marks_found: frame.valid_mask.count_ones(),
        base_from_camera: vservo_scene::pose_rows::pose_from_rows(&frame.base_from_camera),
    }
}
