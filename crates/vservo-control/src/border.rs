//! Keeping the marks inside the image: a barrier on each seen mark's image coordinates.
//!
//! The design: the image minus a margin of `margin_px` on every side is the allowed region. For each seen
//! mark and each image axis, with `p` the coordinate predicted for the moment the twist starts to act and
//! `h = p − margin` its distance to the edge of the allowed region (negative once inside the band), the
//! twist u must satisfy `(B u)_c ≥ −γ·h` (and the mirror condition on the far side): per frame a mark may
//! approach the edge by at most the fraction γ of the distance left, so it never crosses it, and a mark
//! already inside the band is pushed back out of it at the same rate. A twist that breaks a condition is
//! changed by the least R-weighted correction that meets it, condition by condition, in a few sweeps; a
//! twist that meets them all is left as it is. Allocates nothing.

use nalgebra::Matrix6;
use vservo_scene::{CameraIntrinsics, FeatureVector, MARKS};

use crate::frame_design::MarkSet;
use crate::{InteractionMatrix, Twist};

/// γ: the fraction of the distance to the edge of the allowed region a mark may cover in one frame.
pub const APPROACH_PER_FRAME: f64 = 0.5;

/// Sweeps over the conditions.
const SWEEPS: usize = 4;

/// The barrier of one image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Barrier {
    /// The image size (px).
    pub limits_px: [f64; 2],
    /// How far inside the image the marks are kept (px).
    pub margin_px: f64,
    /// R⁻¹, the metric of the correction.
    pub r_inverse: Matrix6<f64>,
}

impl Barrier {
    /// The barrier `margin_px` inside `camera`'s image, corrections weighted by `r_inverse`.
    pub fn new(camera: &CameraIntrinsics, margin_px: f64, r_inverse: Matrix6<f64>) -> Self {
        Self {
            limits_px: [f64::from(camera.width_px()), f64::from(camera.height_px())],
            margin_px,
            r_inverse,
        }
    }

    /// The twist nearest `twist` (in the metric R⁻¹ gives) that keeps the `seen` marks, predicted at
    /// `predicted` (px) before the twist acts and moving by `b·twist + drift` (px, `drift` the target's own
    /// motion) over the frame, inside the image with the margin to spare. Returns the twist and how many
    /// conditions had to be met.
    pub fn keep_inside(
        &self,
        twist: Twist,
        b: &InteractionMatrix,
        predicted: &FeatureVector,
        drift: &FeatureVector,
        seen: MarkSet,
    ) -> (Twist, u32) {
        keep_inside(twist, b, predicted, drift, seen, self)
    }
}

fn keep_inside(
    twist: Twist,
    b: &InteractionMatrix,
    predicted: &FeatureVector,
    drift: &FeatureVector,
    seen: MarkSet,
    barrier: &Barrier,
) -> (Twist, u32) {
    let (margin_px, r_inverse) = (barrier.margin_px, &barrier.r_inverse);
    let mut u = twist;
    let mut corrected = 0;
    for _ in 0..SWEEPS {
        let mut changed = false;
        for mark in (0..MARKS).filter(|m| seen & (1 << m) != 0) {
            for (axis, limit) in barrier.limits_px.iter().enumerate() {
                let row = 2 * mark + axis;
                let p = predicted[row];
                if !p.is_finite() {
                    continue;
                }
                let a = b.row(row).transpose();
                let motion = a.dot(&u) + drift[row];
                let lower = -APPROACH_PER_FRAME * (p - margin_px);
                let upper = APPROACH_PER_FRAME * (limit - margin_px - p);
                let target = if motion < lower {
                    lower
                } else if motion > upper {
                    upper
                } else {
                    continue;
                };
                let direction = r_inverse * a;
                let along = a.dot(&direction);
                if along <= f64::EPSILON {
                    continue;
                }
                u += direction * ((target - motion) / along);
                changed = true;
                corrected += 1;
            }
        }
        if !changed {
            break;
        }
    }
    (u, corrected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_jacobian::interaction_matrix;
    use vservo_scene::MarkDepths;

    fn setup() -> (CameraIntrinsics, InteractionMatrix, FeatureVector) {
        let camera = CameraIntrinsics::paper();
        let features = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0]);
        let b = interaction_matrix(&camera, &features, &MarkDepths::from_element(0.5), 0.085);
        (camera, b, features)
    }

    #[test]
    fn a_twist_that_keeps_the_marks_well_inside_is_left_alone() {
        let (camera, b, features) = setup();
        let twist = Twist::new(0.01, 0.0, 0.0, 0.0, 0.0, 0.0);
        let barrier = Barrier::new(&camera, 20.0, Matrix6::identity());
        let (out, corrected) = barrier.keep_inside(twist, &b, &features, &FeatureVector::zeros(), 0b1111);
        assert_eq!((out, corrected), (twist, 0));
    }

    #[test]
    fn a_twist_that_would_push_a_mark_out_is_cut_to_approach_the_margin_by_half_the_distance() {
        let (camera, b, features) = setup();
        // mark 4 is at y = 70: a fast move that shifts the image up by ~100 px would take it out
        let twist = Twist::new(0.0, 1.2, 0.0, 0.0, 0.0, 0.0);
        let before = b * twist;
        assert!(features[7] + before[7] < 0.0, "the test's twist must push mark 4 out");
        let barrier = Barrier::new(&camera, 20.0, Matrix6::identity());
        let (out, corrected) = barrier.keep_inside(twist, &b, &features, &FeatureVector::zeros(), 0b1111);
        assert!(corrected > 0);
        let after = features + b * out;
        for mark in 0..MARKS {
            let (x, y) = (after[2 * mark], after[2 * mark + 1]);
            assert!((20.0..=492.0).contains(&x) && (20.0..=492.0).contains(&y), "mark {mark} at ({x}, {y})");
        }
        // the mark nearest the top edge moved at most half its distance to the margin
        assert!(after[7] >= 70.0 - 0.5 * 50.0 - 1e-6, "{}", after[7]);
    }
}
