//! The lens: OpenCV's Brown–Conrady distortion (`plumb_bob`: k1, k2, p1, p2, k3) on normalised image
//! coordinates (x = X/Z, y = Y/Z), and its inverse.
//!
//! [`Distortion::distort`] is OpenCV's formula (`cv::projectPoints`) term for term. [`Distortion::undistort`]
//! inverts it by Newton's method, as `cv::undistortPoints` inverts it by fixed-point iteration; it stops when
//! re-distorting its answer lands within [`UNDISTORT_TOLERANCE`] of the observed point (normalised units; at
//! 600 px focal length 6·10⁻¹² px) and refuses (`None`) a point it does not reach in
//! [`UNDISTORT_MAX_ITERATIONS`] steps or whose answer lies outside the lens's valid region
//! ([`Distortion::valid_radius`]: where the radial mapping r ↦ r·(1 + k1 r² + k2 r⁴ + k3 r⁶) still grows).

use nalgebra::{Matrix2, Point2, Vector2};

/// Re-distorting an undistorted point must land this close (max-norm, normalised units) to the observed one.
pub const UNDISTORT_TOLERANCE: f64 = 1e-14;
/// Newton steps [`Distortion::undistort`] takes at most.
pub const UNDISTORT_MAX_ITERATIONS: usize = 20;
/// The valid radius's cap (normalised units, 84° off axis) when the radial mapping grows everywhere.
pub const MAX_VALID_RADIUS: f64 = 10.0;

/// OpenCV's five distortion coefficients, in OpenCV's order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Distortion {
    k1: f64,
    k2: f64,
    p1: f64,
    p2: f64,
    k3: f64,
    /// The undistorted radius (normalised) up to which the radial mapping grows.
    valid_radius: f64,
}

/// Why a set of distortion coefficients was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DistortionError {
    /// Every coefficient must be finite.
    #[error("distortion coefficient {name} = {value} must be finite")]
    NotFinite {
        /// k1, k2, p1, p2 or k3.
        name: &'static str,
        /// The value given.
        value: f64,
    },
}

impl Default for Distortion {
    fn default() -> Self {
        Self::NONE
    }
}

impl Distortion {
    /// No distortion: the ideal pinhole.
    pub const NONE: Self =
        Self { k1: 0.0, k2: 0.0, p1: 0.0, p2: 0.0, k3: 0.0, valid_radius: MAX_VALID_RADIUS };

