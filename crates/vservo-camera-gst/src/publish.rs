//! The driver's loop: the pipeline's frames, checked, counted and stamped, onto `camera_image`.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::Context;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::ipc;
use vservo_camera_gst::frames::FrameCounter;
use vservo_camera_gst::stamp::{self, StampSource};
use vservo_protocol::CameraImageHeader;
use vservo_time::monotonic_ns;

use crate::pipeline::{self, Camera, Frame, PipelineError};

/// How long one wait for a frame lasts before the stop flag and the stall rule are looked at (ms).
const POLL_MS: u64 = 20;

/// Runs the configured pipeline and publishes its frames until `stop`.
pub fn run(config_path: &Path, stats_every_s: f64, stop: &AtomicBool) -> anyhow::Result<()> {
    let config = vservo_config::Config::load(config_path)?;
    let settings = config.gstreamer.clone().with_context(|| {
        format!("{}: no [camera.gstreamer] section (its pipeline is what this driver runs)", config.origin)
    })?;
    let (width, height) = (config.cell.camera.width_px(), config.cell.camera.height_px());
    let camera = Camera::build(&settings)?;
    camera.play()?;
    tracing::info!(
        "pipeline {:?} playing on the monotonic system clock (clock − CLOCK_MONOTONIC = {} ns)",
        camera.text,
        camera.clock_minus_monotonic_ns()
    );
    let mut watch = Watch::new(config.cell.timing.vision_period_s, settings.stall_periods, stats_every_s);
    let Some(first) = first_frame(&camera, &mut watch, stop)? else { return Ok(()) };
    let negotiated = pipeline::negotiated(&first.sample);
    vservo_camera_gst::caps::check(&negotiated, width, height)
        .map_err(|e| PipelineError::Caps { pipeline: camera.text.clone(), reason: e.to_string() })?;
    tracing::info!("frames: {}", negotiated.caps);
    let Some(out) = Output::connect(&config.instance, stop)? else { return Ok(()) };
    let period_ns = match pipeline::caps_frame_period_ns(&first.sample) {
        0 => vservo_time::nanos(config.cell.timing.vision_period_s),
        caps_period => caps_period,
    };
    let mut publishing = Publishing {
        out,
        counter: FrameCounter::default(),
        image: vec![0; width as usize * height as usize],
        width,
        height,
        period_ns,
    };
    let mut next = Some(first);
    while !stop.load(Ordering::Relaxed) {
        if let Some(frame) = next.take() {
            publishing.publish(&camera, &frame, &mut watch);
        }
        next = camera.next_frame(POLL_MS)?;
        watch.look(monotonic_ns(), &camera.text, &publishing.counter);
    }
    watch.report(&publishing.counter, "stopped (SIGINT/SIGTERM)");
    Ok(())
}

/// The first frame (None: stopped before it came).
fn first_frame(camera: &Camera, watch: &mut Watch, stop: &AtomicBool) -> anyhow::Result<Option<Frame>> {
    while !stop.load(Ordering::Relaxed) {
        if let Some(frame) = camera.next_frame(POLL_MS)? {
            return Ok(Some(frame));
        }
        watch.look(monotonic_ns(), &camera.text, &FrameCounter::default());
    }
    Ok(None)
}

/// The `camera_image` ports: the one publisher and notifier slot of the instance's camera stream.
struct Output {
    _node: iceoryx2::node::Node<ipc::Service>,
    publisher: Publisher<ipc::Service, [u8], CameraImageHeader>,
    notifier: Notifier<ipc::Service>,
}

impl Output {
    /// Waits for the instance's runtime directory (vservod makes it), then takes the slot.
    fn connect(instance: &str, stop: &AtomicBool) -> anyhow::Result<Option<Output>> {
        let stopped = || stop.load(Ordering::Relaxed);
        let waiting = |why: &_| tracing::info!("instance {instance:?}: {why}; waiting for vservod");
        let Some(dir) = vservo_protocol::InstanceDir::locate_until(instance, stopped, waiting)? else {
            return Ok(None);
        };
        let node = vservo_protocol::create_node_in(&dir, "gst-camera")?;
        let publisher = vservo_protocol::camera_image_publisher(&node, instance)
            .with_context(|| format!("the camera_image stream of instance {instance:?}"))?;
        let notifier = vservo_protocol::camera_image_notifier(&node, instance)
            .with_context(|| format!("the camera_image event of instance {instance:?}"))?;
        tracing::info!("publishing on vservo/{instance}/camera_image");
        Ok(Some(Output { _node: node, publisher, notifier }))
    }
}

/// The publishing state: ports, the frame counter and the image buffer (allocated once).
struct Publishing {
    out: Output,
    counter: FrameCounter,
    image: Vec<u8>,
    width: u32,
    height: u32,
    period_ns: u64,
}

