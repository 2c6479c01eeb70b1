//! The vision node. With the simulated camera it runs on the simulation's time (an image every vision
//! period of plant ticks), renders the board from that tick's joint state and the simulation's `sim_world`,
//! and publishes each image on
//! `camera_image` (so every user can see what the extractor saw). With an external camera it wakes on each
//! frame a camera driver publishes on `camera_image`, works on it at once and stamps the features with the
//! frame's capture time and the camera's pose at that time (the joint states around it, kept in a
//! [`JointHistory`]): the camera paces the loop. A frame older than one vision period on arrival is
//! dropped and counted (it would steer the arm by where it was).

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::ipc;
use nalgebra::IsometryMatrix3;
use vservo_arm::JointVector;
use vservo_cell::{DeliveredFrame, VisionStage};
use vservo_protocol::TakeMessages;
use vservo_protocol::{
    CameraImageHeader, FeaturesMsg, JointStateMsg, MARKS, MarkStatus as WireMarkStatus, NodeRole,
    PixelFormat, SCHEMA_VERSION, SimWorldMsg, Topic,
};
use vservo_vision::GrayImage;
use vservo_vision::{Extraction, MarkStatus};

use super::{IDLE_WAIT, NodeBase, go_realtime, latest, start};
use crate::joint_history::{JointHistory, NoJoints};
use crate::telemetry::{Counters, CycleSample, LoopMonitor, Note};
use crate::wire::{joints_from_wire, pose_from_wire, pose_to_wire, to_array};
use crate::{NodeContext, RuntimeError};
use vservo_time::monotonic_ns;

/// How often, at the least, an external camera's vision node takes in the joint states heard: 32 driver
/// periods (the joint_state queue holds 64 states), and at most this.
const LONGEST_DRAIN_WAIT_S: f64 = 0.02;

// the configuration refuses a camera whose image is larger than one camera_image sample: the same number
const _: () = assert!(vservo_config::MAX_CAMERA_IMAGE_BYTES == vservo_protocol::MAX_IMAGE_BYTES);

/// The extractor's status of a mark as the wire says it (`features.mark_status`).
fn status_on_wire(status: &MarkStatus) -> WireMarkStatus {
    match status {
        MarkStatus::Valid => WireMarkStatus::Valid,
        MarkStatus::OutsideImage => WireMarkStatus::OutsideImage,
        MarkStatus::CutByBorder => WireMarkStatus::CutByBorder,
        MarkStatus::MergedWith(_) => WireMarkStatus::Merged,
        MarkStatus::Irregular => WireMarkStatus::Irregular,
        MarkStatus::NotFound => WireMarkStatus::NotFound,
        MarkStatus::Ambiguous => WireMarkStatus::Ambiguous,
        MarkStatus::BadImage(_) => WireMarkStatus::BadImage,
    }
}

/// How a frame's marks were measured, as `features` carries it.
#[derive(Debug, Clone, Copy)]
struct Measured {
    refined: [bool; MARKS],
    edge_rms_px: [f64; MARKS],
    decision_margin: f64,
    bits_corrected: u16,
    tags_used_mask: u16,
}

impl Measured {
    /// Nothing known (a frame whose slot a later one took, or none yet).
    const UNKNOWN: Self = Self {
        refined: [false; MARKS],
        edge_rms_px: [f64::NAN; MARKS],
        decision_margin: f64::NAN,
        bits_corrected: 0,
        tags_used_mask: 0,
    };

    fn of(captured: &Extraction) -> Self {
        let tag = captured.tag_quality.as_ref();
        Self {
            refined: captured.refined(),
            edge_rms_px: tag.map_or([f64::NAN; MARKS], |q| q.edge_rms_px),
            decision_margin: tag.map_or(f64::NAN, |q| f64::from(q.decision_margin)),
            bits_corrected: tag.map_or(0, |q| u16::from(q.bits_corrected)),
            tags_used_mask: tag.map_or(0, |q| u16::from(q.tags_used)),
        }
    }
}

/// What the pipeline remembers of a frame until it leaves: capture time, mark status and how the marks were
/// measured.
#[derive(Debug, Clone, Copy)]
struct FrameInfo {
    frame: u64,
    capture_stamp_ns: u64,
    status: [WireMarkStatus; MARKS],
    measured: Measured,
}

impl Default for FrameInfo {
    fn default() -> Self {
        let measured = Measured::UNKNOWN;
        Self { frame: 0, capture_stamp_ns: 0, status: [WireMarkStatus::Valid; MARKS], measured }
    }
}

