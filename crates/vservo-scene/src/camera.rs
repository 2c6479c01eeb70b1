//! The pinhole camera and projection.

use nalgebra::{Point2, Point3};

use crate::{Board, Distortion, FeatureVector, IsometryMatrix3, MARKS, MarkDepths};

/// What is added to an OpenCV or ROS pixel coordinate to make it vservo's (the same point): OpenCV and ROS put a
/// pixel's centre at integer coordinates, vservo at + ½ (its pixel (u, v) covers [u, u+1) × [v, v+1)).
pub const OPENCV_TO_VSERVO_PX: f64 = 0.5;

/// Whether a pixel position lies inside a `width_px` × `height_px` image by at least `margin_px` from every
/// border ([m, width − m] × [m, height − m]); a position that is not finite never does. The one answer to
/// "is this point inside the image" ([`CameraIntrinsics::contains_with_margin`] for a camera; the extractor,
/// which knows the image only, asks it directly).
pub fn image_contains(width_px: u32, height_px: u32, pixel: &Point2<f64>, margin_px: f64) -> bool {
    pixel.x >= margin_px
        && pixel.y >= margin_px
        && pixel.x <= f64::from(width_px) - margin_px
        && pixel.y <= f64::from(height_px) - margin_px
}

/// The camera's intrinsics: focal lengths fx, fy (px; non-square pixels when they differ), the principal
/// point, the image size and the lens's distortion ([`Distortion`], none by default).
///
/// Two images: the *pinhole* pixel of a point (K·(X/Z, Y/Z), [`Self::project`]) — what the features, the
/// image Jacobian and the law work on — and the *observed* pixel, where the lens puts it
/// (K·distort(X/Z, Y/Z), [`Self::project_observed`]). Without distortion they are the same.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraIntrinsics {
    fx_px: f64,
    fy_px: f64,
    principal_point_px: Point2<f64>,
    width_px: u32,
    height_px: u32,
    distortion: Distortion,
}

/// Why a set of intrinsics was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IntrinsicsError {
    /// A focal length must be a positive finite number of pixels.
    #[error("focal length {0} px must be positive and finite")]
    FocalLength(f64),
    /// The image must have at least one pixel each way.
    #[error("image size {0}×{1} px must be at least 1×1")]
    ImageSize(u32, u32),
    /// The principal point must be finite.
    #[error("principal point ({0}, {1}) px must be finite")]
    PrincipalPoint(f64, f64),
}

/// Why a point has no image.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ProjectionError {
    /// The point is at or behind the camera's centre (z ≤ 0 in the camera frame).
    #[error("mark {mark} is behind the camera (depth {depth_m} m)", mark = .index + 1)]
    BehindCamera {
        /// Zero-based mark index.
        index: usize,
        /// Its depth (m).
        depth_m: f64,
    },
}

