//! Camera calibration files: the intrinsics and the lens from a ROS `camera_info` YAML (the
//! `camera_calibration` package's format: `image_width`, `image_height`, `camera_matrix.data`,
//! `distortion_model: plumb_bob`, `distortion_coefficients.data`) or an OpenCV FileStorage YAML (`%YAML:1.0`,
//! `!!opencv-matrix` maps with `rows`, `cols`, `dt`, `data`; keys `camera_matrix`, `distortion_coefficients`,
//! `image_width`, `image_height`).
//!
//! Pixels: OpenCV and ROS put a pixel's centre at integer coordinates, vservo at + ½ (its pixel (u, v) covers
//! [u, u+1) × [v, v+1), docs/ARCHITECTURE.md): the file's principal point is taken + ½ px on each axis
//! ([`OPENCV_TO_VSERVO_PX`]), and `vservoctl calibrate` writes its files the other way round.
//!
//! Parsed with `yaml-rust2` (pure Rust, maintained; `serde_yaml` is unmaintained and `serde_yml` unsound):
//! its document tree lets every error name the key. OpenCV's `%YAML:1.0` header is not a YAML directive
//! (YAML writes `%YAML 1.0`): it is taken out before parsing; the `!!opencv-matrix` tag is a YAML tag the
//! parser reads and this module ignores.

use vservo_scene::OPENCV_TO_VSERVO_PX;
use yaml_rust2::{Yaml, YamlLoader};

/// What a calibration file gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Image width (px).
    pub width_px: u32,
    /// Image height (px).
    pub height_px: u32,
    /// fx, fy (px).
    pub focal_px: [f64; 2],
    /// cx, cy (px, vservo's pixels: the file's + [`OPENCV_TO_VSERVO_PX`]).
    pub principal_point_px: [f64; 2],
    /// OpenCV's k1, k2, p1, p2, k3 (k3 = 0 when the file gives four).
    pub distortion: [f64; 5],
    /// The hand-eye transform, where the file has one (`tool_from_camera`, a 4 × 4 rigid transform, rows; a
    /// file of `vservoctl calibrate`): it then takes the place of `camera.tool_from_camera`.
    pub tool_from_camera: Option<nalgebra::IsometryMatrix3<f64>>,
    /// A fixed camera's pose in the arm's base, where the file has one (`base_from_camera`, as
    /// `tool_from_camera`; a file of `vservoctl calibrate` on an eye-to-hand cell): it then takes the place of
    /// `camera.base_from_camera`.
    pub base_from_camera: Option<nalgebra::IsometryMatrix3<f64>>,
}

/// Why a calibration file's text was refused: the key (dotted, inside the file) and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    /// Not YAML.
    #[error("not YAML: {0}")]
    NotYaml(String),
    /// A key is missing or its value is not acceptable.
    #[error("{key}: {reason}")]
    Key {
        /// The key in the file.
        key: String,
        /// What is wrong with it.
        reason: String,
    },
}

/// The largest calibration text read (bytes): a camera_info or OpenCV file is a few hundred.
pub const MAX_CALIBRATION_BYTES: usize = 1 << 20;
/// The deepest nesting of maps and sequences in one (it has two levels).
const MAX_CALIBRATION_DEPTH: usize = 16;
/// The most YAML events (keys, values, collections) in one.
const MAX_CALIBRATION_EVENTS: usize = 10_000;

/// The text's YAML events within the bounds, read flat (the loader recurses and expands aliases: a file of
/// nested aliases grows to gigabytes, one of deep nesting overflows the stack), and no alias: a calibration file
/// has none.
fn within_bounds(text: &str) -> Result<(), CalibrationError> {
    use yaml_rust2::parser::{Event, Parser};
    if text.len() > MAX_CALIBRATION_BYTES {
        return Err(CalibrationError::NotYaml(format!(
            "{} bytes, more than the {MAX_CALIBRATION_BYTES} a calibration file is read up to",
            text.len()
        )));
    }
    let mut parser = Parser::new_from_str(text);
    let (mut depth, mut events) = (0usize, 0usize);
    loop {
        let (event, mark) = parser.next_token().map_err(|e| CalibrationError::NotYaml(e.to_string()))?;
        events += 1;
        let line = mark.line();
        match event {
            Event::StreamEnd => return Ok(()),
            Event::Alias(_) => {
                return Err(CalibrationError::NotYaml(format!(
                    "an alias (*…) at line {line}: a calibration file has none, and they are not expanded"
                )));
            }
            Event::MappingStart(..) | Event::SequenceStart(..) => depth += 1,
            Event::MappingEnd | Event::SequenceEnd => depth = depth.saturating_sub(1),
            _ => {}
        }
        if depth > MAX_CALIBRATION_DEPTH {
            return Err(CalibrationError::NotYaml(format!(
                "maps and sequences nest deeper than {MAX_CALIBRATION_DEPTH} at line {line}"
            )));
        }
        if events > MAX_CALIBRATION_EVENTS {
            return Err(CalibrationError::NotYaml(format!("more than {MAX_CALIBRATION_EVENTS} YAML events")));
        }
    }
}

