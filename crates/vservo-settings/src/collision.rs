//! The collision guard's solids and workspace as plain values: what the configuration gives and the guard
//! (`vservo-collision`) builds its shapes from.

/// A solid as a configuration or a robot description gives it, centred on its own frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// A box of these full edge lengths along its frame's x, y and z.
    Box {
        /// The edge lengths (m).
        size_m: [f64; 3],
    },
    /// A cylinder along its frame's z (a URDF `<cylinder>`).
    Cylinder {
        /// Its radius (m).
        radius_m: f64,
        /// Its length, end to end (m).
        length_m: f64,
    },
    /// A capsule along its frame's z: a cylinder of this length with a half-ball on each end.
    Capsule {
        /// Its radius (m).
        radius_m: f64,
        /// The length of its cylinder (m).
        length_m: f64,
    },
    /// A ball.
    Sphere {
        /// Its radius (m).
        radius_m: f64,
    },
    /// Everything below its frame's xy plane (z ≤ 0): a floor or a wall with no end.
    HalfSpace,
}

/// A box the tool and the camera stay inside, in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// Its lowest corner (m).
    pub min_m: [f64; 3],
    /// Its highest corner (m).
    pub max_m: [f64; 3],
}
