//! # vservo-scene — what the camera looks at
//!
//! This crate owns the geometry shared by the controller, the vision and the simulator:
//! - [`CameraIntrinsics`]: the camera (focal lengths fx, fy in pixels, principal point, image size, the lens's
//!   [`Distortion`] in [`lens`]) and the projection of points given in the camera frame (x right, y down, z
//!   along the optical axis), to the pinhole pixel ([`CameraIntrinsics::project`]: what ξ, ξ_d and the image
//!   Jacobian are in) and through the lens to the observed (distorted) one
//!   ([`CameraIntrinsics::project_observed`], [`CameraIntrinsics::observed_of_pinhole`],
//!   [`CameraIntrinsics::pinhole_of_observed`]); without distortion every mapping is the pinhole's;
//! - [`lens`]: OpenCV's Brown–Conrady distortion ([`Distortion`]: k1, k2, p1, p2, k3): `distort` is
//!   `cv::projectPoints`'s formula, `undistort` Newton's method to 1e-14 (normalised) in at most 20 steps,
//!   refused outside the lens's valid radius; checked against OpenCV in `tests/opencv_lens.rs` (the fixture by
//!   `scripts/lens-reference.py`);
//! - [`Board`]: the object — a board with four disc marks, their centres in the board frame, or with one
//!   AprilTag whose four corners are the marks ([`Target`], [`AprilTag`]: id, size, centre, corners in the C
//!   library's order, which cell is black; [`AprilTag::with_corners_covered`]: a scenario's occlusion of a
//!   corner), or with a bundle of up to eight tags whose outer corners are the marks ([`TagBundle`]);
//!   [`tag36h11`]: the family's codes and bit positions, from the C library's `tag36h11.c`;
//! - [`TagGrid`]: a calibration board, a grid of tag36h11 tags with white gaps (ids row by row, corners in
//!   the board frame, [`TagGrid::is_black_at`], [`TagGrid::tags_meeting`] a box), which a [`Board`] may carry
//!   printed on it (`Board::calibration_grid`; the renderer judges a pixel against every tag that can reach
//!   it, the target's tag deciding inside its own square);
//! - [`fit_homography`]: a plane's homography to the image from any number of point pairs (the normalised
//!   DLT), which finds a bundle's outer corners from the tags seen;
//! - [`CameraMount`]: a camera on the hand or fixed in the world (the board then on the tool): where camera and
//!   board are for a tool pose, and the tool twist that moves the camera relative to the board as a law asks;
//! - [`pose_rows`]: a pose as vservo's messages carry it, the top three rows of the 4×4 transform
//!   (3×4 [R | t], row-major);
//! - the feature vector ξ = [x₁ y₁ x₂ y₂ x₃ y₃ x₄ y₄] (pixels, image origin top-left) in the board's mark
//!   order, which never changes from frame to frame, and the marks' depths.
//!
//! Transforms are named `a_from_b` and map points given in `b` into `a`.
//!
//! ```
//! use nalgebra::{Translation3, Vector3};
//! use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3};
//!
//! let camera = CameraIntrinsics::paper();
//! let board = Board::paper();
//! let camera_from_board = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Default::default());
//! let features = camera.project_marks(&board, &camera_from_board).expect("all marks in front");
//! assert!((features[0] - 151.0).abs() < 1e-9 && (features[1] - 168.0).abs() < 1e-9);
//! ```

mod board;
mod bundle;
mod camera;
mod homography;
pub mod lens;
mod mount;
pub mod pose_rows;
pub mod tag36h11;
mod tag_grid;

pub use board::{AprilTag, Board, MARKS, SHEET_MARGIN_CELLS, Target, UnknownTagId};
pub use bundle::{BundleError, MAX_BUNDLE_TAGS, TagBundle};
pub use camera::{CameraIntrinsics, IntrinsicsError, OPENCV_TO_VSERVO_PX, ProjectionError, image_contains};
pub use homography::{apply_homography, fit_homography};
pub use lens::{Distortion, DistortionError};
pub use mount::CameraMount;
pub use nalgebra::IsometryMatrix3;
pub use tag_grid::{TagGrid, TagGridError};

/// The angle of a rotation (rad, 0 to π), from its matrix's skew and symmetric parts (atan2): defined for a matrix
/// a rounding off orthonormal, where nalgebra's `Rotation3::angle` (the arccosine of (trace − 1)/2) is NaN once
/// rounding puts the cosine past 1, as it does for two poses the same to the last bits.
pub fn rotation_angle_rad(rotation: &nalgebra::Rotation3<f64>) -> f64 {
    let m = rotation.matrix();
    let sine = nalgebra::Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)])
        .norm()
        / 2.0;
    let cosine = (m.trace() - 1.0) / 2.0;
    sine.atan2(cosine)
}

/// Number of image features: x and y of each mark.
pub const FEATURES: usize = 2 * MARKS;
/// The feature vector ξ (pixels).
pub type FeatureVector = nalgebra::SVector<f64, FEATURES>;
/// The depths of the four marks in the camera frame (m).
pub type MarkDepths = nalgebra::SVector<f64, MARKS>;

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Rotation3, Vector3};
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_angle_of_a_rotation_is_its_axis_angle(x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0, angle in 0.0f64..3.1) {
            let axis = Vector3::new(x, y, z);
            prop_assume!(axis.norm() > 1e-3);
            let rotation = Rotation3::from_scaled_axis(axis.normalize() * angle);
            prop_assert!((rotation_angle_rad(&rotation) - angle).abs() < 1e-12);
        }
    }

    /// Two poses the same to the last bits: a matrix a rounding past orthonormal has trace 3 + 1e-15, whose
    /// arccosine is NaN; its angle is 0.
    #[test]
    fn a_rotation_a_rounding_off_the_identity_has_angle_zero() {
        let rounded = Rotation3::from_matrix_unchecked(Matrix3::<f64>::identity() * (1.0 + 1e-15));
        assert!(rounded.angle().is_nan(), "the premise: nalgebra's arccosine");
        assert!(rotation_angle_rad(&rounded).abs() < 1e-12);
    }
}
