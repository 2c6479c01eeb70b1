//! Poses as vservo's messages carry them: the top three rows of the 4×4 transform, [R | t] row-major.

use nalgebra::IsometryMatrix3;

/// A pose as the wire carries it (`sim_world.base_from_board`, `features.base_from_camera`): 3×4 [R | t]
/// row-major.
pub fn pose_to_rows(pose: &IsometryMatrix3<f64>) -> [f64; 12] {
    let (r, t) = (pose.rotation.matrix(), pose.translation.vector);
    let mut out = [0.0; 12];
    for row in 0..3 {
        for col in 0..3 {
            out[4 * row + col] = r[(row, col)];
        }
        out[4 * row + 3] = t[row];
    }
    out
}

/// The pose from a 3×4 [R | t] row-major array; `None` if a number is not finite or R is not a rotation
/// (RᵀR = I and det R = 1 to 1e-6).
pub fn pose_from_rows(m: &[f64; 12]) -> Option<IsometryMatrix3<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let rotation = nalgebra::Matrix3::new(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
    let orthonormal = (rotation.transpose() * rotation - nalgebra::Matrix3::identity()).amax() < 1e-6;
    if !orthonormal || (rotation.determinant() - 1.0).abs() > 1e-6 {
        return None;
    }
    Some(IsometryMatrix3::from_parts(
        nalgebra::Vector3::new(m[3], m[7], m[11]).into(),
        nalgebra::Rotation3::from_matrix_unchecked(rotation),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_survive_their_rows_and_non_finite_ones_are_refused() {
        let pose = IsometryMatrix3::from_parts(
            nalgebra::Translation3::new(1.2, -0.15, 0.66),
            nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 1.1),
        );
        assert_eq!(pose_from_rows(&pose_to_rows(&pose)), Some(pose));
        let mut broken = pose_to_rows(&pose);
        broken[7] = f64::INFINITY;
        assert_eq!(pose_from_rows(&broken), None);
        // a matrix that is not a rotation is no pose
        let mut scaled = pose_to_rows(&pose);
        scaled[0] *= 1.01;
        assert_eq!(pose_from_rows(&scaled), None);
        let mirrored = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        assert_eq!(pose_from_rows(&mirrored), None);
    }
}
