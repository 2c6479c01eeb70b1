//! `[collision]` and `[[scene.obstacles]]`, validated: what the guard keeps the arm off and at what distances.

pub use vservo_settings::collision::{Obstacle, Primitive, PrimitiveKind, Solid, Workspace};

/// The guard's settings (`[collision]` given).
#[derive(Debug, Clone, PartialEq)]
pub struct Collision {
    /// Below this a motion that closes a distance is slowed (m).
    pub slowdown_distance_m: f64,
    /// The arm stops before a distance is below this (m).
    pub stop_distance_m: f64,
    /// Pairs never checked besides the arm's neighbouring links (link, obstacle or `"camera"` names).
    pub disabled_pairs: Vec<[String; 2]>,
    /// The URDF whose `<collision>` elements are the arm's shapes (`None`: the arm has none, as the built-in
    /// PUMA 560, or `collision.arm_shapes = false`).
    pub arm_urdf: Option<String>,
    /// The camera and its mount, as a box in the camera frame.
    pub camera_box: Option<CameraBox>,
    /// The box the tool and the camera stay inside, in the base frame.
    pub workspace: Option<Workspace>,
    /// What stands around the arm.
    pub obstacles: Vec<Obstacle>,
    /// Whether the board is an obstacle too (a thin box behind its face).
    pub board: bool,
}

/// The camera and its mount as a box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraBox {
    /// Its edge lengths along the camera's x, y and z (m).
    pub size_m: [f64; 3],
    /// Its centre in the camera frame (m).
    pub centre_in_camera_m: [f64; 3],
}
