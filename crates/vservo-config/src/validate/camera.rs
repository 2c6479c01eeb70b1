//! `[camera]`: the intrinsics, where the camera sits on the hand, and where images come from.

use nalgebra::Point2;
use vservo_scene::{CameraIntrinsics, Distortion};

use super::checker::Checker;
use crate::calibration::Calibration;
use crate::raw::{RawCamera, RawCameraMount, RawCameraSource, RawGstreamer};
use crate::{CameraTruth, ConfigError, GstreamerCamera, VisionSource};

/// `camera.calibration_file`, read and parsed once, if written.
pub fn calibration_file(check: &Checker, c: &RawCamera) -> Result<Option<Calibration>, ConfigError> {
    c.calibration_file.as_deref().map(|file| calibration(check, c, file)).transpose()
}

/// The intrinsics: from the calibration file, or the image size, the principal point inside it, the focal
/// lengths (`focal_px`, or `fx_px` and `fy_px`) and the lens's `distortion` (none when not written).
pub fn intrinsics(
    check: &Checker,
    c: &RawCamera,
    calibration: Option<&Calibration>,
) -> Result<CameraIntrinsics, ConfigError> {
    let calibration = calibration.copied();
    let given = |key: &str, value: Option<i64>, from_file: Option<u32>| match (value, from_file) {
        (Some(v), _) => Ok(v),
        (None, Some(v)) => Ok(i64::from(v)),
        (None, None) => Err(missing(check, key)),
    };
    // a size the calibration file gave is its fault, not the keys' the file left out
    let from_file = |key: &'static str, written: Option<i64>| match (written, calibration) {
        (None, Some(_)) => "camera.calibration_file",
        _ => key,
    };
    let size = |key: &str, v: i64| {
        check.whole(key, v, 1u32, 16384, "must be a whole number of pixels between 1 and 16384")
    };
    let width_key = from_file("camera.width_px", c.width_px);
    let height_key = from_file("camera.height_px", c.height_px);
    let width_px = size(width_key, given("camera.width_px", c.width_px, calibration.map(|k| k.width_px))?)?;
    let height_px =
        size(height_key, given("camera.height_px", c.height_px, calibration.map(|k| k.height_px))?)?;
    fits_camera_image(check, (width_key, width_px), (height_key, height_px), c.calibration_file.as_deref())?;
    let key = "camera.principal_point_px";
    let principal = c
        .principal_point_px
        .or(calibration.map(|k| k.principal_point_px))
        .ok_or_else(|| missing(check, key))?;
    let principal = check.finite(key, principal)?;
    if !(0.0..=f64::from(width_px)).contains(&principal[0])
        || !(0.0..=f64::from(height_px)).contains(&principal[1])
    {
        return Err(check.invalid(
            key,
            format!("{principal:?}"),
            format!("must lie in the {width_px}×{height_px} image"),
        ));
    }
    let focal_px = match calibration {
        Some(k) => k.focal_px,
        None => focal_lengths(check, c)?,
    };
    let distortion = lens(check, calibration.map_or(c.distortion.unwrap_or_default(), |k| k.distortion))?;
    CameraIntrinsics::with_lens(focal_px, Point2::from(principal), width_px, height_px, distortion)
        .map_err(|e| check.invalid("camera", format!("{c:?}"), e.to_string()))
}

fn missing(check: &Checker, key: &str) -> ConfigError {
    check.invalid(key, "nothing", "must be given (or camera.calibration_file)")
}

/// fx and fy: `focal_px` for square pixels, or `fx_px` and `fy_px`; never both ways.
fn focal_lengths(check: &Checker, c: &RawCamera) -> Result<[f64; 2], ConfigError> {
    let focal = |key: &str, v: f64| check.within(key, v, 1.0, 1e5, "px");
    match (c.focal_px, c.fx_px, c.fy_px) {
        (Some(f), None, None) => {
            let f = focal("camera.focal_px", f)?;
            Ok([f, f])
        }
        (None, Some(fx), Some(fy)) => Ok([focal("camera.fx_px", fx)?, focal("camera.fy_px", fy)?]),
        (Some(f), _, _) => Err(check.invalid(
            "camera.focal_px",
            f,
            "is given with camera.fx_px/fy_px: give focal_px for square pixels or fx_px and fy_px, not both",
        )),
        (None, None, None) => Err(check.invalid(
            "camera.focal_px",
            "nothing",
            "must be given (or camera.fx_px and camera.fy_px, or camera.calibration_file)",
        )),
        (None, fx, _) => {
            let (key, other) =
                if fx.is_none() { ("camera.fx_px", "fy_px") } else { ("camera.fy_px", "fx_px") };
            Err(check.invalid(key, "nothing", format!("must be given with camera.{other}")))
        }
    }
}

