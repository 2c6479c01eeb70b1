//! The vision node: on its own vision-period timer, images the board from the latest joint state.

use vservo_arm::JointVector;
use vservo_cell::DeliveredFrame;
use vservo_protocol::{FeaturesMsg, JointStateMsg, MARKS, NodeRole, SCHEMA_VERSION, Topic, mark_status};
use vservo_vision::MarkStatus;

use super::{NodeBase, go_realtime, latest, start};
use crate::clock::{PeriodicTimer, monotonic_ns};
use crate::telemetry::CycleSample;
use crate::wire::{pose_from_wire, to_array};
use crate::{NodeContext, RuntimeError};

fn status_code(status: &MarkStatus) -> u8 {
    match status {
        MarkStatus::Valid => mark_status::VALID,
        MarkStatus::OutsideImage => mark_status::OUTSIDE_IMAGE,
        MarkStatus::CutByBorder => mark_status::CUT_BY_BORDER,
        MarkStatus::MergedWith(_) => mark_status::MERGED,
        MarkStatus::Irregular => mark_status::IRREGULAR,
        MarkStatus::NotFound => mark_status::NOT_FOUND,
        MarkStatus::BadImage(_) => mark_status::BAD_IMAGE,
    }
}

/// What the pipeline remembers of a frame until it leaves: capture time and mark status.
#[derive(Debug, Clone, Copy, Default)]
struct FrameInfo {
    frame: u64,
    capture_stamp_ns: u64,
    status: [u8; MARKS],
}

/// Runs the vision node until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let config = context.cell.config();
    let instance = &context.instance;
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Vision)?;
    let state_subscriber = vservo_protocol::subscriber::<JointStateMsg>(&node, instance, Topic::JointState)?;
    let features_publisher = vservo_protocol::publisher::<FeaturesMsg>(&node, instance, Topic::Features)?;
    let features_notifier = vservo_protocol::notifier(&node, instance, Topic::Features)?;
    go_realtime(context, NodeRole::Vision);
    let mut stage = context.cell.vision();
    if let Some(features) = &context.resume_features {
        stage.resume_tracking(features);
        tracing::info!(node = "vision", "tracking the marks from where they were last seen");
    }
    let counters = monitor.counters();
    let period_ns = (config.timing.vision_period_s * 1e9).round() as u64;
    // the pipeline holds at most MAX_DELAY_FRAMES + 1 frames
    let mut frames_in_pipeline = [FrameInfo::default(); 8];
    let mut frame: u64 = 0;
    let publish = |delivered: &DeliveredFrame, frames_in_pipeline: &[FrameInfo; 8]| {
        let info = frames_in_pipeline[(delivered.frame % 8) as usize];
        let mut valid_mask = 0u32;
        for mark in 0..MARKS {
            if info.status[mark] == mark_status::VALID && info.frame == delivered.frame {
                valid_mask |= 1 << mark;
            }
        }
        let message = FeaturesMsg {
            schema: SCHEMA_VERSION,
            valid_mask,
            frame: delivered.frame,
            capture_tick: delivered.capture_tick,
            capture_stamp_ns: info.capture_stamp_ns,
            stamp_ns: monotonic_ns(),
            features_px: to_array(&delivered.features),
            mark_status: info.status,
            reserved: [0; 4],
        };
        if let Ok(sample) = features_publisher.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
        let _ = features_notifier.notify();
    };
    let mut timer = PeriodicTimer::start(period_ns);

    while !context.stopping() {
        let wake = timer.wait();
        let started = monotonic_ns();
        if wake.skipped_periods > 0 {
            counters.overrun();
            counters.skipped(wake.skipped_periods);
        }
        // the frame processed during the last period leaves the pipeline now, before the new image is taken
        if let Some(delivered) = stage.take_delivered() {
            publish(&delivered, &frames_in_pipeline);
        }
        let latest = latest(&state_subscriber, |m: &JointStateMsg| m.schema, counters);
        // no plant yet (or a restart under way): no image to take
        let Some(state) = latest else { continue };
        let q = JointVector::from(state.q_rad);
        let Some(base_from_board) =
            pose_from_wire(&state.base_from_board).filter(|_| q.iter().all(|v| v.is_finite()))
        else {
            counters.rejected();
            continue;
        };
        let taken = stage.capture(frame, state.tick, &q, &base_from_board);
        frames_in_pipeline[(frame % 8) as usize] = FrameInfo {
            frame,
            capture_stamp_ns: started,
            status: taken.captured.status.map(|s| status_code(&s)),
        };
        frame += 1;
        // with no pipeline delay the new frame leaves at once
        if let Some(delivered) = taken.delivered {
            publish(&delivered, &frames_in_pipeline);
        }
        counters.set_progress(frame);
        monitor.record(CycleSample {
            wake_latency_ns: wake.lateness_ns,
            execution_ns: monotonic_ns().saturating_sub(started),
            round_trip_ns: 0,
        });
    }
    tracing::info!(node = "vision", "stopped");
    Ok(())
}
