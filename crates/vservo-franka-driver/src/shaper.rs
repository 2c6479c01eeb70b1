//! The driver's last guard on what the robot is sent (libfranka's `limit_rate`, done per period): each joint's
//! commanded velocity, seen as the robot sees it — its change over one period an acceleration, the change of
//! that a jerk — kept within the arm's acceleration and jerk limits, whatever comes from the rmrc.
//!
//! The rmrc's reference already keeps those limits (vservo-sim's jerk-limited interpolator), and when its answers
//! come one per period the guard passes them on unchanged. It acts when they do not: an answer that came too late
//! repeats the last one (a step in acceleration), the arm held or brought to rest (the target drops to zero),
//! a reference restarted at rest. Each period each joint speeds up towards its target at most as fast as it
//! could still stop on it (a = √(2·j·|error|)), at most its acceleration limit, and changes its acceleration by at
//! most its jerk limit times the period; near rest it lands on zero exactly.

use vservo_protocol::MAX_JOINTS;

/// Each joint's acceleration (rad/s²) and jerk (rad/s³) limits, and the period (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShaperLimits {
    /// Acceleration per joint.
    pub acceleration: [f64; MAX_JOINTS],
    /// Jerk per joint.
    pub jerk: [f64; MAX_JOINTS],
    /// The period.
    pub dt_s: f64,
}

/// The velocities sent so far, as the robot measures them.
#[derive(Debug, Clone)]
pub struct CommandShaper {
    limits: ShaperLimits,
    /// The dynamics override in force (0–1]: the share of the acceleration and jerk limits kept.
    speed_scale: f64,
    joints: usize,
    /// The last velocity sent (rad/s).
    velocity: [f64; MAX_JOINTS],
    /// Its change over the last period (rad/s²).
    acceleration: [f64; MAX_JOINTS],
}

impl CommandShaper {
    /// A guard for `joints` joints whose motion starts at `velocity` and `acceleration`: a robot's motion starts
    /// from its own desired velocity and acceleration (`dq_d`, `ddq_d`), which its checker differences the first
    /// command against, as libfranka's rate limiter starts from them. A motion started after a recovery that
    /// left the arm still slowing down starts from that deceleration, not from none.
    pub fn new(
        limits: ShaperLimits,
        joints: usize,
        velocity: [f64; MAX_JOINTS],
        acceleration: [f64; MAX_JOINTS],
    ) -> Self {
        let acceleration = acceleration.map(|a| if a.is_finite() { a } else { 0.0 });
        Self { limits, speed_scale: 1.0, joints: joints.min(MAX_JOINTS), velocity, acceleration }
    }

    /// Keeps `speed_scale` (0–1] of the acceleration and jerk limits from the next command on, as the rmrc's
    /// reference does (another value is ignored). An acceleration above the new limit comes down within the jerk
    /// limit, never in one step.
    pub fn set_speed_scale(&mut self, speed_scale: f64) {
        if speed_scale > 0.0 && speed_scale <= 1.0 {
            self.speed_scale = speed_scale;
        }
    }

    /// The velocity to send this period towards `target` (a non-finite target is taken as zero: rest).
    pub fn next(&mut self, target: &[f64; MAX_JOINTS]) -> [f64; MAX_JOINTS] {
        let dt = self.limits.dt_s;
        let joints = self.joints;
        for (j, goal) in target.iter().enumerate().take(joints) {
            let (v, a) = (self.velocity[j], self.acceleration[j]);
            let scale = self.speed_scale;
            let (a_max, jerk) = (self.limits.acceleration[j] * scale, self.limits.jerk[j] * scale);
            let goal = if goal.is_finite() { *goal } else { 0.0 };
            let error = goal - v;
            let step = jerk * dt;
            let next_a = if error.abs() <= 0.5 * step * dt && a.abs() <= 0.5 * step {
                // on the target within what one period can settle: land on it
                error / dt
            } else {
                let wanted =
                    (error.abs() / dt).min((2.0 * jerk * error.abs()).sqrt()).min(a_max).copysign(error);
                // the jerk limit last: an acceleration above the limit (a lower override, or the robot's own
                // at the start) comes down within it
                wanted.clamp(-a_max, a_max).clamp(a - step, a + step)
            };
            self.acceleration[j] = next_a;
            self.velocity[j] = v + next_a * dt;
        }
        self.velocity
    }