/// The frames in the pipeline (at most MAX_DELAY_FRAMES + 1) and the port their features leave by.
struct FeaturesOut {
    in_pipeline: [FrameInfo; 8],
    /// Whether the last frame had blobs of a mark's size beyond the extractor's cap.
    over_cap: bool,
    publisher: Publisher<ipc::Service, FeaturesMsg, ()>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    /// The run's key: the features leave sealed with it.
    key: Option<vservo_protocol::seal::SealKey>,
}

impl FeaturesOut {
    /// Keeps a frame's capture time and mark status until its features leave; says when the extractor
    /// starts finding more blobs of a mark's size than it considers.
    fn remember(&mut self, frame: u64, capture_stamp_ns: u64, captured: &Extraction, monitor: &LoopMonitor) {
        self.in_pipeline[(frame % 8) as usize] = FrameInfo {
            frame,
            capture_stamp_ns,
            status: captured.status.map(|s| status_on_wire(&s)),
            measured: Measured::of(captured),
        };
        let over_cap = captured.sized_blobs_over_cap;
        if over_cap > 0 && !self.over_cap {
            monitor.note(Note::BlobsOverCap { frame, over_cap });
        }
        self.over_cap = over_cap > 0;
    }

    fn publish(&self, delivered: &DeliveredFrame) {
        let info = self.in_pipeline[(delivered.frame % 8) as usize];
        let mut status = info.status;
        let mut valid_mask = 0u32;
        for (mark, mark_status) in status.iter_mut().enumerate() {
            let undistorted =
                delivered.features[2 * mark].is_finite() && delivered.features[2 * mark + 1].is_finite();
            // found in the image, but where the lens has no undistorted position: outside its usable part
            if *mark_status == WireMarkStatus::Valid && !undistorted {
                *mark_status = WireMarkStatus::OutsideImage;
            }
            if *mark_status == WireMarkStatus::Valid && info.frame == delivered.frame {
                valid_mask |= 1 << mark;
            }
        }
        // a frame whose slot was taken by a later one: nothing of it is known
        let measured = if info.frame == delivered.frame { info.measured } else { Measured::UNKNOWN };
        let mut message = FeaturesMsg {
            schema: SCHEMA_VERSION,
            valid_mask,
            frame: delivered.frame,
            capture_tick: delivered.capture_tick,
            capture_stamp_ns: info.capture_stamp_ns,
            stamp_ns: monotonic_ns(),
            features_px: to_array(&delivered.features),
            mark_status: status.map(u8::from),
            writer_pid: std::process::id(),
            base_from_camera: delivered.holder_from_camera.as_ref().map_or([f64::NAN; 12], pose_to_wire),
            edge_rms_px: measured.edge_rms_px,
            decision_margin: measured.decision_margin,
            refined_mask: (0..MARKS).filter(|&m| measured.refined[m]).fold(0, |mask, m| mask | 1 << m)
                & valid_mask,
            bits_corrected: measured.bits_corrected,
            tags_used_mask: measured.tags_used_mask,
            seal: 0,
        };
        vservo_protocol::seal::sign_with(self.key.as_ref(), &mut message);
        if let Ok(sample) = self.publisher.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
        let _ = self.notifier.notify();
    }
}

/// The time since the previous capture (ns), 0 for the first; `previous` becomes `capture_ns`.
fn frame_period_ns(previous: &mut u64, capture_ns: u64) -> u64 {
    let period = if *previous > 0 { capture_ns.saturating_sub(*previous) } else { 0 };
    *previous = capture_ns;
    period
}

/// Runs the vision node until the stop flag is set.
pub fn run(context: &NodeContext) -> Result<(), RuntimeError> {
    let instance = &context.instance;
    let NodeBase { _telemetry, monitor, node } = start(context, NodeRole::Vision)?;
    let state_subscriber = vservo_protocol::subscriber::<JointStateMsg>(&node, instance, Topic::JointState)?;
    let mut out = FeaturesOut {
        in_pipeline: [FrameInfo::default(); 8],
        over_cap: false,
        publisher: vservo_protocol::publisher::<FeaturesMsg>(&node, instance, Topic::Features)?,
        notifier: vservo_protocol::notifier(&node, instance, Topic::Features)?,
        key: context.seal_key.clone(),
    };
    let mut stage = context.cell.vision();
    if let Some(features) = &context.resume_features {
        stage.resume_tracking(features);
        tracing::info!(node = "vision", "tracking the marks from where they were last seen");
    }
    // the daemon refuses recorded images (open-loop checks are `vservoctl vision extract`'s)
    if context.cell.config().vision.source.from_camera_driver() {
        run_external_camera(context, &node, &monitor, &state_subscriber, &mut stage, &mut out)?;
    } else {
        run_simulated_camera(context, &node, &monitor, &state_subscriber, &mut stage, &mut out)?;
    }
    tracing::info!(node = "vision", "stopped");
    Ok(())
}

