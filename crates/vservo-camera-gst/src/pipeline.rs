//! The GStreamer side: the configured pipeline with its appsink on the monotonic system clock, exposure and
//! gain on its sources, and each frame taken with its caps, stamp and buffer offset.

use gstreamer as gst;
use gstreamer::prelude::*;
use gstreamer_app as gst_app;
use gstreamer_video as gst_video;
use gstreamer_video::prelude::*;
use vservo_camera_gst::caps::Negotiated;
use vservo_camera_gst::controls::{self, Setting};
use vservo_camera_gst::luma;
use vservo_camera_gst::stamp::ClockMapping;
use vservo_config::GstreamerCamera;

/// Why the pipeline cannot give the camera's frames.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// GStreamer itself did not start.
    #[error("GStreamer did not initialise: {0}")]
    Init(String),
    /// The text is not a pipeline GStreamer can build.
    #[error("camera.gstreamer.pipeline {pipeline:?}: {reason}")]
    Parse {
        /// The text.
        pipeline: String,
        /// GStreamer's reason.
        reason: String,
    },
    /// An element posted an error (negotiation failed, a device missing, …).
    #[error(
        "camera.gstreamer.pipeline {pipeline:?}: {element}: {message}{debug}{}",
        vservo_camera_gst::caps::element_hint(message)
    )]
    Element {
        /// The text.
        pipeline: String,
        /// The element's path.
        element: String,
        /// Its message.
        message: String,
        /// Details, if any.
        debug: String,
    },
    /// The pipeline ended (a source that ran out, a closed stream).
    #[error("camera.gstreamer.pipeline {pipeline:?}: the stream ended (end of stream)")]
    Ended {
        /// The text.
        pipeline: String,
    },
    /// A frame did not match the camera.
    #[error("camera.gstreamer.pipeline {pipeline:?}: {reason}")]
    Caps {
        /// The text.
        pipeline: String,
        /// What is wrong.
        reason: String,
    },
}

/// A running pipeline and the appsink its frames come from.
pub struct Camera {
    /// The pipeline text, for messages.
    pub text: String,
    pipeline: gst::Pipeline,
    appsink: gst_app::AppSink,
    clock_minus_monotonic_ns: i64,
    /// The source element that reports its exposure (a double `exposure` property, µs) or gain (a double
    /// `gain`, dB), if one does (`aravissrc`; not `v4l2src`, whose controls are written, not read back).
    reporting: Option<gst::Element>,
}

/// One frame as taken from the appsink.
pub struct Frame {
    /// The sample (caps and buffer).
    pub sample: gst::Sample,
    /// Its PTS in running time (ns), if it has one.
    pub running_time_ns: Option<u64>,
    /// Its PTS (ns), if any.
    pub pts_ns: Option<u64>,
    /// Its buffer offset, if the source numbers frames.
    pub offset: Option<u64>,
}

impl Camera {
    /// Builds the pipeline (adding `appsink name=<appsink>` at its end unless it has an element of that
    /// name), puts it on the monotonic system clock and sets exposure and gain on its sources.
    pub fn build(settings: &GstreamerCamera) -> Result<Camera, PipelineError> {
        gst::init().map_err(|e| PipelineError::Init(e.to_string()))?;
        let text = settings.pipeline.clone();
        let parse_error =
            |e: gst::glib::Error| PipelineError::Parse { pipeline: text.clone(), reason: e.to_string() };
        // the text with the appsink added at its end; else the text as it is, if it names the appsink itself
        let element = match gst::parse::launch(&format!("{text} ! appsink name={}", settings.appsink)) {
            Ok(element) => element,
            Err(appended) => gst::parse::launch(&text)
                .ok()
                .filter(|element| bin_child(element, &settings.appsink).is_some())
                .ok_or_else(|| parse_error(appended))?,
        };
        let pipeline = element.downcast::<gst::Pipeline>().map_err(|_| PipelineError::Parse {
            pipeline: text.clone(),
            reason: "is one element, not a pipeline ending in 8-bit gray frames".into(),
        })?;
        let appsink = appsink(&pipeline, &settings.appsink, &text)?;
        let clock_minus_monotonic_ns = use_monotonic_clock(&pipeline);
        apply_controls(&pipeline, settings);
        let reporting = reporting_source(&pipeline);
        Ok(Camera { text, pipeline, appsink, clock_minus_monotonic_ns, reporting })
    }

    /// Starts the pipeline.
    pub fn play(&self) -> Result<(), PipelineError> {
        if self.pipeline.set_state(gst::State::Playing).is_err() {
            return Err(self.posted_error().unwrap_or_else(|| PipelineError::Element {
                pipeline: self.text.clone(),
                element: "pipeline".into(),
                message: "refused to start".into(),
                debug: String::new(),
            }));
        }
        Ok(())
    }