/// `camera.distortion` = [k1, k2, p1, p2, k3]: finite, and small enough that the lens is one to one over
/// the image (|k| ≤ 10).
fn lens(check: &Checker, coefficients: [f64; 5]) -> Result<Distortion, ConfigError> {
    let coefficients =
        check.all_within("camera.distortion", coefficients, -10.0, 10.0, "(k1, k2, p1, p2, k3)")?;
    Distortion::new(coefficients)
        .map_err(|e| check.invalid("camera.distortion", format!("{coefficients:?}"), e.to_string()))
}

/// The calibration file's intrinsics; it takes the place of every other lens key in its `[camera]`.
fn calibration(check: &Checker, c: &RawCamera, file: &str) -> Result<Calibration, ConfigError> {
    let key = "camera.calibration_file";
    let written = [
        ("focal_px", c.focal_px.is_some()),
        ("fx_px", c.fx_px.is_some()),
        ("fy_px", c.fy_px.is_some()),
        ("principal_point_px", c.principal_point_px.is_some()),
        ("distortion", c.distortion.is_some()),
        ("width_px", c.width_px.is_some()),
        ("height_px", c.height_px.is_some()),
    ];
    if let Some((other, _)) = written.iter().find(|(_, given)| *given) {
        return Err(check.invalid(
            key,
            format!("{file:?}"),
            format!("is given with camera.{other}: the calibration file gives the whole lens, write one or the other"),
        ));
    }
    if file.trim().is_empty() {
        return Err(check.invalid(
            key,
            "\"\"",
            "must name a calibration file (ROS camera_info or OpenCV YAML)",
        ));
    }
    let text = crate::layers::read_bounded(std::path::Path::new(file))
        .map_err(|reason| check.invalid(key, format!("{file:?}"), format!("cannot read: {reason}")))?;
    crate::calibration::parse(&text).map_err(|e| check.invalid(key, format!("{file:?}"), e.to_string()))
}

/// An image of `width_px` × `height_px` 8-bit pixels must fit in one `camera_image` sample
/// ([`crate::MAX_CAMERA_IMAGE_BYTES`]): a larger camera would never deliver a frame.
/// Each side is given with the key it came from (`camera.width_px`, or `camera.calibration_file` for a size the
/// file gave).
fn fits_camera_image(
    check: &Checker,
    (width_key, width_px): (&str, u32),
    (height_key, height_px): (&str, u32),
    calibration_file: Option<&str>,
) -> Result<(), ConfigError> {
    let bytes = u64::from(width_px) * u64::from(height_px);
    if bytes <= crate::MAX_CAMERA_IMAGE_BYTES as u64 {
        return Ok(());
    }
    // name the side that is over 1280 (or the width when both are within and only their product is not)
    let (key, value) =
        if height_px > 1024 && width_px <= 1280 { (height_key, height_px) } else { (width_key, width_px) };
    let (shown, lower) = match calibration_file {
        Some(file) if key == "camera.calibration_file" => (
            format!("{file:?}"),
            "the file calibrates a larger camera than vservo takes (calibrate it at a lower resolution)",
        ),
        _ => (value.to_string(), "lower camera.width_px or camera.height_px"),
    };
    Err(check.invalid(
        key,
        shown,
        format!(
            "a {width_px} × {height_px} image is {bytes} bytes, more than a camera_image sample carries \
             ({} bytes, e.g. 1280 × 1024): {lower}",
            crate::MAX_CAMERA_IMAGE_BYTES
        ),
    ))
}

/// `camera.tool_from_camera`: within 2 m of the tool; the calibration file's where it has one (a file of
/// `vservoctl calibrate`). A fixed camera (`camera.mount = "world"`) has none: the identity stands in, and
/// [`crate::CellConfig::mount`] is the rule for where the camera is.
pub fn tool_from_camera(
    check: &Checker,
    c: &RawCamera,
    calibration: Option<&Calibration>,
) -> Result<nalgebra::IsometryMatrix3<f64>, ConfigError> {
    match (c.mount, &c.tool_from_camera) {
        (RawCameraMount::Hand, None) => Err(check.invalid(
            "camera.tool_from_camera",
            "nothing",
            "must be given for a camera on the hand (or camera.mount = \"world\" with camera.base_from_camera)",
        )),
        (RawCameraMount::Hand, Some(pose)) => {
            if calibration.is_some_and(|k| k.base_from_camera.is_some()) {
                return Err(check.invalid(
                    "camera.calibration_file",
                    c.calibration_file.clone().unwrap_or_default(),
                    "holds a fixed camera's pose (base_from_camera): a camera on the hand is at tool_from_camera \
                     (or camera.mount = \"world\")",
                ));
            }
            let written = check.pose("camera.tool_from_camera", pose, 2.0)?;
            Ok(calibration.and_then(|k| k.tool_from_camera).unwrap_or(written))
        }
        (RawCameraMount::World, Some(_)) => Err(check.invalid(
            "camera.tool_from_camera",
            "(given)",
            "is a hand camera's pose: a fixed camera (camera.mount = \"world\") is at camera.base_from_camera",
        )),
        (RawCameraMount::World, None) => {
            if calibration.is_some_and(|k| k.tool_from_camera.is_some()) {
                return Err(check.invalid(
                    "camera.calibration_file",
                    c.calibration_file.clone().unwrap_or_default(),
                    "holds a hand-eye transform (tool_from_camera), a hand camera's: a fixed camera \
                     (camera.mount = \"world\") is at camera.base_from_camera",
                ));
            }
            Ok(nalgebra::IsometryMatrix3::identity())
        }
    }
}

