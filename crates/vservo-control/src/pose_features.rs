//! Features of the target's pose, for the laws beyond image-based servoing: pose-based servoing (PBVS) and
//! 2½-D servoing (Malis, Chaumette & Boudet, IEEE T-RA 1999). An AprilTag of known size gives the target's pose
//! in the camera from its four corners through the calibrated lens; these are the errors a law drives to zero
//! and how they move with the camera's twist u = [v; ω] (in the camera's own frame, as everywhere in vservo):
//! ė = L u.
//!
//! - [`PoseFeatures::CameraPath`]: e = (c*t_c, θu) of the camera in the desired camera's frame,
//!   `L = [c*R_c, 0; 0, L_θu]`. The proportional law u = −λ L⁻¹ e moves the camera's origin on a straight line.
//! - [`PoseFeatures::TargetPath`]: e = (c t_o − c* t_o, θu), `L = [−I, [c t_o]×; 0, L_θu]`: the target's origin
//!   moves on a straight line in the camera's frame (and so in the image).
//! - [`PoseFeatures::TwoAndAHalfD`]: e = (x − x*, y − y*, log(Z/Z*), θu) of the target's origin (normalized image
//!   coordinates and depth), `L = [L_v, L_ω; 0, L_θu]` with the point's rows of the image Jacobian and the
//!   log-depth row `[0, 0, −1/Z, −y, x, 0]`.
//!
//! θu is the rotation c*R_c as an axis times its angle, and `L_θu = I + (θ/2)[u]× + (1 − sinc θ / sinc²(θ/2))[u]×²`
//! (ViSP's `vpFeatureThetaU` for c*R_c). The tests check every L against finite differences of a moving camera.
//! Pure functions, no allocation.

use nalgebra::{IsometryMatrix3, Matrix3, Matrix6, Rotation3, Vector3, Vector6};

/// Which pose features a law servoes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseFeatures {
    /// The camera's pose in the desired camera's frame: the camera moves on a straight line.
    CameraPath,
    /// The target's origin in the camera's frame and the rotation: the target moves on a straight line.
    TargetPath,
    /// 2½-D: the target origin's image point and log depth, and the rotation.
    TwoAndAHalfD,
}

/// The error of the features and how it moves with the camera's twist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseError {
    /// e, zero at the desired pose (m and rad; 2½-D: normalized image coordinates, log depth and rad).
    pub error: Vector6<f64>,
    /// L: ė = L u, u the camera's twist in its own frame.
    pub interaction: Matrix6<f64>,
}

/// Why no pose error can be formed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum PoseErrorRefused {
    /// The target's origin is not in front of the camera (2½-D needs its image point and depth).
    #[error("the target's origin is not in front of the camera (depth {depth_m} m)")]
    BehindCamera {
        /// Its depth (m).
        depth_m: f64,
    },
    /// A pose is not finite.
    #[error("a pose that is not finite")]
    NotFinite,
}

/// The skew-symmetric matrix of `v`: `skew(v) w = v × w`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-9 { 1.0 - x * x / 6.0 } else { x.sin() / x }
}

/// θu of a rotation: its axis times its angle (rad, in [0, π]). From the rotation's antisymmetric part and its
/// trace through `atan2` (accurate at small angles, where the trace's `acos` loses half the digits), and
/// nalgebra's axis-angle near π, where the antisymmetric part vanishes.
pub fn theta_u(rotation: &Rotation3<f64>) -> Vector3<f64> {
    let m = rotation.matrix();
    let sin_axis = Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]) * 0.5;
    let (sin, cos) = (sin_axis.norm(), (m.trace() - 1.0) / 2.0);
    let theta = sin.atan2(cos);
    if theta > 3.0 {
        rotation.scaled_axis()
    } else if sin == 0.0 {
        Vector3::zeros()
    } else {
        sin_axis * (theta / sin)
    }
}

/// L_θu: d(θu)/dt = L_θu ω for θu of c*R_c and ω the camera's angular velocity in its own frame.
pub fn theta_u_interaction(theta_u: &Vector3<f64>) -> Matrix3<f64> {
    let theta = theta_u.norm();
    if theta < 1e-12 {
        return Matrix3::identity();
    }
    let ux = skew(&(theta_u / theta));
    Matrix3::identity() + ux * (theta / 2.0) + ux * ux * (1.0 - sinc(theta) / sinc(theta / 2.0).powi(2))
}

