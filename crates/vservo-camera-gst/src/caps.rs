//! Whether the frames the pipeline negotiated are the configured camera's: raw video of its size, in a format
//! the driver turns into 8-bit gray ([`crate::luma`]).

use crate::luma::{self, Luma};

/// What the pipeline negotiated, as read from its caps.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Negotiated {
    /// The caps as GStreamer prints them.
    pub caps: String,
    /// The raw video format's name (`GRAY8`, `I420`, …), None if the caps are not raw video.
    pub format: Option<String>,
    /// The frame size (px).
    pub width_px: u32,
    /// The frame size (px).
    pub height_px: u32,
}

/// Frames that are not the camera's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CapsError {
    /// Not raw video at all (encoded video, audio, …).
    #[error(
        "the pipeline ends in {caps}, not raw video: end it in video/x-raw,format=GRAY8{}",
        decode_hint(caps)
    )]
    NotRawVideo {
        /// The caps.
        caps: String,
    },
    /// A pixel format the driver does not convert.
    #[error(
        "the pipeline ends in {caps}: format {format}, not one the driver turns into gray ({}; {})",
        luma::FORMATS.join(", "),
        convert_hint(caps)
    )]
    UnsupportedFormat {
        /// The caps.
        caps: String,
        /// Their format.
        format: String,
    },
    /// Another size than `[camera] width_px` × `height_px`.
    #[error(
        "the pipeline ends in {caps}: {width_px}×{height_px}, not the configured camera's \
         {expected_width_px}×{expected_height_px} (camera.width_px, camera.height_px)"
    )]
    WrongSize {
        /// The caps.
        caps: String,
        /// Their width.
        width_px: u32,
        /// Their height.
        height_px: u32,
        /// camera.width_px.
        expected_width_px: u32,
        /// camera.height_px.
        expected_height_px: u32,
    },
}

/// For encoded frames, how to decode them (an MJPEG camera is the usual case).
fn decode_hint(caps: &str) -> &'static str {
    if caps.starts_with("image/jpeg") {
        " (an MJPEG camera: decode its frames, `… ! image/jpeg,… ! jpegdec ! videoconvert ! video/x-raw,format=GRAY8`)"
    } else {
        ""
    }
}

/// How to make GRAY8 of another format: convert raw video, decode an MJPEG camera's frames.
fn convert_hint(caps: &str) -> &'static str {
    if caps.starts_with("image/jpeg") {
        "an MJPEG camera: decode its frames, `… ! image/jpeg,… ! jpegdec ! videoconvert ! video/x-raw,format=GRAY8`"
    } else {
        "add `videoconvert ! video/x-raw,format=GRAY8`"
    }
}

/// What to check when an element of the pipeline refused to run, from its message; empty when nothing is known.
pub fn element_hint(message: &str) -> &'static str {
    if message.contains("Cannot identify device") || message.contains("Could not open device") {
        "; no camera there: list the cameras with `v4l2-ctl --list-devices` (Debian's v4l-utils) and set v4l2src's \
         device=, and check that this user may open it (the `video` group)"
    } else if message.contains("Device") && message.contains("is busy") {
        "; another program has the camera open (`fuser /dev/video*` names it)"
    } else {
        ""
    }
}

/// Accepts raw frames of `width_px` × `height_px` in a format the driver converts, and says where their luma
/// is; else says what is wrong.
pub fn check(negotiated: &Negotiated, width_px: u32, height_px: u32) -> Result<Luma, CapsError> {
    let caps = negotiated.caps.clone();
    let Some(format) = &negotiated.format else { return Err(CapsError::NotRawVideo { caps }) };
    let Some(luma) = luma::of_format(format) else {
        return Err(CapsError::UnsupportedFormat { caps, format: format.clone() });
    };
    if (negotiated.width_px, negotiated.height_px) != (width_px, height_px) {
        return Err(CapsError::WrongSize {
            caps,
            width_px: negotiated.width_px,
            height_px: negotiated.height_px,
            expected_width_px: width_px,
            expected_height_px: height_px,
        });
    }
    Ok(luma)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn negotiated(format: Option<&str>, width_px: u32, height_px: u32) -> Negotiated {
        Negotiated {
            caps: "video/x-raw, …".into(), format: format.map(str::to_string), width_px, height_px
        }
    }

    #[test]
    fn gray_yuv_and_rgb_of_the_configured_size_are_taken() {
        assert_eq!(check(&negotiated(Some("GRAY8"), 512, 512), 512, 512), Ok(Luma::Bytes));
        assert_eq!(check(&negotiated(Some("YUY2"), 512, 512), 512, 512), Ok(Luma::Packed422 { first: 0 }));
        assert!(matches!(check(&negotiated(Some("BGRx"), 512, 512), 512, 512), Ok(Luma::Rgb { .. })));
    }

    #[test]
    fn another_format_size_or_media_is_refused_naming_it() {
        let refusal = |n: Negotiated| check(&n, 512, 512).expect_err("refused").to_string();
        let format = refusal(negotiated(Some("GRAY16_LE"), 512, 512));
        assert!(
            format.contains("format GRAY16_LE, not one the driver turns into gray (GRAY8, I420"),
            "{format}"
        );
        assert!(format.contains("videoconvert ! video/x-raw,format=GRAY8"), "{format}");
        let size = refusal(negotiated(Some("GRAY8"), 320, 240));
        assert!(size.contains("320×240, not the configured camera's 512×512"), "{size}");
        assert!(refusal(negotiated(None, 0, 0)).contains("not raw video"));
        let mjpeg = Negotiated {
            caps: "image/jpeg, width=(int)640".into(),
            format: None,
            width_px: 640,
            height_px: 480,
        };
        assert!(refusal(mjpeg).contains("jpegdec ! videoconvert"), "an MJPEG camera is told how to decode");
        let encoded = Negotiated {
            caps: "image/jpeg, width=(int)512".into(),
            format: Some("ENCODED".into()),
            width_px: 512,
            height_px: 512,
        };
        assert!(refusal(encoded).contains("jpegdec ! videoconvert"), "as GStreamer names a JPEG's format");
    }

    #[test]
    fn a_missing_or_busy_camera_is_told_what_to_check() {
        assert!(element_hint("Cannot identify device '/dev/video0'.").contains("v4l2-ctl --list-devices"));
        assert!(element_hint("Device '/dev/video0' is busy").contains("fuser"));
        assert_eq!(element_hint("Internal data stream error."), "");
    }
}