/// A fixed camera (`camera.mount = "world"`): `camera.base_from_camera` (within 5 m of the arm's base; the
/// calibration file's where it has one), and the
/// board on the tool where the desired pose puts it, `tool_from_board = tool_from_base(q_d) · base_from_camera
/// · camera_from_board_d` (within 1 m of the tool: a target held by the hand). `None` for a hand camera, which
/// must not give `camera.base_from_camera`.
pub fn fixed_camera(
    check: &Checker,
    c: &RawCamera,
    arm: &vservo_arm::SerialArm,
    desired: &crate::Desired,
    calibration: Option<&Calibration>,
) -> Result<Option<crate::FixedCamera>, ConfigError> {
    match (c.mount, &c.base_from_camera) {
        (RawCameraMount::Hand, None) => Ok(None),
        (RawCameraMount::Hand, Some(_)) => Err(check.invalid(
            "camera.base_from_camera",
            "(given)",
            "is a fixed camera's pose: write camera.mount = \"world\" (or leave it out for a camera on the hand)",
        )),
        (RawCameraMount::World, None) => Err(check.invalid(
            "camera.base_from_camera",
            "nothing",
            "must be given for a fixed camera (camera.mount = \"world\"): its pose in the arm's base frame",
        )),
        (RawCameraMount::World, Some(pose)) => {
            let written = check.pose("camera.base_from_camera", pose, 5.0)?;
            let base_from_camera = calibration.and_then(|k| k.base_from_camera).unwrap_or(written);
            let tool_from_board = arm.base_from_tool(&desired.joints).inverse()
                * base_from_camera
                * desired.camera_from_board;
            let reach_m = tool_from_board.translation.vector.norm();
            if reach_m > 1.0 {
                return Err(check.invalid(
                    "desired.camera_from_board",
                    format!("{:?}", tool_from_board.translation.vector.as_slice()),
                    format!(
                        "puts the board {reach_m:.2} m from the tool at desired.joints_rad, seen from \
                         camera.base_from_camera: a fixed camera's target rides on the tool (within 1 m)"
                    ),
                ));
            }
            Ok(Some(crate::FixedCamera { base_from_camera, tool_from_board }))
        }
    }
}