    /// The next frame within `timeout_ms` (None: none came), or the error the pipeline posted.
    pub fn next_frame(&self, timeout_ms: u64) -> Result<Option<Frame>, PipelineError> {
        self.check_bus()?;
        let Some(sample) = self.appsink.try_pull_sample(gst::ClockTime::from_mseconds(timeout_ms)) else {
            if self.appsink.is_eos() {
                return Err(self
                    .posted_error()
                    .unwrap_or(PipelineError::Ended { pipeline: self.text.clone() }));
            }
            return Ok(None);
        };
        let buffer = sample.buffer();
        let pts = buffer.and_then(gst::BufferRef::pts);
        let running_time_ns = match (sample.segment().and_then(|s| s.downcast_ref::<gst::ClockTime>()), pts) {
            (Some(segment), Some(pts)) => segment.to_running_time(pts).map(gst::ClockTime::nseconds),
            _ => None,
        };
        let offset = buffer.map(gst::BufferRef::offset).filter(|o| *o != gst::format::Buffers::OFFSET_NONE);
        Ok(Some(Frame { running_time_ns, pts_ns: pts.map(gst::ClockTime::nseconds), offset, sample }))
    }

    /// Pipeline clock time ↔ CLOCK_MONOTONIC now (the base time is set when the pipeline starts playing).
    pub fn clock_mapping(&self) -> ClockMapping {
        ClockMapping {
            base_time_ns: self.pipeline.base_time().map_or(0, gst::ClockTime::nseconds),
            clock_minus_monotonic_ns: self.clock_minus_monotonic_ns,
        }
    }

    /// The exposure and gain the source reports now (NaN where it reports none).
    pub fn reported_exposure(&self) -> vservo_protocol::Exposure {
        let Some(source) = &self.reporting else { return vservo_protocol::Exposure::UNKNOWN };
        let read = |property: &str| {
            if has_double(source, property) { source.property::<f64>(property) } else { f64::NAN }
        };
        vservo_protocol::Exposure { exposure_us: read("exposure"), gain_db: read("gain") }
    }

    /// The offset of the pipeline clock from CLOCK_MONOTONIC (ns; 0 on the monotonic system clock).
    pub fn clock_minus_monotonic_ns(&self) -> i64 {
        self.clock_minus_monotonic_ns
    }

    /// An error or end of stream posted on the bus, as an error.
    fn check_bus(&self) -> Result<(), PipelineError> {
        match self.posted_error() {
            Some(error) => Err(error),
            None => Ok(()),
        }
    }

    fn posted_error(&self) -> Option<PipelineError> {
        let bus = self.pipeline.bus()?;
        while let Some(message) = bus.pop() {
            match message.view() {
                gst::MessageView::Error(e) => {
                    return Some(PipelineError::Element {
                        pipeline: self.text.clone(),
                        element: message.src().map_or_else(|| "?".into(), |s| s.path_string().to_string()),
                        message: e.error().to_string(),
                        debug: e.debug().map_or_else(String::new, |d| format!(" ({d})")),
                    });
                }
                gst::MessageView::Eos(_) => {
                    return Some(PipelineError::Ended { pipeline: self.text.clone() });
                }
                gst::MessageView::Warning(w) => tracing::warn!(
                    "GStreamer: {}: {}",
                    message.src().map_or_else(|| "?".into(), |s| s.path_string().to_string()),
                    w.error()
                ),
                _ => {}
            }
        }
        None
    }
}

impl Drop for Camera {
    fn drop(&mut self) {
        let _ = self.pipeline.set_state(gst::State::Null);
    }
}

/// What a sample's caps say about its frames.
pub fn negotiated(sample: &gst::Sample) -> Negotiated {
    let caps = sample.caps();
    let info = caps.and_then(|c| gst_video::VideoInfo::from_caps(c).ok());
    Negotiated {
        caps: caps.map_or_else(|| "no caps".into(), ToString::to_string),
        format: info.as_ref().map(|i| i.format().to_str().to_string()),
        width_px: info.as_ref().map_or(0, gst_video::VideoInfo::width),
        height_px: info.as_ref().map_or(0, gst_video::VideoInfo::height),
    }
}

/// The frame period the caps give (ns; 0 for a variable or unknown rate).
pub fn caps_frame_period_ns(sample: &gst::Sample) -> u64 {
    let Some(info) = sample.caps().and_then(|c| gst_video::VideoInfo::from_caps(c).ok()) else { return 0 };
    let rate = info.fps();
    if rate.numer() <= 0 || rate.denom() <= 0 {
        return 0;
    }
    vservo_time::Nanos::from_seconds(f64::from(rate.denom()) / f64::from(rate.numer())).get()
}

