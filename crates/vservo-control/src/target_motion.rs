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
        if frame != before.frame.wrapping_add(1) {
            self.rate = FeatureVector::zeros();
            self.change = FeatureVector::zeros();
            self.consecutive = 0;
            return;
        }
        let now_from_before = pose.inverse() * before.base_from_camera;
        let centre = camera.principal_point_px();
        let (fx, fy) = (camera.fx_px(), camera.fy_px());
        let mut measured_any = false;
        for mark in 0..MARKS {
            let rows = [2 * mark, 2 * mark + 1];
            // a mark not seen in both frames has no motion measured: what was estimated of it is forgotten,
            // so that a mark coming back is not fed forward with a rate from before it was lost
            let still = (before.marks & now.marks & (1 << mark) != 0)
                .then(|| {
                    let z = before.depths[mark];
                    let (u, v) = (before.features[rows[0]], before.features[rows[1]]);
                    let point = Point3::new((u - centre.x) * z / fx, (v - centre.y) * z / fy, z);
                    camera.project(&(now_from_before * point))
                })
                .flatten()
                .filter(|still| {
                    (features[rows[0]] - still.x).is_finite() && (features[rows[1]] - still.y).is_finite()
                });
            let Some(still) = still else {
                for row in rows {
                    self.rate[row] = 0.0;
                    self.change[row] = 0.0;
                }
                continue;
            };
            for (row, still_px) in rows.into_iter().zip([still.x, still.y]) {
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

    /// The board's image drifts 1 px per frame in x, the camera still; `marks` seen.
    fn drifting(estimator: &mut TargetMotion, frames: std::ops::Range<u64>, marks: MarkSet) {
        let camera = CameraIntrinsics::paper();
        let pose = IsometryMatrix3::identity();
        for k in frames {
            let mut features = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0]);
            for mark in 0..MARKS {
                features[2 * mark] += k as f64;
                if marks & (1 << mark) == 0 {
                    features[2 * mark] = f64::NAN;
                    features[2 * mark + 1] = f64::NAN;
                }
            }
            estimator.update(&camera, k, &features, &MarkDepths::from_element(0.5), marks, Some(&pose));
        }
    }

    #[test]
    fn a_gap_in_the_frames_restarts_the_estimate() {
        let mut estimator = TargetMotion::default();
        drifting(&mut estimator, 0..8, 0b1111);
        assert!(estimator.settled());
        assert!(estimator.motion_in_frame(0)[0] > 0.8, "{}", estimator.motion_in_frame(0));
        // frames 8 and 9 lost
        drifting(&mut estimator, 10..11, 0b1111);
        assert!(!estimator.settled());
        assert_eq!(estimator.motion_in_frame(0), FeatureVector::zeros(), "the rate is forgotten");
        // a frame without the camera's pose
        drifting(&mut estimator, 11..16, 0b1111);
        assert!(estimator.settled());
        let features = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0]);
        let camera = CameraIntrinsics::paper();
        estimator.update(&camera, 16, &features, &MarkDepths::from_element(0.5), 0b1111, None);
        assert!(!estimator.settled());
        assert_eq!(estimator.motion_in_frame(0), FeatureVector::zeros());
        // the frame after u64::MAX is 0, and nothing overflows
        let mut estimator = TargetMotion::default();
        drifting(&mut estimator, u64::MAX - 1..u64::MAX, 0b1111);
        estimator.update(
            &camera,
            u64::MAX,
            &features,
            &MarkDepths::from_element(0.5),
            0b1111,
            Some(&IsometryMatrix3::identity()),
        );
        estimator.update(
            &camera,
            0,
            &features,
            &MarkDepths::from_element(0.5),
            0b1111,
            Some(&IsometryMatrix3::identity()),
        );
        assert_eq!(estimator.consecutive, 2);
    }

    #[test]
    fn a_mark_lost_and_back_is_not_fed_forward_with_its_rate_from_before() {
        let mut estimator = TargetMotion::default();
        drifting(&mut estimator, 0..8, 0b1111);
        // mark 2 lost for a frame: its rate is forgotten, the others' kept
        drifting(&mut estimator, 8..9, 0b1101);
        let motion = estimator.motion_in_frame(0);
        assert!(estimator.settled());
        assert_eq!((motion[2], motion[3]), (0.0, 0.0), "{motion}");
        assert!(motion[0] > 0.8 && motion[4] > 0.8, "{motion}");
        // back: measured again from the frame after its return, from zero
        drifting(&mut estimator, 9..11, 0b1111);
        let motion = estimator.motion_in_frame(0);
        assert!(motion[2] > 0.0 && motion[2] < motion[0], "{motion}");
    }
}
