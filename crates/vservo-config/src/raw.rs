//! The file as written: serde structures that mirror the TOML, refusing unknown keys.

use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawConfig {
    pub instance: RawInstance,
    pub timing: RawTiming,
    pub camera: RawCamera,
    pub object: RawObject,
    pub desired: RawDesired,
    pub controller: RawController,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawInstance {
    pub name: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTiming {
    pub vision_period_s: f64,
    pub pipeline_delay_frames: i64,
    pub control_period_s: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCamera {
    pub focal_px: f64,
    pub principal_point_px: [f64; 2],
    pub width_px: i64,
    pub height_px: i64,
    pub tool_from_camera: RawPose,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPose {
    pub translation_m: [f64; 3],
    pub rotation_rpy_deg: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawObject {
    pub mark_diameter_m: f64,
    pub marks_in_board_m: Vec<[f64; 2]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDesired {
    pub joints_rad: Vec<f64>,
    pub camera_from_board: RawPose,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawController {
    pub law: String,
    pub q: toml::Value,
    pub r: toml::Value,
    pub r_units: String,
}
