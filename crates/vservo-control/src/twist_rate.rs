//! The twist shaped to what the arm can follow within a frame.
//!
//! The law is designed for an arm whose camera moves with the twist it was sent for the whole frame. A real
//! arm's reference keeps acceleration and jerk limits: a twist that asks the joints to change speed by more
//! than they can within the frame is reached only in a later frame, and the camera goes on moving after the
//! law has asked it to stop. The law then swings (measured on the UR5e's limits: from 60 px, between 2 and 77
//! px for seconds, docs/BENCHMARKS.md "A law that knows what the arm can follow").
//!
//! [`TwistRateLimit`] bounds the change of the twist from one frame to the next so that every joint's speed
//! can change by it, from rest in acceleration, within the frame and the arm's acceleration and jerk limits:
//! the change is scaled down as a whole (its direction kept) to the most the busiest joint can take. The law
//! remembers the twist as sent (anti-windup): its prediction through the pipeline's delay is of what the arm
//! was really asked.
//!
//! The joints' speeds per twist come from the arm's Jacobian at one pose (the desired one, where the law
//! works), computed by whoever knows the arm; here it is a matrix.

use nalgebra::{SMatrix, SVector, Vector6};

use crate::Twist;

/// The most joints a limit is kept for (vservo's arms have 6 or 7).
pub const MAX_LIMITED_JOINTS: usize = 7;

/// Joint speed per camera twist, one row per joint (rows past the arm's joints zero).
pub type JointRatesPerTwist = SMatrix<f64, MAX_LIMITED_JOINTS, 6>;

/// One joint's acceleration and jerk limits (rad/s², rad/s³; no jerk limit: infinite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDynamics {
    /// The acceleration limit (rad/s²).
    pub acceleration_rad_s2: f64,
    /// The jerk limit (rad/s³); infinite when the arm has none.
    pub jerk_rad_s3: f64,
}

impl JointDynamics {
    /// The most a joint's speed can change (rad/s) within `within_s`, starting and ending without
    /// acceleration, within these limits: the jerk-limited ramp's, `J τ²/4` while the acceleration stays
    /// under its limit, `A (τ − A/J)` once it reaches it.
    pub fn speed_change_within(&self, within_s: f64) -> f64 {
        let (a, j) = (self.acceleration_rad_s2, self.jerk_rad_s3);
        if !j.is_finite() {
            return a * within_s;
        }
        if j * within_s / 2.0 <= a { j * within_s * within_s / 4.0 } else { a * (within_s - a / j) }
    }
}

/// Why a limit could not be made.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TwistRateError {
    /// More joints than [`MAX_LIMITED_JOINTS`].
    #[error("{0} joints: a twist rate limit keeps at most {MAX_LIMITED_JOINTS}")]
    TooManyJoints(usize),
    /// A limit or the frame's time is not a positive number.
    #[error("joint {joint}: the acceleration, jerk and frame time must be positive (got {value})")]
    NotPositive {
        /// One-based joint number (0: the frame's time).
        joint: usize,
        /// The value refused.
        value: f64,
    },
}

/// What an arm follows of the twist it is sent: its rate limit, and the lag (s) through which the camera's
/// velocity follows the twist (its drives', and the reference's ramps within the frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmResponse {
    /// The bound on the twist's change between frames.
    pub rate_limit: TwistRateLimit,
    /// The time constant (s) of the first-order lag the law predicts the camera's motion through.
    pub lag_s: f64,
}

/// The bound on the change of the twist between frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwistRateLimit {
    /// Row j: joint j's speed per twist over the most joint j's speed may change within a frame. A change
    /// Δu is followed within the frame when every |row · Δu| ≤ 1 (at the full limits).
    load_per_change: JointRatesPerTwist,
    /// The dynamics override in force: the share of the limits the reference keeps (a speed change scales
    /// with it, the acceleration and jerk limits both scaled by it).
    speed_scale: f64,
}

impl TwistRateLimit {
    /// The limit for joints whose speeds per twist are `joint_rates` (rows past `dynamics.len()` ignored),
    /// with these limits, the ramp to complete within `within_s`.
    pub fn new(
        joint_rates: &JointRatesPerTwist,
        dynamics: &[JointDynamics],
        within_s: f64,
    ) -> Result<Self, TwistRateError> {
        if dynamics.len() > MAX_LIMITED_JOINTS {
            return Err(TwistRateError::TooManyJoints(dynamics.len()));
        }
        if !(within_s.is_finite() && within_s > 0.0) {
            return Err(TwistRateError::NotPositive { joint: 0, value: within_s });
        }
        let mut load_per_change = JointRatesPerTwist::zeros();
        for (j, limits) in dynamics.iter().enumerate() {
            let (a, jerk) = (limits.acceleration_rad_s2, limits.jerk_rad_s3);
            // a finite acceleration; a jerk that may be infinite (none), NaN refused by both comparisons
            for (value, ok) in [(a, a.is_finite() && a > 0.0), (jerk, jerk > 0.0)] {
                if !ok {
                    return Err(TwistRateError::NotPositive { joint: j + 1, value });
                }
            }
            let most = limits.speed_change_within(within_s);
            load_per_change.set_row(j, &(joint_rates.row(j) / most));
        }
        Ok(Self { load_per_change, speed_scale: 1.0 })
    }

