//! The object's motion: where the board is at each instant of simulated time.

use nalgebra::Vector3;

/// How the board moves, in the frame of the camera at the desired pose ("the desired camera frame").
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObjectMotion {
    /// It stays where the desired pose puts it.
    Hold,
    /// At `at_s` it jumps by `translation_m` (desired camera frame).
    Step {
        /// When (s).
        at_s: f64,
        /// By how much (m), in the desired camera frame.
        translation_m: Vector3<f64>,
    },
    /// A circle of `radius_m` in the desired camera frame's y–z plane, at `rev_per_min`, starting where the
    /// desired pose puts it: p(t) = p₀ + r·[sin ωt · y + (cos ωt − 1) · z] (docs/REPRODUCTION.md).
    Circle {
        /// Radius (m).
        radius_m: f64,
        /// Speed (revolutions per minute).
        rev_per_min: f64,
    },
}

impl ObjectMotion {
    /// The board's displacement at time `t_s` from its desired-pose position, in the desired camera frame.
    pub fn offset_in_desired_camera(&self, t_s: f64) -> Vector3<f64> {
        match *self {
            ObjectMotion::Hold => Vector3::zeros(),
            ObjectMotion::Step { at_s, translation_m } => {
                if t_s >= at_s {
                    translation_m
                } else {
                    Vector3::zeros()
                }
            }
            ObjectMotion::Circle { radius_m, rev_per_min } => {
                let omega = std::f64::consts::TAU * rev_per_min / 60.0;
                let (s, c) = (omega * t_s).sin_cos();
                Vector3::new(0.0, radius_m * s, radius_m * (c - 1.0))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_circle_starts_at_the_desired_position_and_has_its_radius() {
        let circle = ObjectMotion::Circle { radius_m: 0.1, rev_per_min: 5.0 };
        assert_eq!(circle.offset_in_desired_camera(0.0), Vector3::zeros());
        // a quarter turn (3 s at 5 rev/min): up by r along y, towards the camera by r along z
        let quarter = circle.offset_in_desired_camera(3.0);
        assert!((quarter - Vector3::new(0.0, 0.1, -0.1)).norm() < 1e-12, "{quarter}");
        let half = circle.offset_in_desired_camera(6.0);
        assert!((half - Vector3::new(0.0, 0.0, -0.2)).norm() < 1e-12);
        let step = ObjectMotion::Step { at_s: 1.0, translation_m: Vector3::x() };
        assert_eq!(step.offset_in_desired_camera(0.999), Vector3::zeros());
        assert_eq!(step.offset_in_desired_camera(1.0), Vector3::x());
    }
}
