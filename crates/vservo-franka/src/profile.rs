//! A smooth, jerk-bounded joint-velocity profile: v(t) = peak · sin²(π t / T) on [0, T], zero outside.
//!
//! It starts and ends at zero velocity and zero acceleration; its acceleration is bounded by π·peak/T and
//! its jerk by 2π²·peak/T², and it moves the joint by peak·T/2.

use std::f64::consts::PI;

/// A sin² velocity bump of one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothVelocityProfile {
    /// Peak velocity (at T/2), rad/s.
    pub peak_rad_per_s: f64,
    /// Duration T, s.
    pub duration_s: f64,
}

impl SmoothVelocityProfile {
    /// A bump peaking at `peak_rad_per_s` over `duration_s` seconds.
    pub const fn new(peak_rad_per_s: f64, duration_s: f64) -> Self {
        SmoothVelocityProfile { peak_rad_per_s, duration_s }
    }

    /// Velocity at time `t_s` (s) from the start, rad/s; 0 outside [0, T] or if T ≤ 0.
    pub fn velocity_at(&self, t_s: f64) -> f64 {
        let inside = self.duration_s > 0.0 && t_s > 0.0 && t_s < self.duration_s;
        if !inside {
            return 0.0;
        }
        let s = (PI * t_s / self.duration_s).sin();
        self.peak_rad_per_s * s * s
    }

    /// Displacement over the whole profile, rad (its integral, peak·T/2).
    pub fn displacement_rad(&self) -> f64 {
        self.peak_rad_per_s * self.duration_s / 2.0
    }

    /// Largest |acceleration|, rad/s² (π·peak/T).
    pub fn max_acceleration_rad_per_s2(&self) -> f64 {
        PI * self.peak_rad_per_s.abs() / self.duration_s
    }

    /// Largest |jerk|, rad/s³ (2π²·peak/T²).
    pub fn max_jerk_rad_per_s3(&self) -> f64 {
        2.0 * PI * PI * self.peak_rad_per_s.abs() / (self.duration_s * self.duration_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_and_ends_at_rest_and_integrates_to_half_peak_times_duration() {
        let p = SmoothVelocityProfile::new(0.1, 1.0);
        assert_eq!(p.velocity_at(0.0), 0.0);
        assert_eq!(p.velocity_at(1.0), 0.0);
        assert_eq!(p.velocity_at(-1.0), 0.0);
        assert!((p.velocity_at(0.5) - 0.1).abs() < 1e-12);
        let dt = 1e-3;
        let sum: f64 = (0..1000).map(|k| p.velocity_at(f64::from(k) * dt) * dt).sum();
        assert!((sum - p.displacement_rad()).abs() < 1e-9, "{sum}");
        assert!((p.displacement_rad() - 0.05).abs() < 1e-15);
    }

    #[test]
    fn discrete_acceleration_and_jerk_stay_within_the_bounds() {
        let p = SmoothVelocityProfile::new(0.1, 1.0);
        let dt = 1e-3;
        let v: Vec<f64> = (0..=1100).map(|k| p.velocity_at(f64::from(k) * dt)).collect();
        let a: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let j: Vec<f64> = a.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let a_max = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let j_max = j.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(a_max <= p.max_acceleration_rad_per_s2() + 1e-9 && a_max < 10.0, "{a_max}");
        assert!(j_max <= p.max_jerk_rad_per_s3() * 1.01 && j_max < 5000.0, "{j_max}");
    }

    #[test]
    fn a_degenerate_duration_gives_zero() {
        assert_eq!(SmoothVelocityProfile::new(0.1, 0.0).velocity_at(0.5), 0.0);
        assert_eq!(SmoothVelocityProfile::new(0.1, f64::NAN).velocity_at(0.5), 0.0);
    }
}