/// Writes the luma of a frame's rows into `out` (width bytes each, no padding), by the frame's own format
/// ([`luma::of_format`]); false if it cannot be read, is not `width` × `height` or its format is not one the
/// driver converts (caps may change mid-stream).
pub fn copy_luma(sample: &gst::Sample, out: &mut [u8], width: usize, height: usize) -> bool {
    let (Some(buffer), Some(caps)) = (sample.buffer(), sample.caps()) else { return false };
    let Ok(info) = gst_video::VideoInfo::from_caps(caps) else { return false };
    let Some(luma) = luma::of_format(info.format().to_str()) else { return false };
    if (info.width() as usize, info.height() as usize) != (width, height) {
        return false;
    }
    let Ok(frame) = gst_video::VideoFrameRef::from_buffer_ref_readable(buffer, &info) else { return false };
    let (Ok(data), Ok(stride)) = (frame.plane_data(0), usize::try_from(frame.plane_stride()[0])) else {
        return false;
    };
    let row_bytes = luma.row_bytes(width);
    if stride < row_bytes || out.len() < width * height {
        return false;
    }
    for (row, target) in out.chunks_exact_mut(width).take(height).enumerate() {
        let Some(source) = data.get(row * stride..row * stride + row_bytes) else { return false };
        luma.convert_row(source, target);
    }
    true
}

fn bin_child(element: &gst::Element, name: &str) -> Option<gst::Element> {
    element.downcast_ref::<gst::Bin>().and_then(|bin| bin.by_name(name))
}

fn appsink(pipeline: &gst::Pipeline, name: &str, text: &str) -> Result<gst_app::AppSink, PipelineError> {
    let element = pipeline.by_name(name).ok_or_else(|| PipelineError::Parse {
        pipeline: text.to_string(),
        reason: format!("has no element named {name:?} (camera.gstreamer.appsink)"),
    })?;
    let kind = element.factory().map_or_else(|| "?".into(), |f| f.name().to_string());
    let appsink = element.dynamic_cast::<gst_app::AppSink>().map_err(|_| PipelineError::Parse {
        pipeline: text.to_string(),
        reason: format!("its element {name:?} is a {kind}, not an appsink (camera.gstreamer.appsink)"),
    })?;
    // the newest frames only: a late driver loses old frames (counted as gaps), never falls behind
    appsink.set_max_buffers(2);
    appsink.set_drop(true);
    appsink.set_sync(false);
    Ok(appsink)
}

/// GStreamer's system clock, set to CLOCK_MONOTONIC (`clock-type` monotonic), for the whole pipeline:
/// clock time is then CLOCK_MONOTONIC time. Returns the measured offset for any other clock (0 here).
fn use_monotonic_clock(pipeline: &gst::Pipeline) -> i64 {
    let clock = gst::SystemClock::obtain();
    if let Some(system) = clock.downcast_ref::<gst::SystemClock>() {
        system.set_clock_type(gst::ClockType::Monotonic);
    }
    pipeline.use_clock(Some(&clock));
    let is_monotonic =
        clock.downcast_ref::<gst::SystemClock>().is_some_and(|s| s.clock_type() == gst::ClockType::Monotonic);
    if is_monotonic {
        return 0;
    }
    // another clock: its reading bracketed by two CLOCK_MONOTONIC readings
    let before = vservo_time::monotonic_ns();
    let clock_ns = clock.time().nseconds();
    let after = vservo_time::monotonic_ns();
    (i128::from(clock_ns) - i128::from(before / 2 + after / 2)) as i64
}

/// Whether `element` has a property `name` of type double.
fn has_double(element: &gst::Element, name: &str) -> bool {
    element.find_property(name).is_some_and(|p| p.value_type() == f64::static_type())
}

/// The first source element with a double `exposure` or `gain` property.
fn reporting_source(pipeline: &gst::Pipeline) -> Option<gst::Element> {
    let mut sources = pipeline.iterate_sources();
    while let Ok(Some(source)) = sources.next() {
        if has_double(&source, "exposure") || has_double(&source, "gain") {
            return Some(source);
        }
    }
    None
}

/// Exposure and gain on every source element of the pipeline (docs/DRIVERS.md).
fn apply_controls(pipeline: &gst::Pipeline, settings: &GstreamerCamera) {
    let mut sources = pipeline.iterate_sources();
    while let Ok(Some(source)) = sources.next() {
        let name = source.name().to_string();
        let factory = source.factory().map_or_else(|| "?".into(), |f| f.name().to_string());
        let plan = controls::plan(
            &name,
            &factory,
            |property| has_double(&source, property),
            settings.exposure_us,
            settings.gain_db,
        );
        for warning in &plan.warnings {
            tracing::warn!("{warning}");
        }
        for setting in plan.settings {
            apply(&source, &setting);
        }
    }
}

fn apply(source: &gst::Element, setting: &Setting) {
    match setting {
        Setting::Double(property, value) => source.set_property(property, value),
        Setting::EnumNick(property, nick) => {
            if source.find_property(property).is_some() {
                source.set_property_from_str(property, nick);
            }
        }
        Setting::ExtraControls(controls) => {
            let mut structure = gst::Structure::new_empty("controls");
            for (name, value) in controls {
                structure.set(*name, *value);
            }
            source.set_property("extra-controls", structure);
        }
    }
    tracing::info!("{}: {setting:?}", source.name());
}
