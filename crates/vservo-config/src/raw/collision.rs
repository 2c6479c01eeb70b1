//! `[collision]` and `[[scene.obstacles]]` as written.

use serde::Deserialize;

/// `[collision]`: the guard that keeps the arm off what stands around it (its section given: the guard on).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawCollision {
    pub slowdown_distance_m: f64,
    pub stop_distance_m: f64,
    pub disabled_pairs: Vec<[String; 2]>,
    pub arm_shapes: bool,
    pub camera_box_m: Option<[f64; 3]>,
    pub camera_box_centre_m: [f64; 3],
    pub workspace_min_m: Option<[f64; 3]>,
    pub workspace_max_m: Option<[f64; 3]>,
    pub board: bool,
}

/// config/vservo.toml's documented defaults.
impl Default for RawCollision {
    fn default() -> Self {
        Self {
            slowdown_distance_m: 0.10,
            stop_distance_m: 0.03,
            disabled_pairs: Vec::new(),
            arm_shapes: true,
            camera_box_m: None,
            camera_box_centre_m: [0.0; 3],
            workspace_min_m: None,
            workspace_max_m: None,
            board: true,
        }
    }
}

/// `[scene]`: what stands around the arm.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawScene {
    pub obstacles: Vec<RawObstacle>,
}

/// One `[[scene.obstacles]]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawObstacle {
    pub name: String,
    pub shape: RawObstacleShape,
    #[serde(default)]
    pub size_m: Option<[f64; 3]>,
    #[serde(default)]
    pub radius_m: Option<f64>,
    #[serde(default)]
    pub length_m: Option<f64>,
    #[serde(default)]
    pub translation_m: [f64; 3],
    #[serde(default)]
    pub rotation_rpy_deg: [f64; 3],
}

/// `scene.obstacles[k].shape`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawObstacleShape {
    Box,
    Cylinder,
    Capsule,
    Sphere,
    Plane,
}