/// An external camera's frames as the vision node takes them: the image buffer, the joint states heard (to
/// place the camera at each exposure), and what it has said.
struct ExternalCamera {
    image: GrayImage,
    /// The camera's pose is the arm's at the frame's exposure: the joint states heard are kept (two vision
    /// periods of them, more than a frame may be late).
    joints: JointHistory,
    /// An image older than a vision period on arrival would steer the arm by where it was: dropped.
    stale_after_ns: u64,
    said_unplaced: bool,
    previous_capture_ns: u64,
}

impl ExternalCamera {
    fn new(context: &NodeContext) -> Self {
        let config = context.cell.config();
        Self {
            image: GrayImage::new(config.camera.width_px(), config.camera.height_px()),
            joints: JointHistory::new(config.robot.period_s, 2.0 * config.timing.vision_period_s),
            stale_after_ns: vservo_time::nanos(config.timing.vision_period_s),
            said_unplaced: false,
            previous_capture_ns: 0,
        }
    }

    /// The tick and the joints at a frame's exposure (the newest tick and none if the joint states heard do
    /// not place it; said once, and not for the frames that come before the history has filled — a node
    /// that has just started —: then a camera's stamps do not match the robot's clock).
    fn at_exposure(
        &mut self,
        header: &CameraImageHeader,
        monitor: &LoopMonitor,
    ) -> (u64, Option<JointVector>) {
        match self.joints.at(header.capture_stamp_ns) {
            Ok(at) => (at.tick, Some(at.q)),
            Err(why) => {
                let filled = self.joints.span_ns() >= self.stale_after_ns;
                if !self.said_unplaced && (filled || why == NoJoints::AfterNewest) {
                    monitor.note(Note::FrameWithoutPose {
                        frame: header.frame,
                        capture_stamp_ns: header.capture_stamp_ns,
                        why,
                    });
                    self.said_unplaced = true;
                }
                (self.joints.newest_tick().unwrap_or(0), None)
            }
        }
    }
}

/// An external camera paces the loop: each frame it publishes is extracted as it arrives and its features
/// published at once, stamped with its capture time and the camera's pose then. The joint states are
/// drained often enough that none is lost (the joint_state queue holds 64 states).
fn run_external_camera(
    context: &NodeContext,
    node: &iceoryx2::prelude::Node<ipc::Service>,
    monitor: &LoopMonitor,
    state_subscriber: &iceoryx2::port::subscriber::Subscriber<ipc::Service, JointStateMsg, ()>,
    stage: &mut VisionStage,
    out: &mut FeaturesOut,
) -> Result<(), RuntimeError> {
    let instance = &context.instance;
    let images =
        vservo_protocol::camera_image_subscriber(node, instance, vservo_protocol::Opening::OpenOrCreate)?;
    let listener = vservo_protocol::camera_image_listener(node, instance)?;
    go_realtime(context, NodeRole::Vision);
    let counters = monitor.counters();
    let mut camera = ExternalCamera::new(context);
    let joint_count = context.cell.arm().joint_count();
    let driver_period_s = context.cell.config().robot.period_s;
    let drain_wait = std::time::Duration::from_secs_f64((32.0 * driver_period_s).min(LONGEST_DRAIN_WAIT_S));
    while !context.stopping() && !context.orphaned() {
        let _ = listener.timed_wait(|_| {}, drain_wait);
        hear_joints(state_subscriber, &mut camera.joints, joint_count, counters);
        while let Ok(Some(sample)) = images.receive() {
            let woke_at = monotonic_ns();
            let header = *sample.user_header();
            let stale = woke_at.saturating_sub(header.capture_stamp_ns) > camera.stale_after_ns;
            if stale || !copy_image(&header, sample.payload(), &mut camera.image) {
                counters.rejected();
                continue;
            }
            drop(sample);
            hear_joints(state_subscriber, &mut camera.joints, joint_count, counters);
            let (tick, q) = camera.at_exposure(&header, monitor);
            let (captured, delivered) = stage.process_image(header.frame, tick, q.as_ref(), &camera.image);
            out.remember(header.frame, header.capture_stamp_ns, &captured, monitor);
            if let Some(delivered) = delivered {
                out.publish(&delivered);
            }
            counters.set_progress(header.frame);
            monitor.record(CycleSample {
                wake_latency_ns: woke_at.saturating_sub(header.capture_stamp_ns),
                execution_ns: monotonic_ns().saturating_sub(woke_at),
                frame_period_ns: frame_period_ns(&mut camera.previous_capture_ns, header.capture_stamp_ns),
                ..CycleSample::default()
            });
        }
    }
    Ok(())
}

