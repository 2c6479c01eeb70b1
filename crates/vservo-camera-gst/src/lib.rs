//! # vservo-camera-gst — a camera driver for real cameras through GStreamer
//!
//! The binary `vservo-gst-camera` runs the GStreamer pipeline of `[camera.gstreamer]` (a `v4l2src` for a
//! USB/UVC camera, an `aravissrc` for GigE Vision, an `rtspsrc` for an IP camera, or anything else ending in
//! raw frames of the configured size: gray, YUV or RGB), takes each frame from an appsink, turns it into 8-bit
//! gray and publishes it on `camera_image` under the driver contract of docs/DRIVERS.md ("A real camera
//! through GStreamer").
//!
//! This library holds the driver's decisions as pure functions, tested without GStreamer:
//! - [`stamp`]: a buffer's timestamp → the capture stamp on CLOCK_MONOTONIC (or its arrival time);
//! - [`frames`]: the camera's frame counter and the frames lost on the way (gaps in buffer offsets or
//!   timestamps, frames no publisher slot took);
//! - [`caps`]: whether the negotiated format is the configured camera's;
//! - [`luma`]: where a raw format's luma is, and the conversion of a row to 8-bit gray;
//! - [`controls`]: how exposure and gain are set on a source element, or why they cannot be.

pub mod caps;
pub mod controls;
pub mod frames;
pub mod luma;
pub mod stamp;