impl Publishing {
    /// Counts, stamps and publishes one frame.
    fn publish(&mut self, camera: &Camera, frame: &Frame, watch: &mut Watch) {
        let arrival_ns = monotonic_ns();
        let step = self.counter.count(frame.offset, frame.pts_ns, self.period_ns);
        let stamp = stamp::capture_stamp(camera.clock_mapping(), frame.running_time_ns, arrival_ns);
        watch.frame(arrival_ns, stamp.source, arrival_ns - stamp.monotonic_ns);
        if !pipeline::copy_luma(&frame.sample, &mut self.image, self.width as usize, self.height as usize) {
            watch.unreadable += 1;
            return;
        }
        let size = (self.width, self.height);
        if !vservo_protocol::publish_mono8(
            &self.out.publisher,
            size,
            &self.image,
            (step.frame, stamp.monotonic_ns),
            camera.reported_exposure(),
        ) {
            watch.no_slot += 1;
            return;
        }
        let _ = self.out.notifier.notify();
    }
}

/// What the driver logs: statistics every so often, a stalled pipeline, and totals at the end.
struct Watch {
    stall_after_ns: u64,
    stats_every_ns: u64,
    last_frame_ns: u64,
    last_stats_ns: u64,
    stalled: bool,
    /// Frames stamped with their arrival (no PTS), and clamped to it (stamp after arrival).
    arrival_stamped: u64,
    clamped: u64,
    /// Frames not published: no free sample in the publisher, or a buffer that could not be read.
    no_slot: u64,
    unreadable: u64,
    window_frames: u64,
    window_age_sum_ns: u64,
    window_age_max_ns: u64,
}

impl Watch {
    fn new(vision_period_s: f64, stall_periods: u32, stats_every_s: f64) -> Watch {
        let now = monotonic_ns();
        Watch {
            stall_after_ns: vservo_time::Nanos::from_periods(f64::from(stall_periods), vision_period_s).get(),
            stats_every_ns: if stats_every_s > 0.0 { vservo_time::nanos(stats_every_s) } else { u64::MAX },
            last_frame_ns: now,
            last_stats_ns: now,
            stalled: false,
            arrival_stamped: 0,
            clamped: 0,
            no_slot: 0,
            unreadable: 0,
            window_frames: 0,
            window_age_sum_ns: 0,
            window_age_max_ns: 0,
        }
    }

    fn frame(&mut self, now_ns: u64, source: StampSource, age_ns: u64) {
        if self.stalled {
            tracing::info!(
                "frames again after {:.2} s",
                vservo_time::seconds_between(now_ns, self.last_frame_ns)
            );
            self.stalled = false;
        }
        self.last_frame_ns = now_ns;
        match source {
            StampSource::Buffer => {}
            StampSource::ArrivalNoTimestamp => self.arrival_stamped += 1,
            StampSource::ArrivalClamped => self.clamped += 1,
        }
        self.window_frames += 1;
        self.window_age_sum_ns += age_ns;
        self.window_age_max_ns = self.window_age_max_ns.max(age_ns);
    }

    /// The stall rule and the periodic statistics.
    fn look(&mut self, now_ns: u64, pipeline: &str, counter: &FrameCounter) {
        let silent_ns = now_ns.saturating_sub(self.last_frame_ns);
        if !self.stalled && silent_ns > self.stall_after_ns {
            self.stalled = true;
            tracing::warn!(
                "no frame for {:.2} s (camera.gstreamer.stall_periods): the pipeline {pipeline:?} is stalled",
                vservo_time::Nanos(silent_ns).seconds()
            );
        }
        if now_ns.saturating_sub(self.last_stats_ns) >= self.stats_every_ns {
            let window_s = vservo_time::seconds_between(now_ns, self.last_stats_ns);
            self.report(counter, &format!("{:.1} frames/s", self.window_frames as f64 / window_s));
            self.last_stats_ns = now_ns;
            (self.window_frames, self.window_age_sum_ns, self.window_age_max_ns) = (0, 0, 0);
        }
    }

    fn report(&self, counter: &FrameCounter, what: &str) {
        let mean_age_ms = self.window_age_sum_ns as f64 / 1e6 / self.window_frames.max(1) as f64;
        tracing::info!(
            "{what}: frames {} lost {} not published {} (no slot) {} (unreadable); stamped at arrival {} \
             (no timestamp) {} (clamped); capture→taken mean/max {mean_age_ms:.2}/{:.2} ms",
            counter.taken,
            counter.lost,
            self.no_slot,
            self.unreadable,
            self.arrival_stamped,
            self.clamped,
            self.window_age_max_ns as f64 / 1e6
        );
    }
}
