//! The servo stage: the LQ law, and what it does with a frame it cannot fully use.
//!
//! - All four marks: the law's twist ([`ServoVerdict::Servoing`]).
//! - Three: the law on those three ([`ServoVerdict::ServoingOnThree`]).
//! - Two or fewer: the camera is steered back towards where it was when all four were last seen, its own
//!   motion since then known from the joint states at capture ([`ServoVerdict::Reacquiring`]); with no such
//!   pose (none seen yet, or the camera's pose not known), zero twist ([`ServoVerdict::MarksMissing`]).

use vservo_config::Reacquire;
use vservo_control::{Gains, LawFlags, LawGains, LawGeometry, ServoLaw, Twist};
use vservo_scene::{FeatureVector, IsometryMatrix3};

/// Why the servo sent the twist it sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServoVerdict {
    /// No frame has come through the pipeline yet: zero twist.
    Waiting,
    /// The law's twist for a frame with all four marks.
    Servoing,
    /// The law's twist on the three marks seen (bit m set for the missing mark m).
    ServoingOnThree(u8),
    /// Two or more marks missing (bit m set for mark m), or one and no design for the three seen (their
    /// desired images in a line): steering back to where all were last seen.
    Reacquiring(u8),
    /// Marks missing and nowhere known to go back to: zero twist.
    MarksMissing(u8),
}

/// A frame leaving the pipeline, as the servo takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoInput<'a> {
    /// The frame number.
    pub frame: u64,
    /// ξ (px), NaN where a mark is not valid.
    pub features: &'a FeatureVector,
    /// The camera's pose at capture, if known.
    pub base_from_camera: Option<&'a IsometryMatrix3<f64>>,
}

/// The servo: the law, its command history, and the pose where all marks were last seen.
#[derive(Debug, Clone)]
pub struct ServoStage {
    law: ServoLaw,
    period_s: f64,
    reacquire: Reacquire,
    last_seen_whole: Option<IsometryMatrix3<f64>>,
}

impl ServoStage {
    pub(crate) fn new(geometry: LawGeometry, gains: &Gains, reacquire: Reacquire) -> Self {
        Self {
            law: ServoLaw::new(geometry, gains),
            period_s: geometry.period_s,
            reacquire,
            last_seen_whole: None,
        }
    }

    /// The desired features ξ_d.
    pub fn desired_features(&self) -> &FeatureVector {
        self.law.desired_features()
    }

    /// Swaps in new gains, keeping the command history (no twist jump beyond the new gain's own).
    pub fn set_gains(&mut self, gains: &LawGains) {
        self.law.set_law_gains(gains);
    }

    /// What the law did beyond the law as designed on the last frame [`ServoStage::step`] took (all false
    /// when it reacquired or held).
    pub fn law_flags(&self) -> LawFlags {
        self.law.flags()
    }

    /// A frame while the cell is held in a safe stop: zero twist, and the law remembers that zero was sent
    /// (so that a delay-aware law resumes from what the arm really got).
    pub fn hold(&mut self) -> Twist {
        self.law.hold()
    }

    /// The twist for the frame leaving the pipeline now (`None` before the first one has).
    pub fn step(&mut self, delivered: Option<ServoInput<'_>>) -> (Twist, ServoVerdict) {
        let Some(input) = delivered else { return (Twist::zeros(), ServoVerdict::Waiting) };
        let seen = input.features;
        let mut missing = 0u8;
        for mark in 0..seen.len() / 2 {
            if !(seen[2 * mark].is_finite() && seen[2 * mark + 1].is_finite()) {
                missing |= 1 << mark;
            }
        }
        if missing == 0 {
            self.last_seen_whole = input.base_from_camera.copied();
        }
        match self.law.step(input.frame, seen, input.base_from_camera) {
            Some(twist) if missing == 0 => (twist, ServoVerdict::Servoing),
            Some(twist) => (twist, ServoVerdict::ServoingOnThree(missing)),
            None => match (self.last_seen_whole, input.base_from_camera) {
                (Some(then), Some(now)) => {
                    let twist = steer_towards(now, &then, self.period_s, &self.reacquire);
                    self.law.sent(twist);
                    (twist, ServoVerdict::Reacquiring(missing))
                }
                _ => (self.law.hold(), ServoVerdict::MarksMissing(missing)),
            },
        }
    }
}

/// The camera twist (in the camera frame) that moves the camera from `now` towards `then` with the
/// `[reacquire]` gain, its speeds capped, and never beyond `then` within one frame.
pub fn steer_towards(
    now: &IsometryMatrix3<f64>,
    then: &IsometryMatrix3<f64>,
    period_s: f64,
    reacquire: &Reacquire,
) -> Twist {
    let now_from_then = now.inverse() * then;
    let translation = now_from_then.translation.vector;
    let rotation = now_from_then.rotation.scaled_axis();
    let gain = reacquire.gain_per_s.min(1.0 / period_s);
    let mut v = translation * gain;
    let mut w = rotation * gain;
    if v.norm() > reacquire.max_speed_m_s {
        v *= reacquire.max_speed_m_s / v.norm();
    }
    if w.norm() > reacquire.max_rotation_rad_s {
        w *= reacquire.max_rotation_rad_s / w.norm();
    }
    Twist::new(v.x, v.y, v.z, w.x, w.y, w.z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3, Vector3};

    #[test]
    fn steering_back_points_the_camera_to_where_it_was_and_stays_within_its_limits() {
        let then = IsometryMatrix3::identity();
        let now = IsometryMatrix3::from_parts(Translation3::new(0.02, 0.0, 0.0), Rotation3::identity());
        let reacquire = Reacquire::default();
        let twist = steer_towards(&now, &then, 0.085, &reacquire);
        // back along −x of the camera, at the gain
        assert!((twist[0] + 0.02 * reacquire.gain_per_s).abs() < 1e-12, "{twist}");
        assert!(twist.rows(1, 5).amax() < 1e-12);
        let far = IsometryMatrix3::from_parts(
            Translation3::new(1.0, 0.5, 0.0),
            Rotation3::from_axis_angle(&Vector3::z_axis(), 1.0),
        );
        let twist = steer_towards(&far, &then, 0.085, &reacquire);
        assert!(twist.fixed_rows::<3>(0).norm() <= reacquire.max_speed_m_s + 1e-12);
        assert!(twist.fixed_rows::<3>(3).norm() <= reacquire.max_rotation_rad_s + 1e-12);
        assert!(twist[5] < 0.0, "turns back");
        // slower caps, as configured
        let gentle = Reacquire { gain_per_s: 0.5, max_speed_m_s: 0.02, max_rotation_rad_s: 0.1 };
        let twist = steer_towards(&far, &then, 0.085, &gentle);
        assert!((twist.fixed_rows::<3>(0).norm() - 0.02).abs() < 1e-12, "{twist}");
        assert!((twist.fixed_rows::<3>(3).norm() - 0.1).abs() < 1e-12, "{twist}");
        let twist = steer_towards(&now, &then, 0.085, &gentle);
        assert!((twist[0] + 0.02 * 0.5).abs() < 1e-12, "{twist}");
    }
}