impl PoseFeatures {
    /// The error and its interaction matrix with the target at `camera_from_target` and wanted at
    /// `desired_camera_from_target`.
    pub fn error(
        self,
        camera_from_target: &IsometryMatrix3<f64>,
        desired_camera_from_target: &IsometryMatrix3<f64>,
    ) -> Result<PoseError, PoseErrorRefused> {
        let finite = |pose: &IsometryMatrix3<f64>| pose.to_homogeneous().iter().all(|v| v.is_finite());
        if !finite(camera_from_target) || !finite(desired_camera_from_target) {
            return Err(PoseErrorRefused::NotFinite);
        }
        let desired_from_camera = desired_camera_from_target * camera_from_target.inverse();
        let theta_u = theta_u(&desired_from_camera.rotation);
        let l_theta_u = theta_u_interaction(&theta_u);
        let mut error = Vector6::zeros();
        let mut interaction = Matrix6::zeros();
        error.fixed_rows_mut::<3>(3).copy_from(&theta_u);
        interaction.fixed_view_mut::<3, 3>(3, 3).copy_from(&l_theta_u);
        match self {
            PoseFeatures::CameraPath => {
                error.fixed_rows_mut::<3>(0).copy_from(&desired_from_camera.translation.vector);
                interaction.fixed_view_mut::<3, 3>(0, 0).copy_from(desired_from_camera.rotation.matrix());
            }
            PoseFeatures::TargetPath => {
                let target = camera_from_target.translation.vector;
                error
                    .fixed_rows_mut::<3>(0)
                    .copy_from(&(target - desired_camera_from_target.translation.vector));
                interaction.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-Matrix3::identity()));
                interaction.fixed_view_mut::<3, 3>(0, 3).copy_from(&skew(&target));
            }
            PoseFeatures::TwoAndAHalfD => {
                let (point, depth) = image_point(camera_from_target)?;
                let (wanted, wanted_depth) = image_point(desired_camera_from_target)?;
                error[0] = point.x - wanted.x;
                error[1] = point.y - wanted.y;
                error[2] = (depth / wanted_depth).ln();
                let (x, y, z) = (point.x, point.y, depth);
                let rows = nalgebra::SMatrix::<f64, 3, 6>::from_row_slice(&[
                    -1.0 / z,
                    0.0,
                    x / z,
                    x * y,
                    -(1.0 + x * x),
                    y,
                    0.0,
                    -1.0 / z,
                    y / z,
                    1.0 + y * y,
                    -x * y,
                    -x,
                    0.0,
                    0.0,
                    -1.0 / z,
                    -y,
                    x,
                    0.0,
                ]);
                interaction.fixed_view_mut::<3, 6>(0, 0).copy_from(&rows);
            }
        }
        Ok(PoseError { error, interaction })
    }
}

/// The target origin's normalized image point and its depth.
fn image_point(
    camera_from_target: &IsometryMatrix3<f64>,
) -> Result<(nalgebra::Vector2<f64>, f64), PoseErrorRefused> {
    let origin = camera_from_target.translation.vector;
    if origin.z <= 0.0 {
        return Err(PoseErrorRefused::BehindCamera { depth_m: origin.z });
    }
    Ok((nalgebra::Vector2::new(origin.x / origin.z, origin.y / origin.z), origin.z))
}

/// The classic proportional law on these features, u = −λ L⁻¹ e (rad/s and m/s for λ in 1/s); `None` where L is
/// singular (θ = 2π, or a target at the camera's centre of projection).
pub fn proportional_twist(error: &PoseError, lambda_per_s: f64) -> Option<Vector6<f64>> {
    error.interaction.try_inverse().map(|inverse| -lambda_per_s * inverse * error.error)
}

#[cfg(test)]
mod tests {
    use nalgebra::Translation3;

    use super::*;

    /// The camera moved by the twist `u` (in its own frame) for `dt`: the target seen from the moved camera.
    fn moved(camera_from_target: &IsometryMatrix3<f64>, u: &Vector6<f64>, dt: f64) -> IsometryMatrix3<f64> {
        let v = Vector3::new(u[0], u[1], u[2]);
        let w = Vector3::new(u[3], u[4], u[5]);
        // first order in dt is what the derivative needs; the midpoint rotation keeps the error O(dt²)
        let camera_from_moved =
            IsometryMatrix3::from_parts(Translation3::from(v * dt), Rotation3::from_scaled_axis(w * dt));
        camera_from_moved.inverse() * camera_from_target
    }

    fn poses() -> Vec<(IsometryMatrix3<f64>, IsometryMatrix3<f64>)> {
        let desired = IsometryMatrix3::from_parts(
            Translation3::new(0.0, 0.0, 0.5),
            Rotation3::from_scaled_axis(Vector3::new(0.0, 0.0, 0.0)),
        );
        let mut out = Vec::new();
        for (k, angle) in [0.0, 0.3, 1.2, 2.8].iter().enumerate() {
            let axis = Vector3::new(0.3, -0.5 + 0.2 * k as f64, 0.8).normalize();
            let current = IsometryMatrix3::from_parts(
                Translation3::new(0.05 * k as f64, -0.03, 0.6 + 0.1 * k as f64),
                Rotation3::from_scaled_axis(axis * *angle),
            );
            let tilted = IsometryMatrix3::from_parts(
                Translation3::new(0.02, 0.01, 0.45),
                Rotation3::from_scaled_axis(Vector3::new(0.1, -0.2, 0.3)),
            );
            out.push((current, desired));
            out.push((current, tilted));
        }
        out
    }