    /// The same limit with the reference keeping `speed_scale` (0–1] of the arm's acceleration and jerk
    /// limits; any other value leaves it as it is.
    pub fn at_speed_scale(self, speed_scale: f64) -> Self {
        if speed_scale > 0.0 && speed_scale <= 1.0 { Self { speed_scale, ..self } } else { self }
    }

    /// The twist sent after `previous`, moving towards `wanted` as far as the arm follows within a frame.
    ///
    /// - **Braking in time.** With `to_go`, the twist that would close the error within one frame (−B⁺ ê on
    ///   the error predicted through the pipeline), `wanted` is first scaled down, whole, to the speed from
    ///   which the arm can still stop within that motion: braking by at most the frame's change each frame
    ///   from a load L covers L²/2 + L/2 frames' worth of it, so L ≤ √(1/4 + 2 L_to_go) − 1/2 (loads in
    ///   frames' changes of the busiest joint).
    /// - **Within the frame.** The change from `previous` is then scaled down as a whole (its direction kept) to
    ///   the most the busiest joint follows within the frame.
    ///
    /// `wanted` itself when the arm follows it and can stop in time.
    pub fn shape(&self, previous: &Twist, wanted: &Twist, to_go: Option<&Twist>) -> Twist {
        let mut wanted = *wanted;
        if let Some(to_go) = to_go {
            // the motion to go along the twist wanted
            let along = wanted.dot(to_go).max(0.0) / wanted.norm_squared().max(f64::MIN_POSITIVE);
            // within one frame's change the arm stops within a frame anyway: the law's own small twists are
            // never cut
            let most = ((0.25 + 2.0 * self.load(&(wanted * along))).sqrt() - 0.5).max(1.0);
            let load = self.load(&wanted);
            if load > most && load.is_finite() {
                wanted *= most / load;
            }
        }
        let change: Vector6<f64> = wanted - previous;
        let busiest = self.load(&change);
        if busiest <= 1.0 || !busiest.is_finite() {
            return if busiest.is_finite() { wanted } else { *previous };
        }
        previous + change / busiest
    }

    /// A twist (or a change of it) in frames' changes of the busiest joint: 1 is the most a joint's speed
    /// follows within one frame.
    fn load(&self, twist: &Twist) -> f64 {
        let loads: SVector<f64, MAX_LIMITED_JOINTS> = self.load_per_change * twist;
        loads.amax() / self.speed_scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const UR5E: JointDynamics = JointDynamics { acceleration_rad_s2: 5.0, jerk_rad_s3: 100.0 };

    #[test]
    fn the_speed_change_is_the_jerk_limited_ramp_s() {
        // J τ/2 = 4.2 < 5: the acceleration never reaches its limit
        assert!((UR5E.speed_change_within(0.084) - 100.0 * 0.084 * 0.084 / 4.0).abs() < 1e-12);
        // J τ/2 = 25 > 5: a trapezoid of acceleration, 5 rad/s² for τ − A/J
        assert!((UR5E.speed_change_within(0.5) - 5.0 * (0.5 - 0.05)).abs() < 1e-12);
        let no_jerk = JointDynamics { acceleration_rad_s2: 5.0, jerk_rad_s3: f64::INFINITY };
        assert!((no_jerk.speed_change_within(0.1) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_change_the_arm_follows_is_kept_and_a_larger_one_scaled_whole() {
        let mut rates = JointRatesPerTwist::zeros();
        rates[(0, 0)] = 2.0; // joint 1: 2 rad/s per m/s along x
        rates[(1, 5)] = 1.0; // joint 2: 1 rad/s per rad/s about z
        let limit = TwistRateLimit::new(&rates, &[UR5E, UR5E], 0.084).expect("valid");
        let most = UR5E.speed_change_within(0.084);
        let previous = Twist::new(0.01, 0.0, 0.0, 0.0, 0.0, 0.02);
        let small = previous + Twist::new(0.5 * most / 2.0, 0.3, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(limit.shape(&previous, &small, None), small, "within the limits: as wanted");
        let wanted = previous + Twist::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.5);
        let sent = limit.shape(&previous, &wanted, None);
        let change = sent - previous;
        // the busiest joint (joint 1: 2 rad/s against joint 2's 0.5) at its most, the direction kept
        assert!((2.0 * change[0] - most).abs() < 1e-12, "{change}");
        assert!((change[5] / change[0] - 0.5).abs() < 1e-12, "{change}");
        assert!(change[5] < most);
        // at a quarter of the limits, a quarter of the change
        let slow = limit.at_speed_scale(0.25).shape(&previous, &wanted, None) - previous;
        assert!((2.0 * slow[0] - 0.25 * most).abs() < 1e-12, "{slow}");
        assert_eq!(limit.at_speed_scale(0.0), limit, "out of range: unchanged");
    }

    #[test]
    fn limits_that_are_not_positive_are_refused() {
        let rates = JointRatesPerTwist::zeros();
        let bad = JointDynamics { acceleration_rad_s2: 0.0, jerk_rad_s3: 100.0 };
        assert!(matches!(
            TwistRateLimit::new(&rates, &[UR5E, bad], 0.084),
            Err(TwistRateError::NotPositive { joint: 2, .. })
        ));
        assert!(TwistRateLimit::new(&rates, &[UR5E; 8], 0.084).is_err());
        assert!(TwistRateLimit::new(&rates, &[UR5E], f64::NAN).is_err());
    }
}