/// Takes the joint states waiting into the history (others' schemas, and another arm's joint count, refused
/// and counted).
fn hear_joints(
    subscriber: &iceoryx2::port::subscriber::Subscriber<ipc::Service, JointStateMsg, ()>,
    joints: &mut JointHistory,
    joint_count: usize,
    counters: &Counters,
) {
    while let Some(taken) = subscriber.next_message() {
        match taken {
            Ok(state) => match state.arm_q_rad(joint_count) {
                Some(q) => joints.push(state.stamp_ns, state.tick, state.driver_epoch, &JointVector::from(q)),
                None => counters.rejected(),
            },
            Err(_) => counters.rejected(),
        }
    }
}

/// Copies a `camera_image` sample into `image` if it is of this build's schema, 8-bit gray, of the
/// configured size and complete.
fn copy_image(header: &CameraImageHeader, payload: &[u8], image: &mut GrayImage) -> bool {
    let (width, height) = image.dimensions();
    let stride = header.stride_bytes as usize;
    let needed = stride.saturating_mul(height.saturating_sub(1) as usize).saturating_add(width as usize);
    let fits = vservo_protocol::inbox::accept(*header).is_ok()
        && PixelFormat::try_from(header.format) == Ok(PixelFormat::Mono8)
        && (header.width, header.height) == (width, height)
        && stride >= width as usize
        && payload.len() >= needed;
    if !fits {
        return false;
    }
    let w = width as usize;
    for (row, pixels) in image.chunks_exact_mut(w).enumerate() {
        pixels.copy_from_slice(&payload[row * stride..row * stride + w]);
    }
    true
}

/// When the simulated camera takes its images: the tick of the next one (the first joint state heard,
/// then every `ticks_per_frame` ticks).
struct CaptureTicks {
    ticks_per_frame: u64,
    next_tick: Option<u64>,
}

impl CaptureTicks {
    /// Drains the joint states waiting (others' schemas refused and counted): the state of the capture tick,
    /// or the first after it had this node been late (the ticks skipped counted), if it has come. A
    /// restarted plant starts again at rest where the arm was: capture from its first state.
    fn due(
        &mut self,
        subscriber: &iceoryx2::port::subscriber::Subscriber<ipc::Service, JointStateMsg, ()>,
        counters: &Counters,
    ) -> Option<JointStateMsg> {
        let mut due = None;
        while let Some(taken) = subscriber.next_message() {
            let Ok(state) = taken else {
                counters.rejected();
                continue;
            };
            let wanted = *self.next_tick.get_or_insert(state.tick);
            if state.tick + self.ticks_per_frame < wanted {
                self.next_tick = Some(state.tick);
            }
            if due.is_none() && state.tick >= self.next_tick.unwrap_or(state.tick) {
                due = Some(state);
            }
        }
        due
    }

    /// The image of `state` is taken: the next one is a vision period of ticks later. A state later than the
    /// one wanted (this node woke after the capture tick's state was gone) is counted as an overrun.
    fn taken(&mut self, state: &JointStateMsg, counters: &Counters) {
        if let Some(wanted) = self.next_tick
            && state.tick > wanted
        {
            counters.overrun();
            counters.skipped((state.tick - wanted) / self.ticks_per_frame);
        }
        self.next_tick = Some(state.tick + self.ticks_per_frame);
    }
}