    #[test]
    fn every_interaction_matrix_is_the_features_derivative_along_a_camera_twist() {
        let dt = 1e-6;
        for features in [PoseFeatures::CameraPath, PoseFeatures::TargetPath, PoseFeatures::TwoAndAHalfD] {
            for (current, desired) in poses() {
                let at = features.error(&current, &desired).expect("an error");
                for axis in 0..6 {
                    let u = Vector6::ith(axis, 1.0);
                    let ahead = features.error(&moved(&current, &u, dt), &desired).expect("an error");
                    let behind = features.error(&moved(&current, &u, -dt), &desired).expect("an error");
                    let measured = (ahead.error - behind.error) / (2.0 * dt);
                    let predicted = at.interaction * u;
                    assert!(
                        (measured - predicted).norm() < 1e-5,
                        "{features:?}, axis {axis}: measured {measured:?}, L u {predicted:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn theta_u_is_nalgebras_axis_angle_and_exact_at_small_angles() {
        for angle in [1e-9, 1e-6, 0.3, 1.5, 2.9, 3.1] {
            let axis = Vector3::new(0.2, -0.7, 0.4).normalize();
            let rotation = Rotation3::from_scaled_axis(axis * angle);
            assert!((theta_u(&rotation) - axis * angle).norm() < 1e-12 * angle.max(1e-3), "{angle}");
        }
        assert_eq!(theta_u(&Rotation3::identity()), Vector3::zeros());
    }

    #[test]
    fn theta_u_interaction_is_the_identity_at_rest_and_leaves_theta_u_unchanged() {
        assert_eq!(theta_u_interaction(&Vector3::zeros()), Matrix3::identity());
        let theta_u = Vector3::new(0.4, -1.0, 0.7);
        assert!((theta_u_interaction(&theta_u) * theta_u - theta_u).norm() < 1e-12);
    }

    /// How far the points of `path` stray from the straight line from its first point to `end` (m).
    fn off_line(path: &[Vector3<f64>], end: Vector3<f64>) -> f64 {
        let from = path[0];
        let direction = (end - from).normalize();
        path.iter().map(|p| ((p - from) - direction * (p - from).dot(&direction)).norm()).fold(0.0, f64::max)
    }

    /// The camera under u = −λ L⁻¹ e, integrated by Euler steps of 0.1 ms for 3 s: e decays as e(0)·exp(−λt)
    /// for each feature set; with CameraPath the camera's origin stays on the straight line to the desired pose,
    /// with TargetPath the target's origin stays on the straight line to where it is wanted in the camera.
    #[test]
    fn the_proportional_law_decays_exponentially_on_the_features_straight_lines() {
        let (lambda, dt, steps) = (1.0, 1e-4, 30_000);
        for features in [PoseFeatures::CameraPath, PoseFeatures::TargetPath, PoseFeatures::TwoAndAHalfD] {
            for (start, desired) in poses().into_iter().filter(|(c, _)| c.rotation.angle() < 2.0) {
                let first = features.error(&start, &desired).expect("an error").error;
                let mut current = start;
                let mut camera_in_desired = vec![(desired * current.inverse()).translation.vector];
                let mut target_in_camera = vec![current.translation.vector];
                for _ in 0..steps {
                    let error = features.error(&current, &desired).expect("an error");
                    let u = proportional_twist(&error, lambda).expect("L invertible");
                    current = moved(&current, &u, dt);
                    camera_in_desired.push((desired * current.inverse()).translation.vector);
                    target_in_camera.push(current.translation.vector);
                }
                let last = features.error(&current, &desired).expect("an error").error;
                let expected = first * (-lambda * dt * steps as f64).exp();
                assert!(
                    (last - expected).norm() <= 1e-3 * first.norm(),
                    "{features:?}: e(3 s) {last:?}, e(0)·exp(−3) {expected:?}"
                );
                let camera_off = off_line(&camera_in_desired, Vector3::zeros());
                let target_off = off_line(&target_in_camera, desired.translation.vector);
                println!(
                    "{features:?}, start {:.2} rad away: camera off its line {camera_off:.2e} m, target {target_off:.2e} m",
                    (desired * start.inverse()).rotation.angle()
                );
                match features {
                    PoseFeatures::CameraPath => {
                        assert!(camera_off < 1e-4, "the camera strays {camera_off} m")
                    }
                    PoseFeatures::TargetPath => {
                        assert!(target_off < 1e-4, "the target strays {target_off} m")
                    }
                    PoseFeatures::TwoAndAHalfD => {}
                }
            }
        }
    }

    #[test]
    fn a_target_behind_the_camera_or_a_pose_not_finite_is_refused() {
        let behind = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, -0.5), Rotation3::identity());
        let front = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Rotation3::identity());
        assert!(matches!(
            PoseFeatures::TwoAndAHalfD.error(&behind, &front),
            Err(PoseErrorRefused::BehindCamera { .. })
        ));
        let nan = IsometryMatrix3::from_parts(Translation3::new(f64::NAN, 0.0, 0.5), Rotation3::identity());
        assert_eq!(PoseFeatures::CameraPath.error(&nan, &front), Err(PoseErrorRefused::NotFinite));
    }
}
