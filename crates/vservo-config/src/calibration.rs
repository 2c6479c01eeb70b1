//! Camera calibration files: the intrinsics and the lens from a ROS `camera_info` YAML (the
//! `camera_calibration` package's format: `image_width`, `image_height`, `camera_matrix.data`,
//! `distortion_model: plumb_bob`, `distortion_coefficients.data`) or an OpenCV FileStorage YAML (`%YAML:1.0`,
//! `!!opencv-matrix` maps with `rows`, `cols`, `dt`, `data`; keys `camera_matrix`, `distortion_coefficients`,
//! `image_width`, `image_height`).
//!
//! Parsed with `yaml-rust2` (pure Rust, maintained; `serde_yaml` is unmaintained and `serde_yml` unsound):
//! its document tree lets every error name the key. OpenCV's `%YAML:1.0` header is not a YAML directive
//! (YAML writes `%YAML 1.0`): it is taken out before parsing; the `!!opencv-matrix` tag is a YAML tag the
//! parser reads and this module ignores.

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
    /// cx, cy (px).
    pub principal_point_px: [f64; 2],
    /// OpenCV's k1, k2, p1, p2, k3 (k3 = 0 when the file gives four).
    pub distortion: [f64; 5],
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

fn refuse(key: &str, reason: impl Into<String>) -> CalibrationError {
    CalibrationError::Key { key: key.to_string(), reason: reason.into() }
}

/// The calibration a ROS `camera_info` or OpenCV FileStorage YAML text gives.
pub fn parse(text: &str) -> Result<Calibration, CalibrationError> {
    let yaml_text = without_opencv_header(text);
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
    })
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
    Ok(([k[0], k[4]], [k[2], k[5]]))
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