    /// The lens of OpenCV's coefficients `[k1, k2, p1, p2, k3]`.
    pub fn new(coefficients: [f64; 5]) -> Result<Self, DistortionError> {
        const NAMES: [&str; 5] = ["k1", "k2", "p1", "p2", "k3"];
        for (name, value) in NAMES.into_iter().zip(coefficients) {
            if !value.is_finite() {
                return Err(DistortionError::NotFinite { name, value });
            }
        }
        let [k1, k2, p1, p2, k3] = coefficients;
        let radial_slope = |r: f64| {
            let r2 = r * r;
            1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * 7.0 * k3))
        };
        Ok(Self { k1, k2, p1, p2, k3, valid_radius: first_root(radial_slope) })
    }

    /// `[k1, k2, p1, p2, k3]`.
    pub fn coefficients(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Whether every coefficient is zero (the pinhole: no mapping at all).
    pub fn is_none(&self) -> bool {
        self.coefficients().iter().all(|&c| c == 0.0)
    }

    /// The undistorted (normalised) radius up to which the radial mapping grows: points farther out are
    /// outside the lens's valid region ([`MAX_VALID_RADIUS`] at most).
    pub fn valid_radius(&self) -> f64 {
        self.valid_radius
    }

    /// Where the lens images a normalised point: OpenCV's formula,
    /// x_d = x·(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²),
    /// y_d = y·(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y²) + 2 p2 x y.
    #[inline]
    pub fn distort(&self, normalized: &Point2<f64>) -> Point2<f64> {
        let (x, y) = (normalized.x, normalized.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let xy = x * y;
        Point2::new(
            x * radial + 2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * xy,
        )
    }

    /// [`Self::distort`] and its Jacobian ∂(x_d, y_d)/∂(x, y).
    #[inline]
    fn distort_with_jacobian(&self, p: &Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let radial_slope = self.k1 + r2 * (2.0 * self.k2 + r2 * 3.0 * self.k3);
        let distorted = self.distort(&Point2::new(x, y)).coords;
        let dxd_dx = radial + 2.0 * x * x * radial_slope + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let dxd_dy = 2.0 * x * y * radial_slope + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyd_dx = 2.0 * x * y * radial_slope + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyd_dy = radial + 2.0 * y * y * radial_slope + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        (distorted, Matrix2::new(dxd_dx, dxd_dy, dyd_dx, dyd_dy))
    }

    /// The normalised point the lens images at `distorted`, by Newton's method from `distorted` itself;
    /// `None` when it does not converge to [`UNDISTORT_TOLERANCE`] within [`UNDISTORT_MAX_ITERATIONS`]
    /// steps, the mapping is singular on the way, or the answer lies outside [`Self::valid_radius`].
    pub fn undistort(&self, distorted: &Point2<f64>) -> Option<Point2<f64>> {
        if !(distorted.x.is_finite() && distorted.y.is_finite()) {
            return None;
        }
        if self.is_none() {
            return Some(*distorted);
        }
        let target = distorted.coords;
        let mut p = target;
        for _ in 0..UNDISTORT_MAX_ITERATIONS {
            let (image, jacobian) = self.distort_with_jacobian(&p);
            let residual = image - target;
            if residual.amax() <= UNDISTORT_TOLERANCE {
                return (p.norm() < self.valid_radius).then_some(Point2::from(p));
            }
            let step = jacobian.try_inverse()? * residual;
            p -= step;
            // keep the iteration in the region where the mapping is one to one
            let radius = p.norm();
            if !radius.is_finite() {
                return None;
            }
            if radius >= self.valid_radius {
                p *= 0.99 * self.valid_radius / radius;
            }
        }
        None
    }
}

/// The first r in (0, MAX_VALID_RADIUS] where `slope(r) ≤ 0` (bisected to 1e-12), or MAX_VALID_RADIUS.
fn first_root(slope: impl Fn(f64) -> f64) -> f64 {
    const STEP: f64 = 1e-3;
    let steps = (MAX_VALID_RADIUS / STEP) as usize;
    let Some(first_bad) = (1..=steps).map(|i| i as f64 * STEP).find(|&r| slope(r) <= 0.0) else {
        return MAX_VALID_RADIUS;
    };
    let (mut good, mut bad) = (first_bad - STEP, first_bad);
    while bad - good > 1e-12 {
        let middle = 0.5 * (good + bad);
        if slope(middle) > 0.0 { good = middle } else { bad = middle }
    }
    good
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_distortion_maps_every_point_to_itself() {
        let p = Point2::new(0.3, -0.2);
        assert_eq!(Distortion::NONE.distort(&p), p);
        assert_eq!(Distortion::NONE.undistort(&p), Some(p));
        assert!(Distortion::NONE.is_none());
    }

    #[test]
    fn the_valid_radius_is_where_the_radial_mapping_stops_growing() {
        // 1 + 3 k1 r² = 0 at r = 1/sqrt(0.9) for k1 = −0.3
        let lens = Distortion::new([-0.3, 0.0, 0.0, 0.0, 0.0]).expect("finite");
        assert!((lens.valid_radius() - 1.0 / 0.9f64.sqrt()).abs() < 1e-9, "{}", lens.valid_radius());
        let grows = Distortion::new([-0.25, 0.08, 0.0, 0.0, 0.0]).expect("finite");
        assert_eq!(grows.valid_radius(), MAX_VALID_RADIUS);
    }

    #[test]
    fn a_point_outside_the_valid_region_is_refused() {
        let lens = Distortion::new([-0.3, 0.0, 0.0, 0.0, 0.0]).expect("finite");
        // the largest distorted radius this lens makes is r_max (1 − 0.3 r_max²) ≈ 0.703; beyond it no
        // point images
        assert!(lens.undistort(&Point2::new(0.72, 0.0)).is_none());
        assert!(lens.undistort(&Point2::new(0.65, 0.0)).is_some());
        assert!(lens.undistort(&Point2::new(f64::NAN, 0.0)).is_none());
    }

    #[test]
    fn coefficients_that_are_not_finite_are_refused() {
        let error = Distortion::new([0.0, 0.0, f64::NAN, 0.0, 0.0]).expect_err("NaN");
        assert!(error.to_string().contains("p1"), "{error}");
    }
}
