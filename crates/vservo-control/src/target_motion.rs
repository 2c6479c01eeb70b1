//! The target's own motion in the image, estimated from the features and the camera's measured motion.
//!
//! Between two frames a mark's image moves because the camera moved and because the target moved. The
//! camera's motion is known (its pose at each capture, from the joint states); a mark that stood still would
//! now image where its previous position, at its estimated depth, projects from the camera's new pose. What
//! is left is the target's motion. A two-state α–β filter per feature tracks that motion's rate and its
//! change (px per frame and per frame²), so that a law can feed it forward through the pipeline's delay.

use nalgebra::Point3;
use vservo_scene::{CameraIntrinsics, FeatureVector, IsometryMatrix3, MARKS, MarkDepths};

use crate::frame_design::MarkSet;

/// The filter's gain on the rate.
pub const ALPHA: f64 = 0.5;
/// The filter's gain on the rate's change.
pub const BETA: f64 = 0.1;
/// Frames of consecutive measurements before the estimate is used.
pub const SETTLE_FRAMES: u32 = 4;

/// One frame as the estimator needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seen {
    frame: u64,
    features: FeatureVector,
    depths: MarkDepths,
    marks: MarkSet,
    base_from_camera: IsometryMatrix3<f64>,
}

/// The estimate of the target's image motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetMotion {
    /// px per frame.
    rate: FeatureVector,
    /// px per frame².
    change: FeatureVector,
    previous: Option<Seen>,
    consecutive: u32,
}

impl Default for TargetMotion {
    fn default() -> Self {
        Self { rate: FeatureVector::zeros(), change: FeatureVector::zeros(), previous: None, consecutive: 0 }
    }
}

impl TargetMotion {
    /// Forgets everything (a new target, a jump).
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Takes in frame `frame`: its features (NaN where not seen), the mark depths the law uses, and the
    /// camera's pose at capture. A frame that does not follow the previous one, or without a pose, restarts
    /// the estimate.
    pub fn update(
        &mut self,
        camera: &CameraIntrinsics,
        frame: u64,
        features: &FeatureVector,
        depths: &MarkDepths,
        marks: MarkSet,
        base_from_camera: Option<&IsometryMatrix3<f64>>,
    ) {
        let Some(pose) = base_from_camera else {
            self.reset();
            return;
        };
        let now = Seen { frame, features: *features, depths: *depths, marks, base_from_camera: *pose };
        let Some(before) = self.previous.replace(now) else { return };
        if frame != before.frame + 1 {
            self.rate = FeatureVector::zeros();
            self.change = FeatureVector::zeros();
            self.consecutive = 0;
            return;
        }
        let now_from_before = pose.inverse() * before.base_from_camera;
        let centre = camera.principal_point_px();
        let f = camera.focal_px();
        let mut measured_any = false;
        for mark in (0..MARKS).filter(|m| before.marks & now.marks & (1 << m) != 0) {
            let z = before.depths[mark];
            let (u, v) = (before.features[2 * mark], before.features[2 * mark + 1]);
            let point = Point3::new((u - centre.x) * z / f, (v - centre.y) * z / f, z);
            let Some(still) = camera.project(&(now_from_before * point)) else { continue };
            for (axis, still_px) in [still.x, still.y].into_iter().enumerate() {
                let row = 2 * mark + axis;
                let measured = features[row] - still_px;
                let predicted = self.rate[row] + self.change[row];
                let residual = measured - predicted;
                self.rate[row] = predicted + ALPHA * residual;
                self.change[row] += BETA * residual;
            }
            measured_any = true;
        }
        self.consecutive = if measured_any { self.consecutive + 1 } else { 0 };
    }

    /// Whether enough frames have been seen for the estimate to be used.
    pub fn settled(&self) -> bool {
        self.consecutive >= SETTLE_FRAMES
    }

    /// The target's image motion over the `frames` frames that follow the latest measured one (px).
    pub fn motion_over(&self, frames: usize) -> FeatureVector {
        let n = frames as f64;
        self.rate * n + self.change * (n * (n + 1.0) * 0.5)
    }

    /// The target's image motion over the one frame that starts `after` frames after the latest measured
    /// one (px).
    pub fn motion_in_frame(&self, after: usize) -> FeatureVector {
        self.rate + self.change * (after as f64 + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3, Vector3};
    use vservo_scene::Board;

    /// The camera moves one way, the board another at constant acceleration: the estimate finds the
    /// board's image motion only.
    #[test]
    fn the_camera_s_own_motion_is_taken_out_and_the_target_s_is_found() {
        let camera = CameraIntrinsics::paper();
        let board = Board::paper();
        let mut estimator = TargetMotion::default();
        let board_at = |k: f64| {
            IsometryMatrix3::from_parts(
                Translation3::new(0.0, 0.002 * k + 0.0001 * k * k, 0.5),
                Rotation3::identity(),
            )
        };
        let camera_at = |k: f64| {
            IsometryMatrix3::from_parts(
                Translation3::new(0.003 * k, 0.0, 0.0),
                Rotation3::from_axis_angle(&Vector3::z_axis(), 0.004 * k),
            )
        };
        let image = |k: f64| {
            let camera_from_board = camera_at(k).inverse() * board_at(k);
            camera.project_marks_with_depths(&board, &camera_from_board).expect("in front")
        };
        for k in 0..20 {
            let (features, depths) = image(k as f64);
            estimator.update(&camera, k, &features, &depths, 0b1111, Some(&camera_at(k as f64)));
        }
        assert!(estimator.settled());
        // what the board alone does to the image from frame 19 to 20, seen from the camera at 20
        let (now, _) = image(20.0);
        let still_camera_from_board = camera_at(20.0).inverse() * board_at(19.0);
        let (still, _) =
            camera.project_marks_with_depths(&board, &still_camera_from_board).expect("in front");
        let truth = now - still;
        let estimate = estimator.motion_in_frame(0);
        assert!((estimate - truth).amax() < 0.05, "estimate {estimate} truth {truth}");
        assert!(truth.amax() > 2.0, "the board must move in the test: {truth}");
    }

    #[test]
    fn a_gap_in_the_frames_restarts_the_estimate() {
        let camera = CameraIntrinsics::paper();
        let mut estimator = TargetMotion::default();
        let pose = IsometryMatrix3::identity();
        let features = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0]);
        for k in 0..6 {
            estimator.update(&camera, k, &features, &MarkDepths::from_element(0.5), 0b1111, Some(&pose));
        }
        assert!(estimator.settled());
        estimator.update(&camera, 9, &features, &MarkDepths::from_element(0.5), 0b1111, Some(&pose));
        assert!(!estimator.settled());
        estimator.update(&camera, 10, &features, &MarkDepths::from_element(0.5), 0b1111, None);
        assert!(!estimator.settled());
    }
}
