//! The image Jacobian (paper eq. 3 and 5) and the discrete model B (eq. 12).

use nalgebra::SMatrix;
use vservo_scene::{CameraIntrinsics, FeatureVector, MARKS, MarkDepths};

use crate::InteractionMatrix;

/// The image Jacobian of one point (eq. 3): how its image (x, y) moves with the camera twist [v; ω].
/// `x` and `y` are relative to the principal point (px), `depth_m` is Z in the camera frame, `focal_px` f.
pub fn point_image_jacobian(x: f64, y: f64, depth_m: f64, focal_px: f64) -> SMatrix<f64, 2, 6> {
    let (f, z) = (focal_px, depth_m);
    SMatrix::<f64, 2, 6>::new(
        -f / z,
        0.0,
        x / z,
        x * y / f,
        -(x * x + f * f) / f,
        y,
        0.0,
        -f / z,
        y / z,
        (y * y + f * f) / f,
        -x * y / f,
        -x,
    )
}

/// The extended image Jacobian J⁺(ξ, Z) (eq. 5): the four point Jacobians stacked, 8 × 6.
/// `features` are image coordinates (px, origin top-left); the principal point is subtracted here.
pub fn extended_image_jacobian(
    camera: &CameraIntrinsics,
    features: &FeatureVector,
    depths: &MarkDepths,
) -> InteractionMatrix {
    let centre = camera.principal_point_px();
    let mut jacobian = InteractionMatrix::zeros();
    for mark in 0..MARKS {
        let x = features[2 * mark] - centre.x;
        let y = features[2 * mark + 1] - centre.y;
        let rows = point_image_jacobian(x, y, depths[mark], camera.focal_px());
        jacobian.fixed_view_mut::<2, 6>(2 * mark, 0).copy_from(&rows);
    }
    jacobian
}

/// The discrete model of eq. (12), B = T·J⁺(ξ, Z): the feature change over one vision period `period_s`
/// under a constant twist.
pub fn interaction_matrix(
    camera: &CameraIntrinsics,
    features: &FeatureVector,
    depths: &MarkDepths,
    period_s: f64,
) -> InteractionMatrix {
    extended_image_jacobian(camera, features, depths) * period_s
}