/// `[camera.truth]`, if written: the simulated camera as it really is (a calibration's known answer), its
/// intrinsics and its mount, each key the believed value where left out: vservo's simulated camera renders it,
/// and so does a driver that simulates the cell from `vservoctl scene` (an external camera: the reference
/// drivers). Refused with recorded images (a real camera is where it is; what it is, is for a calibration to
/// find).
pub fn truth(
    check: &Checker,
    c: &RawCamera,
    believed: &CameraIntrinsics,
    believed_tool_from_camera: &nalgebra::IsometryMatrix3<f64>,
) -> Result<Option<CameraTruth>, ConfigError> {
    let Some(t) = &c.truth else { return Ok(None) };
    if c.source == RawCameraSource::Directory {
        return Err(check.invalid(
            "camera.truth",
            "(given)",
            "is a simulated camera's: recorded images were taken by a real camera, which is where it is \
             (camera.source = \"simulated\", or \"external\" for a driver that simulates the cell)",
        ));
    }
    let focal = |key: &str, v: Option<f64>, believed: f64| {
        v.map_or(Ok(believed), |v| check.within(key, v, 1.0, 1e5, "px"))
    };
    let fx = focal("camera.truth.fx_px", t.fx_px, believed.fx_px())?;
    let fy = focal("camera.truth.fy_px", t.fy_px, believed.fy_px())?;
    let (width_px, height_px) = (believed.width_px(), believed.height_px());
    let key = "camera.truth.principal_point_px";
    let principal = match t.principal_point_px {
        None => believed.principal_point_px(),
        Some(p) => {
            let p = check.finite(key, p)?;
            if !(0.0..=f64::from(width_px)).contains(&p[0]) || !(0.0..=f64::from(height_px)).contains(&p[1]) {
                return Err(check.invalid(
                    key,
                    format!("{p:?}"),
                    format!("must lie in the {width_px}×{height_px} image"),
                ));
            }
            Point2::from(p)
        }
    };
    let distortion = match t.distortion {
        None => *believed.distortion(),
        Some(k) => {
            let k = check.all_within("camera.truth.distortion", k, -10.0, 10.0, "(k1, k2, p1, p2, k3)")?;
            Distortion::new(k)
                .map_err(|e| check.invalid("camera.truth.distortion", format!("{k:?}"), e.to_string()))?
        }
    };
    let intrinsics = CameraIntrinsics::with_lens([fx, fy], principal, width_px, height_px, distortion)
        .map_err(|e| check.invalid("camera.truth", format!("{t:?}"), e.to_string()))?;
    if c.mount == RawCameraMount::World && t.tool_from_camera.is_some() {
        return Err(check.invalid(
            "camera.truth.tool_from_camera",
            "(given)",
            "is a hand camera's pose: a fixed camera (camera.mount = \"world\") is at camera.base_from_camera",
        ));
    }
    let base_from_camera = match (&t.base_from_camera, c.mount) {
        (None, _) => None,
        (Some(pose), RawCameraMount::World) => {
            Some(check.pose("camera.truth.base_from_camera", pose, 5.0)?)
        }
        (Some(_), RawCameraMount::Hand) => {
            return Err(check.invalid(
                "camera.truth.base_from_camera",
                "(given)",
                "is a fixed camera's pose: a camera on the hand is at tool_from_camera",
            ));
        }
    };
    let tool_from_camera = match &t.tool_from_camera {
        None => *believed_tool_from_camera,
        Some(pose) => check.pose("camera.truth.tool_from_camera", pose, 2.0)?,
    };
    Ok(Some(CameraTruth { intrinsics, tool_from_camera, base_from_camera }))
}

/// `camera.source`, and the directory it names.
pub fn source(check: &Checker, c: &RawCamera) -> Result<VisionSource, ConfigError> {
    Ok(match c.source {
        RawCameraSource::Simulated => VisionSource::Simulated,
        RawCameraSource::External => VisionSource::External,
        RawCameraSource::Ros2 => VisionSource::Ros2,
        RawCameraSource::Gstreamer => {
            if c.gstreamer.is_none() {
                return Err(check.invalid(
                    "camera.source",
                    "\"gstreamer\"",
                    "needs the camera's pipeline: a [camera.gstreamer] table with pipeline = \"…\" \
                     (docs/DRIVERS.md, \"A real camera\")",
                ));
            }
            VisionSource::Gstreamer
        }
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

/// `[camera.gstreamer]`: a pipeline text, an appsink name, the exposure and gain within what cameras take.
pub fn gstreamer(check: &Checker, g: &RawGstreamer) -> Result<GstreamerCamera, ConfigError> {
    if g.pipeline.trim().is_empty() {
        return Err(check.invalid("camera.gstreamer.pipeline", "\"\"", "must be a GStreamer pipeline"));
    }
    // a camera's pipeline is a line or two; GStreamer's parser takes seconds over thousands of elements, deaf
    // to SIGTERM meanwhile
    if g.pipeline.len() > crate::MAX_PIPELINE_BYTES {
        return Err(check.invalid(
            "camera.gstreamer.pipeline",
            format!("({} bytes)", g.pipeline.len()),
            format!("longer than the {} bytes a camera's pipeline is taken up to", crate::MAX_PIPELINE_BYTES),
        ));
    }
    let appsink = g.appsink.clone().unwrap_or_else(|| "vservo".to_string());
    if appsink.is_empty() || !appsink.chars().all(|c| c.is_ascii_alphanumeric() || "_-".contains(c)) {
        return Err(check.invalid(
            "camera.gstreamer.appsink",
            format!("{appsink:?}"),
            "must be an element name (letters, digits, _ and -)",
        ));
    }
    let exposure_us = g
        .exposure_us
        .map(|v| check.within("camera.gstreamer.exposure_us", v, 1.0, 10_000_000.0, "µs"))
        .transpose()?;
    let gain_db =
        g.gain_db.map(|v| check.within("camera.gstreamer.gain_db", v, -20.0, 60.0, "dB")).transpose()?;
    let stall_periods = check.whole(
        "camera.gstreamer.stall_periods",
        g.stall_periods.unwrap_or(5),
        1u32,
        10_000,
        "must be a whole number of vision periods from 1 to 10000",
    )?;
    Ok(GstreamerCamera { pipeline: g.pipeline.clone(), appsink, exposure_us, gain_db, stall_periods })
}