fn refuse(key: &str, reason: impl Into<String>) -> CalibrationError {
    CalibrationError::Key { key: key.to_string(), reason: reason.into() }
}

/// The calibration a ROS `camera_info` or OpenCV FileStorage YAML text gives.
pub fn parse(text: &str) -> Result<Calibration, CalibrationError> {
    let yaml_text = without_opencv_header(text);
    within_bounds(&yaml_text)?;
    let documents =
        YamlLoader::load_from_str(&yaml_text).map_err(|e| CalibrationError::NotYaml(e.to_string()))?;
    let root = documents.first().ok_or_else(|| CalibrationError::NotYaml("no document".into()))?;
    if root.as_hash().is_none() {
        return Err(CalibrationError::NotYaml("the document is not a map of keys".into()));
    }
    let width_px = image_size(root, "image_width")?;
    let height_px = image_size(root, "image_height")?;
    let camera_matrix = matrix(root, "camera_matrix", &[9])?;
    let (focal_px, principal_point_px) = pinhole(&camera_matrix)?;
    distortion_model(root)?;
    let coefficients = matrix(root, "distortion_coefficients", &[4, 5, 8, 12, 14])?;
    Ok(Calibration {
        width_px,
        height_px,
        focal_px,
        principal_point_px,
        distortion: plumb_bob(&coefficients)?,
        tool_from_camera: hand_eye(root, "tool_from_camera", 2.0)?,
        base_from_camera: hand_eye(root, "base_from_camera", 5.0)?,
    })
}

/// `tool_from_camera` (or a fixed camera's `base_from_camera`), if the file has it: a rigid transform (a
/// rotation to 1e-6, the last row 0 0 0 1) whose translation is within `reach_m` (2 m of the tool, 5 m of the
/// base).
fn hand_eye(
    root: &Yaml,
    key: &'static str,
    reach_m: f64,
) -> Result<Option<nalgebra::IsometryMatrix3<f64>>, CalibrationError> {
    if matches!(root[key], Yaml::BadValue) {
        return Ok(None);
    }
    let m = nalgebra::Matrix4::from_row_slice(&matrix(root, key, &[16])?);
    let rotation = m.fixed_view::<3, 3>(0, 0).into_owned();
    let orthonormal = (rotation.transpose() * rotation - nalgebra::Matrix3::identity()).amax() < 1e-6
        && (rotation.determinant() - 1.0).abs() < 1e-6;
    let last_row = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]] == [0.0, 0.0, 0.0, 1.0];
    if !orthonormal || !last_row {
        return Err(refuse(
            &format!("{key}.data"),
            "is not a rigid transform (a rotation, a translation, the last row 0 0 0 1)",
        ));
    }
    let translation = nalgebra::Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
    if translation.amax() > reach_m {
        let frame = if key == "tool_from_camera" { "the tool" } else { "the arm's base" };
        return Err(refuse(
            &format!("{key}.data"),
            format!("its translation {:?} m is not within {reach_m} m of {frame}", translation.as_slice()),
        ));
    }
    let rotation = nalgebra::Rotation3::from_matrix(&rotation);
    Ok(Some(nalgebra::IsometryMatrix3::from_parts(translation.into(), rotation)))
}

/// The text with OpenCV's `%YAML:1.0` line taken out (YAML's own `%YAML 1.x` directive is kept).
fn without_opencv_header(text: &str) -> String {
    text.lines().filter(|line| !line.trim_start().starts_with("%YAML:")).collect::<Vec<_>>().join("\n")
}

fn image_size(root: &Yaml, key: &str) -> Result<u32, CalibrationError> {
    match &root[key] {
        Yaml::Integer(v) if (1..=16384).contains(v) => Ok(*v as u32),
        Yaml::BadValue => Err(refuse(key, "missing")),
        other => {
            Err(refuse(key, format!("{} must be a whole number of pixels from 1 to 16384", shown(other))))
        }
    }
}