impl CameraIntrinsics {
    /// Validated pinhole intrinsics with square pixels and no distortion.
    pub fn new(
        focal_px: f64,
        principal_point_px: Point2<f64>,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, IntrinsicsError> {
        Self::with_lens([focal_px, focal_px], principal_point_px, width_px, height_px, Distortion::NONE)
    }

    /// Validated intrinsics with focal lengths `[fx, fy]` (px) and a lens.
    pub fn with_lens(
        focal_px: [f64; 2],
        principal_point_px: Point2<f64>,
        width_px: u32,
        height_px: u32,
        distortion: Distortion,
    ) -> Result<Self, IntrinsicsError> {
        if let Some(&bad) = focal_px.iter().find(|f| !(f.is_finite() && **f > 0.0)) {
            return Err(IntrinsicsError::FocalLength(bad));
        }
        if width_px == 0 || height_px == 0 {
            return Err(IntrinsicsError::ImageSize(width_px, height_px));
        }
        if !(principal_point_px.x.is_finite() && principal_point_px.y.is_finite()) {
            return Err(IntrinsicsError::PrincipalPoint(principal_point_px.x, principal_point_px.y));
        }
        let [fx_px, fy_px] = focal_px;
        Ok(Self { fx_px, fy_px, principal_point_px, width_px, height_px, distortion })
    }

    /// The paper's camera (docs/REPRODUCTION.md): 512 × 512 px, f = 500 px, principal point (256, 256).
    pub fn paper() -> Self {
        Self {
            fx_px: 500.0,
            fy_px: 500.0,
            principal_point_px: Point2::new(256.0, 256.0),
            width_px: 512,
            height_px: 512,
            distortion: Distortion::NONE,
        }
    }

    /// Horizontal focal length fx (px).
    pub fn fx_px(&self) -> f64 {
        self.fx_px
    }
    /// Vertical focal length fy (px).
    pub fn fy_px(&self) -> f64 {
        self.fy_px
    }
    /// The lens's distortion.
    pub fn distortion(&self) -> &Distortion {
        &self.distortion
    }
    /// Principal point (px).
    pub fn principal_point_px(&self) -> Point2<f64> {
        self.principal_point_px
    }
    /// Image width (px).
    pub fn width_px(&self) -> u32 {
        self.width_px
    }
    /// Image height (px).
    pub fn height_px(&self) -> u32 {
        self.height_px
    }

    /// The pixel where a point given in the camera frame images, or `None` at or behind the camera.
    pub fn project(&self, point_in_camera: &Point3<f64>) -> Option<Point2<f64>> {
        if point_in_camera.z.is_nan() || point_in_camera.z <= 0.0 {
            return None;
        }
        // (with fx = fy the same operations as the square-pixel camera's f / z)
        let scale_x = self.fx_px / point_in_camera.z;
        let scale_y = self.fy_px / point_in_camera.z;
        Some(Point2::new(
            self.principal_point_px.x + scale_x * point_in_camera.x,
            self.principal_point_px.y + scale_y * point_in_camera.y,
        ))
    }

    /// The pixel where the lens images a point given in the camera frame (`cv::projectPoints`), or `None`
    /// at or behind the camera. Without distortion: [`Self::project`].
    pub fn project_observed(&self, point_in_camera: &Point3<f64>) -> Option<Point2<f64>> {
        if self.distortion.is_none() {
            return self.project(point_in_camera);
        }
        if point_in_camera.z.is_nan() || point_in_camera.z <= 0.0 {
            return None;
        }
        let normalized =
            Point2::new(point_in_camera.x / point_in_camera.z, point_in_camera.y / point_in_camera.z);
        Some(self.pixel_of_normalized(&self.distortion.distort(&normalized)))
    }

    /// Where the lens images the point whose pinhole pixel is `pinhole_px`. Without distortion:
    /// `pinhole_px` itself.
    pub fn observed_of_pinhole(&self, pinhole_px: &Point2<f64>) -> Point2<f64> {
        if self.distortion.is_none() {
            return *pinhole_px;
        }
        self.pixel_of_normalized(&self.distortion.distort(&self.normalized_of_pixel(pinhole_px)))
    }

    /// The pinhole pixel of the point the lens images at `observed_px` (undistortion, as
    /// `cv::undistortPoints` with P = K); `None` where the lens's inverse does not converge or the point is
    /// outside its valid region ([`Distortion::undistort`]). Without distortion: `observed_px` itself.
    pub fn pinhole_of_observed(&self, observed_px: &Point2<f64>) -> Option<Point2<f64>> {
        if self.distortion.is_none() {
            return Some(*observed_px);
        }
        let normalized = self.distortion.undistort(&self.normalized_of_pixel(observed_px))?;
        Some(self.pixel_of_normalized(&normalized))
    }

    /// Normalised coordinates (x/z, y/z) of a pixel: K⁻¹.
    #[inline]
    pub fn normalized_of_pixel(&self, pixel: &Point2<f64>) -> Point2<f64> {
        Point2::new(
            (pixel.x - self.principal_point_px.x) / self.fx_px,
            (pixel.y - self.principal_point_px.y) / self.fy_px,
        )
    }

    /// The pixel of normalised coordinates: K.
    #[inline]
    pub fn pixel_of_normalized(&self, normalized: &Point2<f64>) -> Point2<f64> {
        Point2::new(
            self.principal_point_px.x + self.fx_px * normalized.x,
            self.principal_point_px.y + self.fy_px * normalized.y,
        )
    }

    /// Whether a pixel position lies inside the image ([0, width] × [0, height]).
    pub fn contains(&self, pixel: &Point2<f64>) -> bool {
        self.contains_with_margin(pixel, 0.0)
    }

    /// Whether a pixel position lies inside the image by at least `margin_px` from every border
    /// ([m, width − m] × [m, height − m]); a position that is not finite never does.
    pub fn contains_with_margin(&self, pixel: &Point2<f64>, margin_px: f64) -> bool {
        image_contains(self.width_px, self.height_px, pixel, margin_px)
    }

    /// The feature vector and the mark depths for the board at `camera_from_board`.
    pub fn project_marks_with_depths(
        &self,
        board: &Board,
        camera_from_board: &IsometryMatrix3<f64>,
    ) -> Result<(FeatureVector, MarkDepths), ProjectionError> {
        let mut features = FeatureVector::zeros();
        let mut depths = MarkDepths::zeros();
        for index in 0..MARKS {
            let mark_in_camera = camera_from_board * board.marks_in_board[index];
            let pixel = self
                .project(&mark_in_camera)
                .ok_or(ProjectionError::BehindCamera { index, depth_m: mark_in_camera.z })?;
            features[2 * index] = pixel.x;
            features[2 * index + 1] = pixel.y;
            depths[index] = mark_in_camera.z;
        }
        Ok((features, depths))
    }

    /// The feature vector ξ for the board at `camera_from_board`.
    pub fn project_marks(
        &self,
        board: &Board,
        camera_from_board: &IsometryMatrix3<f64>,
    ) -> Result<FeatureVector, ProjectionError> {
        self.project_marks_with_depths(board, camera_from_board).map(|(features, _)| features)
    }
}

impl CameraIntrinsics {
    /// The board pose that images its marks at `features`: the homography from the board plane (the marks
    /// must lie in its z = 0 plane) to normalised image coordinates by the direct linear transform, split
    /// into a rotation and a translation and the rotation made orthonormal (Zhang 2000). `None` when a
    /// feature is not finite, the marks are not coplanar at z = 0, the features are degenerate (three marks
    /// in a line) or the board would be behind the camera. Four points always fit a homography; whether a
    /// rigid pose explains them is for the caller to judge by reprojecting.
    pub fn board_pose_from_features(
        &self,
        board: &Board,
        features: &FeatureVector,
    ) -> Option<IsometryMatrix3<f64>> {
        use nalgebra::{Matrix3, Rotation3, SMatrix, Translation3, Vector3};
        if !features.iter().all(|v| v.is_finite()) || board.marks_in_board.iter().any(|m| m.z != 0.0) {
            return None;
        }
        // 8 equations in 9 unknowns; the zero ninth row makes the SVD square
        let mut a = SMatrix::<f64, 9, 9>::zeros();
        for (i, mark) in board.marks_in_board.iter().enumerate() {
            let u = (features[2 * i] - self.principal_point_px.x) / self.fx_px;
            let v = (features[2 * i + 1] - self.principal_point_px.y) / self.fy_px;
            let (x, y) = (mark.x, mark.y);
            a.fixed_view_mut::<1, 9>(2 * i, 0).copy_from_slice(&[
                x,
                y,
                1.0,
                0.0,
                0.0,
                0.0,
                -u * x,
                -u * y,
                -u,
            ]);
            a.fixed_view_mut::<1, 9>(2 * i + 1, 0).copy_from_slice(&[
                0.0,
                0.0,
                0.0,
                x,
                y,
                1.0,
                -v * x,
                -v * y,
                -v,
            ]);
        }
        // the null vector of A: its right singular vector of the smallest singular value, which must be
        // alone (a second near-zero one: the marks' images do not fix a homography)
        let svd = a.svd(false, true);
        let v_t = svd.v_t?;
        // (an array, not a Vec: the servo estimates depths with this on every frame)
        let mut order: [usize; 9] = std::array::from_fn(|i| i);
        order.sort_unstable_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
        let largest = svd.singular_values[order[8]];
        // (the inputs are finite, so are the singular values)
        if svd.singular_values[order[1]] <= 1e-9 * largest {
            return None;
        }
        let h = v_t.row(order[0]);
        let homography = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
        // three marks imaged on a line: the homography is singular
        let singular = homography.singular_values();
        if singular.min() <= 1e-9 * singular.max() {
            return None;
        }
        let (h1, h2, h3) = (homography.column(0), homography.column(1), homography.column(2));
        let norm = h1.norm();
        if norm <= 1e-12 {
            return None;
        }
        // the scale that puts the board in front of the camera
        let scale = if h3[2] >= 0.0 { 1.0 / norm } else { -1.0 / norm };
        let r1: Vector3<f64> = h1 * scale;
        let r2: Vector3<f64> = h2 * scale;
        let translation: Vector3<f64> = h3 * scale;
        let rough = Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]);
        let svd = rough.svd(true, true);
        let (u, v_t) = (svd.u?, svd.v_t?);
        let mut rotation = u * v_t;
        if rotation.determinant() < 0.0 {
            rotation = -rotation;
        }
        let pose = IsometryMatrix3::from_parts(
            Translation3::from(translation),
            Rotation3::from_matrix_unchecked(rotation),
        );
        (translation.iter().all(|v| v.is_finite()) && translation.z > 0.0).then_some(pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3, Vector3};
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_board_pose_comes_back_from_its_image(
            x in -0.1f64..0.1, y in -0.1f64..0.1, z in 0.35f64..1.2,
            roll in -0.4f64..0.4, pitch in -0.4f64..0.4, yaw in -0.6f64..0.6,
        ) {
            let camera = CameraIntrinsics::paper();
            let board = Board::paper();
            let pose = IsometryMatrix3::from_parts(
                Translation3::new(x, y, z),
                Rotation3::from_euler_angles(roll, pitch, yaw),
            );
            let features = camera.project_marks(&board, &pose).expect("in front");
            let found = camera.board_pose_from_features(&board, &features).expect("a pose");
            prop_assert!((found.translation.vector - pose.translation.vector).norm() < 1e-9);
            // (angle_to's acos cannot resolve angles below ~1e-8: compare the matrices)
            prop_assert!((found.rotation.matrix() - pose.rotation.matrix()).norm() < 1e-9);
        }
    }

    #[test]
    fn a_point_is_inside_by_a_margin_only_that_far_from_every_border() {
        let camera = CameraIntrinsics::paper();
        let at = |x, y| Point2::new(x, y);
        assert!(camera.contains(&at(0.0, 512.0)) && camera.contains(&at(512.0, 0.0)));
        assert!(!camera.contains(&at(-0.001, 10.0)) && !camera.contains(&at(10.0, 512.001)));
        assert!(camera.contains_with_margin(&at(20.0, 492.0), 20.0));
        assert!(!camera.contains_with_margin(&at(19.9, 256.0), 20.0));
        assert!(!camera.contains_with_margin(&at(256.0, 492.1), 20.0));
        for not_finite in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(!camera.contains_with_margin(&at(not_finite, 256.0), 0.0));
            assert!(!camera.contains_with_margin(&at(256.0, not_finite), 0.0));
        }
    }

    #[test]
    fn degenerate_features_have_no_pose() {
        let camera = CameraIntrinsics::paper();
        let in_a_line = FeatureVector::from([100.0, 100.0, 200.0, 100.0, 300.0, 100.0, 400.0, 100.0]);
        assert!(camera.board_pose_from_features(&Board::paper(), &in_a_line).is_none());
        let nan = FeatureVector::from_element(f64::NAN);
        assert!(camera.board_pose_from_features(&Board::paper(), &nan).is_none());
    }

    #[test]
    fn the_paper_board_at_half_a_metre_images_at_the_papers_desired_features() {
        let camera = CameraIntrinsics::paper();
        let pose = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Rotation3::identity());
        let (features, depths) = camera.project_marks_with_depths(&Board::paper(), &pose).expect("in front");
        let expected = [151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0];
        for (f, e) in features.iter().zip(expected) {
            assert!((f - e).abs() < 1e-9, "{features}");
        }
        assert!(depths.iter().all(|&z| (z - 0.5).abs() < 1e-12));
    }

    #[test]
    fn points_behind_the_camera_have_no_image_and_are_reported() {
        let camera = CameraIntrinsics::paper();
        assert!(camera.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
        assert!(camera.project(&Point3::new(0.0, 0.0, 0.0)).is_none());
        let pose = IsometryMatrix3::from_parts(
            Translation3::from(Vector3::new(0.0, 0.0, -0.5)),
            Rotation3::identity(),
        );
        let error = camera.project_marks(&Board::paper(), &pose).expect_err("behind");
        assert!(error.to_string().contains("mark 1 is behind"), "{error}");
    }

    #[test]
    fn bad_intrinsics_are_refused() {
        assert!(CameraIntrinsics::new(0.0, Point2::new(1.0, 1.0), 10, 10).is_err());
        assert!(CameraIntrinsics::new(f64::NAN, Point2::new(1.0, 1.0), 10, 10).is_err());
        assert!(CameraIntrinsics::new(500.0, Point2::new(1.0, 1.0), 0, 10).is_err());
        assert!(CameraIntrinsics::new(500.0, Point2::new(f64::INFINITY, 1.0), 10, 10).is_err());
        assert!(CameraIntrinsics::new(500.0, Point2::new(256.0, 256.0), 512, 512).is_ok());
    }
}
