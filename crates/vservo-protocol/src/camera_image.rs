//! The camera image stream: the service `camera_image` (a slice of 8-bit pixels under a [`CameraImageHeader`]),
//! its one publisher, its subscribers, and the event of the same name that wakes the vision node.

use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::{Publisher, PublisherCreateError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;

use crate::{
    CameraImageHeader, MAX_IMAGE_BYTES, Opening, PixelFormat, ProtocolError, SCHEMA_VERSION, listener_error,
    named, notifier_error, open_event_named, port_error, subscriber_error, writer_slot,
};

/// The publish-subscribe service `vservo/<instance>/camera_image`: a slice of `u8` (the image) with a
/// [`CameraImageHeader`]; with an event of the same name that wakes the vision node.
pub const CAMERA_IMAGE_SERVICE: &str = "camera_image";

/// The camera image service, opened or created with vservo's sizes (1 publisher, 8 subscribers, no
/// history, 2 samples buffered per subscriber); clients pass [`Opening::OpenOnly`].
pub fn open_camera_image_service(
    node: &Node<ipc::Service>,
    instance: &str,
    opening: Opening,
) -> Result<
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, [u8], CameraImageHeader>,
    ProtocolError,
> {
    let (name, service) = named(&format!("vservo/{instance}/{CAMERA_IMAGE_SERVICE}"))?;
    let builder = node
        .service_builder(&service)
        .publish_subscribe::<[u8]>()
        .user_header::<CameraImageHeader>()
        .max_publishers(1)
        .max_subscribers(8)
        .history_size(0)
        .subscriber_max_buffer_size(2)
        .enable_safe_overflow(true);
    match opening {
        Opening::OpenOrCreate => {
            builder.open_or_create().map_err(|e| port_error("opening the service", &name)(e.to_string()))
        }
        Opening::OpenOnly => builder
            .open()
            .map_err(|e| port_error("opening the service (is a camera publishing?)", &name)(e.to_string())),
    }
}

/// A publisher of camera images up to [`MAX_IMAGE_BYTES`].
pub fn camera_image_publisher(
    node: &Node<ipc::Service>,
    instance: &str,
) -> Result<Publisher<ipc::Service, [u8], CameraImageHeader>, ProtocolError> {
    let service = open_camera_image_service(node, instance, Opening::OpenOrCreate)?;
    writer_slot(node, || service.publisher_builder().initial_max_slice_len(MAX_IMAGE_BYTES).create()).map_err(
        |e| match e {
            PublisherCreateError::ExceedsMaxSupportedPublishers => {
                ProtocolError::SlotTaken { port: "publisher", service: CAMERA_IMAGE_SERVICE.to_string() }
            }
            e => port_error("creating a publisher", CAMERA_IMAGE_SERVICE)(e.to_string()),
        },
    )
}

/// The exposure and gain a camera reports with a frame (NaN where it does not say).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// How long the shutter was open (µs).
    pub exposure_us: f64,
    /// The sensor's gain (dB).
    pub gain_db: f64,
}

impl Exposure {
    /// A camera that reports neither.
    pub const UNKNOWN: Exposure = Exposure { exposure_us: f64::NAN, gain_db: f64::NAN };
}

/// An 8-bit gray image of `width` × `height` (rows packed: `pixels.len()` is their product) published on
/// `camera_image` as frame `frame`, exposed at `capture_stamp_ns` with `exposure`; `false` when no sample was
/// free or the send failed (the caller counts it).
pub fn publish_mono8(
    publisher: &Publisher<ipc::Service, [u8], CameraImageHeader>,
    (width, height): (u32, u32),
    pixels: &[u8],
    (frame, capture_stamp_ns): (u64, u64),
    exposure: Exposure,
) -> bool {
    let Ok(mut sample) = publisher.loan_slice_uninit(pixels.len()) else { return false };
    *sample.user_header_mut() = CameraImageHeader {
        schema: SCHEMA_VERSION,
        format: PixelFormat::Mono8.into(),
        width,
        height,
        stride_bytes: width,
        reserved: 0,
        frame,
        capture_stamp_ns,
        exposure_us: exposure.exposure_us,
        gain_db: exposure.gain_db,
    };
    sample.write_from_slice(pixels).send().is_ok()
}

/// A subscriber of camera images (the vision node creates the service if no camera has yet; clients
/// only open it).
pub fn camera_image_subscriber(
    node: &Node<ipc::Service>,
    instance: &str,
    opening: Opening,
) -> Result<Subscriber<ipc::Service, [u8], CameraImageHeader>, ProtocolError> {
    open_camera_image_service(node, instance, opening)?
        .subscriber_builder()
        .buffer_size(2)
        .create()
        .map_err(|e| subscriber_error(e, CAMERA_IMAGE_SERVICE))
}

/// The notifier of the camera image event.
pub fn camera_image_notifier(
    node: &Node<ipc::Service>,
    instance: &str,
) -> Result<Notifier<ipc::Service>, ProtocolError> {
    let (name, factory) = open_event_named(node, &format!("vservo/{instance}/{CAMERA_IMAGE_SERVICE}"))?;
    writer_slot(node, || factory.notifier_builder().create()).map_err(|e| notifier_error(e, &name))
}

/// The listener the vision node waits on for camera images.
pub fn camera_image_listener(
    node: &Node<ipc::Service>,
    instance: &str,
) -> Result<Listener<ipc::Service>, ProtocolError> {
    let (name, factory) = open_event_named(node, &format!("vservo/{instance}/{CAMERA_IMAGE_SERVICE}"))?;
    factory.listener_builder().create().map_err(|e| listener_error(e, &name))
}
