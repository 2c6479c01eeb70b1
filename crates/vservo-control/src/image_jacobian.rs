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

/// The image Jacobian of one point on a camera with focal lengths `fx_px` and `fy_px` (non-square pixels):
/// the pinhole projection u = fx·X/Z, v = fy·Y/Z differentiated as eq. (3) is, with `x`, `y` the pinhole
/// pixel relative to the principal point. With fx = fy it is [`point_image_jacobian`], the paper's formula
/// computed as the paper's.
pub fn point_image_jacobian_fx_fy(
    x: f64,
    y: f64,
    depth_m: f64,
    fx_px: f64,
    fy_px: f64,
) -> SMatrix<f64, 2, 6> {
    if fx_px == fy_px {
        return point_image_jacobian(x, y, depth_m, fx_px);
    }
    let (fx, fy, z) = (fx_px, fy_px, depth_m);
    SMatrix::<f64, 2, 6>::new(
        -fx / z,
        0.0,
        x / z,
        x * y / fy,
        -(x * x + fx * fx) / fx,
        fx * y / fy,
        0.0,
        -fy / z,
        y / z,
        (y * y + fy * fy) / fy,
        -x * y / fx,
        -fy * x / fx,
    )
}

/// The extended image Jacobian J⁺(ξ, Z) (eq. 5): the four point Jacobians stacked, 8 × 6.
/// `features` are pinhole image coordinates (px, origin top-left: undistorted when the lens distorts); the
/// principal point is subtracted here.
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
        let rows = point_image_jacobian_fx_fy(x, y, depths[mark], camera.fx_px(), camera.fy_px());
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point2, Point3, Rotation3, Vector2, Vector6};

    /// The pinhole pixel of `point` after the camera moves by `twist` [v; ω] for `dt`: the point's velocity
    /// in the camera frame is −v − ω × p.
    fn moved_pixel(
        camera: &CameraIntrinsics,
        point: &Point3<f64>,
        twist: &Vector6<f64>,
        dt: f64,
    ) -> Point2<f64> {
        let (v, w) = (twist.fixed_rows::<3>(0).into_owned(), twist.fixed_rows::<3>(3).into_owned());
        // exact rigid motion of the point relative to the camera over dt (the camera's twist held)
        let rotation = Rotation3::new(-w * dt);
        let moved = rotation * (point.coords - v * dt);
        camera.project(&Point3::from(moved)).expect("in front")
    }

    #[test]
    fn the_jacobian_with_fx_and_fy_is_the_derivative_of_the_projection() {
        let camera = CameraIntrinsics::with_lens(
            [600.0, 640.0],
            Point2::new(330.0, 250.0),
            640,
            480,
            Default::default(),
        )
        .expect("valid");
        let centre = camera.principal_point_px();
        for point in
            [Point3::new(0.05, -0.03, 0.5), Point3::new(-0.12, 0.08, 0.7), Point3::new(0.0, 0.0, 0.4)]
        {
            let pixel = camera.project(&point).expect("in front");
            let jacobian =
                point_image_jacobian_fx_fy(pixel.x - centre.x, pixel.y - centre.y, point.z, 600.0, 640.0);
            for axis in 0..6 {
                let twist = Vector6::from_fn(|i, _| if i == axis { 1.0 } else { 0.0 });
                let h = 1e-6;
                let ahead = moved_pixel(&camera, &point, &twist, h);
                let behind = moved_pixel(&camera, &point, &twist, -h);
                let derivative = (ahead - behind) / (2.0 * h);
                let column = jacobian.column(axis);
                assert!(
                    (derivative - Vector2::new(column[0], column[1])).norm()
                        < 1e-5 * (1.0 + derivative.norm()),
                    "axis {axis}: finite differences {derivative:?}, Jacobian {column:?}"
                );
            }
        }
    }

    #[test]
    fn with_square_pixels_it_is_the_papers_formula_bit_for_bit() {
        let (x, y, z, f) = (-93.25, 41.5, 0.61, 500.0);
        assert_eq!(point_image_jacobian_fx_fy(x, y, z, f, f), point_image_jacobian(x, y, z, f));
    }
}