/// The simulated camera runs on the simulation's time, as the lockstep simulator does: it wakes on each
/// joint state and takes an image every `control_ticks_per_frame` plant ticks (the vision period of
/// simulated time), of the state of exactly that tick. A plant that falls behind the wall clock (skipped
/// periods on a loaded machine) then delays the camera with it instead of changing what it samples. At
/// each capture it first publishes the frame whose processing finished (so the processing time does not add
/// to the pipeline delay), then renders and extracts the new one, and publishes its image on `camera_image`.
fn run_simulated_camera(
    context: &NodeContext,
    node: &iceoryx2::prelude::Node<ipc::Service>,
    monitor: &LoopMonitor,
    state_subscriber: &iceoryx2::port::subscriber::Subscriber<ipc::Service, JointStateMsg, ()>,
    stage: &mut VisionStage,
    out: &mut FeaturesOut,
) -> Result<(), RuntimeError> {
    let instance = &context.instance;
    let state_listener = vservo_protocol::listener(node, instance, Topic::JointState)?;
    let world_subscriber = vservo_protocol::subscriber::<SimWorldMsg>(node, instance, Topic::SimWorld)?;
    let image_publisher = vservo_protocol::camera_image_publisher(node, instance)?;
    let image_notifier = vservo_protocol::camera_image_notifier(node, instance)?;
    go_realtime(context, NodeRole::Vision);
    let counters: &Counters = monitor.counters();
    let ticks_per_frame = u64::from(context.cell.config().timing.control_ticks_per_frame);
    let mut capture = CaptureTicks { ticks_per_frame, next_tick: None };
    let (mut frame, mut previous_capture_ns) = (0u64, 0);
    // the simulated plant moves the board (sim_world); an external simulated arm (franka-sim) has none, and the
    // board stands where the configuration places it (a fixed camera's rides on the tool: the stage puts it
    // where the captured joints do)
    let config = context.cell.config();
    // the simulated camera's exposure, as a camera reports it (its gain is not modelled)
    let simulated_exposure =
        vservo_protocol::Exposure { exposure_us: config.vision.render.exposure_s * 1e6, gain_db: f64::NAN };
    let mut world: Option<IsometryMatrix3<f64>> =
        (!config.robot.driver.is_simulated()).then(|| config.base_from_board(context.cell.arm()));
    while !context.stopping() && !context.orphaned() {
        let _ = state_listener.timed_wait(|_| {}, IDLE_WAIT);
        let woke_at = monotonic_ns();
        if let Some(newest) = latest(&world_subscriber, counters) {
            world = pose_from_wire(&newest.base_from_board);
            if world.is_none() {
                counters.rejected();
            }
        }
        // no plant yet (or a restart under way), or not yet the capture tick: no image to take
        let (Some(state), Some(base_from_board)) = (capture.due(state_subscriber, counters), world) else {
            continue;
        };
        capture.taken(&state, counters);
        // the frame processed during the last period leaves the pipeline now, before the new image is taken
        if let Some(delivered) = stage.take_delivered() {
            out.publish(&delivered);
        }
        let q = joints_from_wire(&state.q_rad, crate::wire::wire_joint_count(context.cell.arm()));
        let Some(base_from_board) = Some(base_from_board).filter(|_| q.iter().all(|v| v.is_finite())) else {
            counters.rejected();
            continue;
        };
        let started = monotonic_ns();
        let taken = stage.capture(frame, state.tick, &q, &base_from_board);
        out.remember(frame, state.stamp_ns, &taken.captured, monitor);
        // with no pipeline delay the new frame leaves at once
        if let Some(delivered) = taken.delivered {
            out.publish(&delivered);
        }
        publish_image(&image_publisher, stage.image(), (frame, state.stamp_ns), simulated_exposure);
        let _ = image_notifier.notify();
        frame += 1;
        counters.set_progress(frame);
        monitor.record(CycleSample {
            wake_latency_ns: woke_at.saturating_sub(state.stamp_ns),
            execution_ns: monotonic_ns().saturating_sub(started),
            frame_period_ns: frame_period_ns(&mut previous_capture_ns, state.stamp_ns),
            ..CycleSample::default()
        });
    }
    Ok(())
}

/// Publishes an image on `camera_image` as frame `frame` exposed at `capture_stamp_ns` (one copy into shared
/// memory; subscribers read it in place).
pub fn publish_image(
    publisher: &Publisher<ipc::Service, [u8], CameraImageHeader>,
    image: &GrayImage,
    (frame, capture_stamp_ns): (u64, u64),
    exposure: vservo_protocol::Exposure,
) {
    let _ = vservo_protocol::publish_mono8(
        publisher,
        image.dimensions(),
        image.as_raw(),
        (frame, capture_stamp_ns),
        exposure,
    );
}