/// `key`'s numbers: a map with `data` (ROS, and OpenCV's `!!opencv-matrix` with `rows`, `cols` and `dt`)
/// whose count is one of `counts` and, where given, rows × cols.
fn matrix(root: &Yaml, key: &str, counts: &[usize]) -> Result<Vec<f64>, CalibrationError> {
    let node = &root[key];
    if matches!(node, Yaml::BadValue) {
        return Err(refuse(key, "missing"));
    }
    let data_key = format!("{key}.data");
    let Some(items) = node["data"].as_vec() else {
        return Err(refuse(&data_key, "missing or not a list of numbers"));
    };
    let values: Vec<f64> = items
        .iter()
        .enumerate()
        .map(|(i, item)| {
            number(item).ok_or_else(|| {
                refuse(&format!("{data_key}[{i}]"), format!("{} is not a finite number", shown(item)))
            })
        })
        .collect::<Result<_, _>>()?;
    if !counts.contains(&values.len()) {
        return Err(refuse(&data_key, format!("has {} numbers: must have {}", values.len(), list(counts))));
    }
    let dimension = |name: &str| match &node[name] {
        Yaml::Integer(v) => Ok(Some(*v)),
        Yaml::BadValue => Ok(None),
        other => Err(refuse(&format!("{key}.{name}"), format!("{} must be a whole number", shown(other)))),
    };
    if let (Some(rows), Some(cols)) = (dimension("rows")?, dimension("cols")?)
        && rows.checked_mul(cols) != Some(values.len() as i64)
    {
        return Err(refuse(
            &format!("{key}.rows"),
            format!("{rows} × {cols} is not the {} numbers of data", values.len()),
        ));
    }
    Ok(values)
}

/// A number (YAML writes whole ones without a point).
fn number(item: &Yaml) -> Option<f64> {
    let value = match item {
        Yaml::Real(_) => item.as_f64()?,
        Yaml::Integer(v) => *v as f64,
        _ => return None,
    };
    value.is_finite().then_some(value)
}

/// fx, fy and cx, cy of K = [fx 0 cx; 0 fy cy; 0 0 1].
fn pinhole(k: &[f64]) -> Result<([f64; 2], [f64; 2]), CalibrationError> {
    let key = "camera_matrix.data";
    if k[1] != 0.0 {
        return Err(refuse(key, format!("skew {} is not 0: vservo's camera has none", k[1])));
    }
    if k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(refuse(key, format!("{:?} is not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]", k)));
    }
    if !(k[0] > 0.0 && k[4] > 0.0) {
        return Err(refuse(key, format!("focal lengths fx = {}, fy = {} must be positive", k[0], k[4])));
    }
    Ok(([k[0], k[4]], [k[2] + OPENCV_TO_VSERVO_PX, k[5] + OPENCV_TO_VSERVO_PX]))
}

/// ROS names the model; OpenCV's files do not (and mean OpenCV's, whose first five are plumb_bob's).
fn distortion_model(root: &Yaml) -> Result<(), CalibrationError> {
    match &root["distortion_model"] {
        Yaml::BadValue => Ok(()),
        Yaml::String(model) if model == "plumb_bob" => Ok(()),
        other => Err(refuse(
            "distortion_model",
            format!("{} is not supported: vservo's lens is plumb_bob (k1, k2, p1, p2, k3)", shown(other)),
        )),
    }
}

/// k1, k2, p1, p2, k3 from OpenCV's 4, 5, 8, 12 or 14 coefficients; the terms beyond plumb_bob must be 0.
fn plumb_bob(coefficients: &[f64]) -> Result<[f64; 5], CalibrationError> {
    if let Some((i, v)) = coefficients.iter().enumerate().skip(5).find(|(_, v)| **v != 0.0) {
        return Err(refuse(
            &format!("distortion_coefficients.data[{i}]"),
            format!("{v} is not 0: only k1, k2, p1, p2, k3 (plumb_bob) are supported"),
        ));
    }
    let mut out = [0.0; 5];
    for (o, c) in out.iter_mut().zip(coefficients) {
        *o = *c;
    }
    Ok(out)
}

fn list(counts: &[usize]) -> String {
    let names: Vec<String> = counts.iter().map(usize::to_string).collect();
    names.join(" or ")
}

/// A value as it reads in a message.
fn shown(value: &Yaml) -> String {
    match value {
        Yaml::Real(v) | Yaml::String(v) => format!("{v:?}"),
        Yaml::Integer(v) => v.to_string(),
        Yaml::Boolean(v) => v.to_string(),
        Yaml::Null => "null".into(),
        Yaml::Array(_) => "a list".into(),
        Yaml::Hash(_) => "a map".into(),
        Yaml::Alias(_) | Yaml::BadValue => "nothing".into(),
    }
}
