//! `vservo-gst-camera`: the GStreamer camera driver. Runs `[camera.gstreamer] pipeline` and publishes its
//! 8-bit gray frames on `camera_image` (docs/DRIVERS.md, "A real camera through GStreamer").
//!
//! vservod starts it with `[camera] source = "gstreamer"` (and ends it with itself); with `"external"` it is
//! the user's to run, by hand or as a unit of its own. The GStreamer (gstreamer-rs 0.25 on Debian's GStreamer 1.22) and iceoryx2 side is
//! here: [`pipeline`] (the pipeline with its appsink on the monotonic system clock, exposure and gain on its
//! sources, each frame taken with its caps, stamp and buffer offset), [`publish`] (each frame checked — raw gray,
//! YUV or RGB of the configured size, turned into gray —, counted and stamped — PTS → running time → CLOCK_MONOTONIC — onto `camera_image`,
//! with the camera's frame counter; stalls logged, one writer per stream). The decisions are the library's,
//! `vservo_camera_gst`.
//!
//! ```text
//! vservo-gst-camera --config FILE [--stats-every-s S] [--daemon-pid PID]
//! ```
//!
//! Exit codes: 0 after SIGINT/SIGTERM, 1 on an error (a bad pipeline, frames of another format or size, a
//! pipeline that failed or ended), 76 when another process holds the `camera_image` slot.

mod pipeline;
mod publish;

use std::process::ExitCode;

use clap::Parser;

/// The exit code when another live process holds the camera slot (vservod's for the same refusal).
const SLOT_TAKEN_EXIT: u8 = 76;

#[derive(Parser)]
#[command(version, about = "Publishes a GStreamer pipeline's 8-bit gray frames on vservo's camera_image")]
struct Cli {
    /// The configuration file (its [camera] size, [camera.gstreamer] and [instance] name).
    #[arg(long, default_value = "config/vservo.toml")]
    config: std::path::PathBuf,
    /// Log the frame statistics every this many seconds (0: only at the end).
    #[arg(long, default_value_t = 10.0)]
    stats_every_s: f64,
    /// Started by this vservod (`camera.source = "gstreamer"`): end when it does, however it ends.
    #[arg(long, value_name = "PID", hide = true)]
    daemon_pid: Option<i32>,
}

fn main() -> ExitCode {
    vservo_driver::logging::to_stderr("info");
    let cli = Cli::parse();
    let result = vservo_protocol::signals::run_until_stopped(cli.daemon_pid, |stop| {
        publish::run(&cli.config, cli.stats_every_s, stop)
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            tracing::error!("{error:#}");
            let slot_taken = error.chain().any(|c| {
                c.downcast_ref::<vservo_protocol::ProtocolError>().is_some_and(|e| e.is_slot_taken())
            });
            if slot_taken { ExitCode::from(SLOT_TAKEN_EXIT) } else { ExitCode::FAILURE }
        }
    }
}
