//! `[camera]`: the intrinsics, where the camera sits on the hand, and where images come from.

use nalgebra::Point2;
use vservo_scene::CameraIntrinsics;

use super::checker::Checker;
use crate::raw::{RawCamera, RawCameraSource};
use crate::{ConfigError, VisionSource};

/// The intrinsics: the image size, the principal point inside it, the focal length.
pub fn intrinsics(check: &Checker, c: &RawCamera) -> Result<CameraIntrinsics, ConfigError> {
    let size = |key: &str, v: i64| {
        check.whole(key, v, 1u32, 16384, "must be a whole number of pixels between 1 and 16384")
    };
    let width_px = size("camera.width_px", c.width_px)?;
    let height_px = size("camera.height_px", c.height_px)?;
    fits_camera_image(check, width_px, height_px)?;
    let principal = check.finite("camera.principal_point_px", c.principal_point_px)?;
    if !(0.0..=f64::from(width_px)).contains(&principal[0])
        || !(0.0..=f64::from(height_px)).contains(&principal[1])
    {
        return Err(check.invalid(
            "camera.principal_point_px",
            format!("{principal:?}"),
            format!("must lie in the {width_px}×{height_px} image"),
        ));
    }
    let focal_px = check.within("camera.focal_px", c.focal_px, 1.0, 1e5, "px")?;
    CameraIntrinsics::new(focal_px, Point2::from(principal), width_px, height_px)
        .map_err(|e| check.invalid("camera", format!("{c:?}"), e.to_string()))
}

/// An image of `width_px` × `height_px` 8-bit pixels must fit in one `camera_image` sample
/// ([`crate::MAX_CAMERA_IMAGE_BYTES`]): a larger camera would never deliver a frame.
fn fits_camera_image(check: &Checker, width_px: u32, height_px: u32) -> Result<(), ConfigError> {
    let bytes = u64::from(width_px) * u64::from(height_px);
    if bytes <= crate::MAX_CAMERA_IMAGE_BYTES as u64 {
        return Ok(());
    }
    // name the side that is over 1280 (or the width when both are within and only their product is not)
    let (key, value) = if height_px > 1024 && width_px <= 1280 {
        ("camera.height_px", height_px)
    } else {
        ("camera.width_px", width_px)
    };
    Err(check.invalid(
        key,
        value,
        format!(
            "a {width_px} × {height_px} image is {bytes} bytes, more than a camera_image sample carries \
             ({} bytes, e.g. 1280 × 1024): lower camera.width_px or camera.height_px",
            crate::MAX_CAMERA_IMAGE_BYTES
        ),
    ))
}

/// `camera.tool_from_camera`: within 2 m of the tool.
pub fn tool_from_camera(
    check: &Checker,
    c: &RawCamera,
) -> Result<nalgebra::IsometryMatrix3<f64>, ConfigError> {
    check.pose("camera.tool_from_camera", &c.tool_from_camera, 2.0)
}

/// `camera.source`, and the directory it names.
pub fn source(check: &Checker, c: &RawCamera) -> Result<VisionSource, ConfigError> {
    Ok(match c.source {
        RawCameraSource::Simulated => VisionSource::Simulated,
        RawCameraSource::External => VisionSource::External,
        RawCameraSource::Directory => {
            if c.directory.trim().is_empty() {
                return Err(check.invalid(
                    "camera.directory",
                    "\"\"",
                    "must name a directory when camera.source = \"directory\"",
                ));
            }
            VisionSource::Directory(std::path::PathBuf::from(&c.directory))
        }
    })
}