    /// Whether the last velocity sent is zero with no acceleration left: the arm commanded to rest.
    pub fn at_rest(&self) -> bool {
        self.velocity[..self.joints].iter().all(|v| *v == 0.0)
            && self.acceleration[..self.joints].iter().all(|a| *a == 0.0)
    }

    /// The last velocity sent.
    #[cfg(test)]
    pub fn velocity(&self) -> &[f64; MAX_JOINTS] {
        &self.velocity
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn fr3() -> ShaperLimits {
        ShaperLimits { acceleration: [10.0; MAX_JOINTS], jerk: [5000.0; MAX_JOINTS], dt_s: 0.001 }
    }

    /// The largest acceleration and jerk, per the robot's differences, of `sent` after a start at `start`
    /// (velocity, acceleration).
    fn measured(
        start: ([f64; MAX_JOINTS], [f64; MAX_JOINTS]),
        sent: &[[f64; MAX_JOINTS]],
        dt: f64,
    ) -> (f64, f64) {
        let (mut a_max, mut j_max) = (0.0f64, 0.0f64);
        let (mut last_v, mut last_a) = start;
        for v in sent {
            for j in 0..MAX_JOINTS {
                let a = (v[j] - last_v[j]) / dt;
                a_max = a_max.max(a.abs());
                j_max = j_max.max(((a - last_a[j]) / dt).abs());
                last_a[j] = a;
            }
            last_v = *v;
        }
        (a_max, j_max)
    }

    proptest! {
        #[test]
        fn whatever_the_targets_every_command_keeps_the_limits_and_rest_is_reached_exactly(
            targets in prop::collection::vec((prop::array::uniform7(-2.0..2.0f64), 1usize..200), 1..20),
        ) {
            let limits = fr3();
            let mut shaper = CommandShaper::new(limits, 7, [0.0; MAX_JOINTS], [0.0; MAX_JOINTS]);
            let mut sent = Vec::new();
            for (target, periods) in &targets {
                for _ in 0..*periods {
                    sent.push(shaper.next(target));
                }
            }
            for _ in 0..2000 {
                sent.push(shaper.next(&[0.0; MAX_JOINTS]));
            }
            let (a, j) = measured(([0.0; MAX_JOINTS], [0.0; MAX_JOINTS]), &sent, limits.dt_s);
            prop_assert!(a <= 10.0 * (1.0 + 1e-9), "acceleration {}", a);
            prop_assert!(j <= 5000.0 * (1.0 + 1e-9), "jerk {}", j);
            prop_assert!(shaper.at_rest(), "{:?}", shaper.velocity());
        }
    }

    #[test]
    fn a_reference_within_the_limits_passes_unchanged() {
        let limits = fr3();
        let mut shaper = CommandShaper::new(limits, 7, [0.0; MAX_JOINTS], [0.0; MAX_JOINTS]);
        // a smooth rise to 0.5 rad/s and back (1 − cos), one sample per period: within the limits
        for k in 1..=800 {
            let v = 0.25 * (1.0 - (std::f64::consts::PI * k as f64 * 0.001 / 0.4).cos());
            let sent = shaper.next(&[v; MAX_JOINTS]);
            assert!((sent[0] - v).abs() < 1e-12, "period {k}: {} against {v}", sent[0]);
        }
    }

    #[test]
    fn a_repeated_sample_is_smoothed_and_a_non_finite_target_is_rest() {
        let limits = fr3();
        let mut shaper = CommandShaper::new(limits, 7, [0.0; MAX_JOINTS], [0.0; MAX_JOINTS]);
        let ramp: Vec<f64> = (1..=50).map(|k| 0.5 * 10.0 * (k as f64 * 0.001).powi(2) * 100.0).collect();
        let mut sent = Vec::new();
        for (k, v) in ramp.iter().enumerate() {
            // every fifth answer late: the last one again
            let target = if k % 5 == 4 { ramp[k - 1] } else { *v };
            sent.push(shaper.next(&[target; MAX_JOINTS]));
        }
        let (a, j) = measured(([0.0; MAX_JOINTS], [0.0; MAX_JOINTS]), &sent, 0.001);
        assert!(a <= 10.0 + 1e-9 && j <= 5000.0 + 1e-6, "{a} {j}");
        for _ in 0..1000 {
            shaper.next(&[f64::NAN; MAX_JOINTS]);
        }
        assert!(shaper.at_rest());
    }

    /// A motion started while the arm still slows down (franka-sim's recovery replies before the arm settles):
    /// `dq_d` 0.3 rad/s, `ddq_d` −7 rad/s², and a reference that wants 0.6 rad/s, then rest. The commands go
    /// from that deceleration within the jerk limit as the robot differences them from its own `ddq_d`, and bring
    /// the arm to rest. Started from no acceleration instead, the first command's jerk is 11,900 rad/s³: the
    /// robot's `joint_motion_generator_acceleration_discontinuity` reflex, which a run on franka-sim met.
    #[test]
    fn a_motion_started_while_the_arm_slows_down_continues_from_its_deceleration_within_the_jerk_limit() {
        let limits = fr3();
        let start = ([0.3; MAX_JOINTS], [-7.0; MAX_JOINTS]);
        let targets = (0..2000).map(|k| if k < 200 { 0.6 } else { 0.0 });
        let mut shaper = CommandShaper::new(limits, 7, start.0, start.1);
        let sent: Vec<[f64; MAX_JOINTS]> = targets.map(|v| shaper.next(&[v; MAX_JOINTS])).collect();
        let (a, j) = measured(start, &sent, limits.dt_s);
        assert!(a <= 10.0 + 1e-9 && j <= 5000.0 + 1e-6, "acceleration {a}, jerk {j}");
        assert!(shaper.at_rest());
        // the premise: from no acceleration, one period takes the robot's −7 rad/s² to +4.9
        let mut unaware = CommandShaper::new(limits, 7, start.0, [0.0; MAX_JOINTS]);
        let first = unaware.next(&[0.6; MAX_JOINTS]);
        let (_, j) = measured(start, &[first], limits.dt_s);
        assert!(j > 5000.0, "{j}");
    }

    /// At a quarter of the limits (the cell's dynamics override), answers late every fifth period (the last
    /// one again) are smoothed within a quarter of the jerk limit; and when the override drops from 1 to a
    /// quarter while the arm accelerates at its limit, the acceleration comes down within the new jerk limit,
    /// never in one step.
    #[test]
    fn the_guard_keeps_the_dynamics_override_late_answers_and_a_lower_override_included() {
        let limits = fr3();
        let mut shaper = CommandShaper::new(limits, 7, [0.0; MAX_JOINTS], [0.0; MAX_JOINTS]);
        shaper.set_speed_scale(0.25);
        // a reference within a quarter of the limits: 0.25 · 0.99 · 10 rad/s² at most
        let ramp: Vec<f64> = (1..=400).map(|k| 0.5 * 2.47 * (k as f64 * 0.001).powi(2)).collect();
        let sent: Vec<[f64; MAX_JOINTS]> = ramp
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let target = if k % 5 == 4 { ramp[k - 1] } else { *v };
                shaper.next(&[target; MAX_JOINTS])
            })
            .collect();
        let (a, j) = measured(([0.0; MAX_JOINTS], [0.0; MAX_JOINTS]), &sent, 0.001);
        assert!(a <= 2.5 + 1e-9 && j <= 1250.0 + 1e-6, "acceleration {a}, jerk {j}");
        // full speed, full acceleration, then a quarter
        let mut shaper = CommandShaper::new(limits, 7, [0.0; MAX_JOINTS], [0.0; MAX_JOINTS]);
        let before: Vec<[f64; MAX_JOINTS]> = (0..10).map(|_| shaper.next(&[2.0; MAX_JOINTS])).collect();
        let start = (before[9], std::array::from_fn(|j| (before[9][j] - before[8][j]) / 0.001));
        assert!(start.1[0] > 9.0, "accelerating at the limit: {}", start.1[0]);
        shaper.set_speed_scale(0.25);
        let sent: Vec<[f64; MAX_JOINTS]> = (0..2000).map(|_| shaper.next(&[2.0; MAX_JOINTS])).collect();
        let (_, j) = measured(start, &sent, 0.001);
        assert!(j <= 1250.0 + 1e-6, "jerk {j} after the override dropped");
        let (a_end, _) = measured((sent[1500], [0.0; MAX_JOINTS]), &sent[1501..], 0.001);
        assert!(a_end <= 2.5 + 1e-9, "within a quarter's acceleration once it has come down: {a_end}");
    }
}
