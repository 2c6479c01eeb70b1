//! Whether the frames the pipeline negotiated are the configured camera's: 8-bit gray of its size.

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
    #[error("the pipeline ends in {caps}, not raw video: end it in video/x-raw,format=GRAY8")]
    NotRawVideo {
        /// The caps.
        caps: String,
    },
    /// Another pixel format.
    #[error(
        "the pipeline ends in {caps}: format {format}, not GRAY8 (add `videoconvert ! video/x-raw,format=GRAY8`)"
    )]
    NotGray8 {
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

/// Accepts GRAY8 frames of `width_px` × `height_px`, else says what is wrong.
pub fn check(negotiated: &Negotiated, width_px: u32, height_px: u32) -> Result<(), CapsError> {
    let caps = negotiated.caps.clone();
    let Some(format) = &negotiated.format else { return Err(CapsError::NotRawVideo { caps }) };
    if format != "GRAY8" {
        return Err(CapsError::NotGray8 { caps, format: format.clone() });
    }
    if (negotiated.width_px, negotiated.height_px) != (width_px, height_px) {
        return Err(CapsError::WrongSize {
            caps,
            width_px: negotiated.width_px,
            height_px: negotiated.height_px,
            expected_width_px: width_px,
            expected_height_px: height_px,
        });
    }
    Ok(())
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
    fn gray8_of_the_configured_size_is_taken() {
        assert_eq!(check(&negotiated(Some("GRAY8"), 512, 512), 512, 512), Ok(()));
    }

    #[test]
    fn another_format_size_or_media_is_refused_naming_it() {
        let refusal = |n: Negotiated| check(&n, 512, 512).expect_err("refused").to_string();
        assert!(refusal(negotiated(Some("I420"), 512, 512)).contains("format I420, not GRAY8"));
        let size = refusal(negotiated(Some("GRAY8"), 320, 240));
        assert!(size.contains("320×240, not the configured camera's 512×512"), "{size}");
        assert!(refusal(negotiated(None, 0, 0)).contains("not raw video"));
    }
}
