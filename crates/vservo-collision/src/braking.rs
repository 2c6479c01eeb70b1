//! How far each joint still turns when the reference brakes now: the time-optimal stop of each joint within its
//! acceleration and jerk limits, which is how the reference brakes (its generator plans each joint on its own, no
//! synchronisation), after the period in which the stop is decided. The guard's stop distance adds to what these
//! angles move the nearest points.

/// The limits a reference brakes within, per joint, and the tool's speed limit in force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrakingLimits<'a> {
    /// Acceleration limits (rad/s²).
    pub acceleration: &'a [f64],
    /// Jerk limits (rad/s³); `None`: the acceleration changes at once, and the joints brake together, their
    /// speeds scaled as one (the reference without jerk limits does).
    pub jerk: Option<&'a [f64]>,
    /// The reference's period (s): one period passes before the stop begins.
    pub period_s: f64,
    /// The tool's speed limit in force (m/s): the fastest a distance may close at the slowdown distance.
    pub tool_speed_m_s: f64,
}

/// The signed angle (rad) a joint moving at `speed` with acceleration `acceleration` turns while it stops in the
/// least time within `acceleration_limit` and `jerk_limit`: down to −A at the jerk limit, held, and eased back to
/// zero acceleration just as the speed reaches zero. Where the stop cannot avoid turning back (braking hard
/// already at a low speed) the angle is bounded by the motion's peak speed over the stop's time. Infinite where a
/// number is not finite or a limit is not positive.
pub fn stop_angle(speed: f64, acceleration: f64, acceleration_limit: f64, jerk_limit: f64) -> f64 {
    if !(speed.is_finite() && acceleration.is_finite() && acceleration_limit > 0.0 && jerk_limit > 0.0) {
        return f64::INFINITY;
    }
    let direction = if speed != 0.0 { speed.signum() } else { acceleration.signum() };
    if direction == 0.0 || !direction.is_finite() {
        return 0.0;
    }
    let (v0, a0, limit, jerk) = (speed * direction, acceleration * direction, acceleration_limit, jerk_limit);
    // the speed the joint comes to if it only eases its acceleration off: below zero, it must turn back
    if a0 < 0.0 && v0 - a0 * a0 / (2.0 * jerk) < 0.0 {
        let peak = v0.max(0.0);
        let time = (-a0) / jerk + 2.0 * (limit / jerk) + v0.abs() / limit;
        return direction * peak * time;
    }
    let deepest = if v0 + a0 * a0 / (2.0 * jerk) >= limit * limit / jerk {
        -limit
    } else {
        -(jerk * v0 + a0 * a0 / 2.0).sqrt()
    };
    let down_s = ((a0 - deepest) / jerk).max(0.0);
    let held_s = if deepest == -limit {
        ((v0 + (a0 * a0 - 2.0 * limit * limit) / (2.0 * jerk)) / limit).max(0.0)
    } else {
        0.0
    };
    let up_s = -deepest / jerk;
    let mut angle = 0.0;
    let (mut v, mut a) = (v0, a0);
    for (duration, j) in [(down_s, -jerk), (held_s, 0.0), (up_s, jerk)] {
        angle += v * duration + a * duration * duration / 2.0 + j * duration.powi(3) / 6.0;
        v += a * duration + j * duration * duration / 2.0;
        a += j * duration;
    }
    direction * angle
}

/// Each joint's signed angle while the reference brakes now: the period before the stop, then the stop (within
/// the jerk limits each joint on its own; without them the joints together at the acceleration limits, the
/// slowest setting the time). Writes the first `qd.len()` entries of `angles`.
pub fn stop_angles(qd: &[f64], qdd: &[f64], limits: &BrakingLimits, angles: &mut [f64]) {
    let dt = limits.period_s;
    let stop_s = qd
        .iter()
        .zip(limits.acceleration)
        .map(|(v, a)| if *a > 0.0 { v.abs() / a } else { f64::INFINITY })
        .fold(0.0, f64::max);
    for (j, angle) in angles.iter_mut().enumerate().take(qd.len()) {
        let (v, a) = (qd[j], qdd.get(j).copied().unwrap_or(0.0));
        let latency = v * dt + a * dt * dt / 2.0;
        let acceleration_limit = limits.acceleration.get(j).copied().unwrap_or(0.0);
        *angle = latency
            + match limits.jerk.and_then(|jerk| jerk.get(j).copied()) {
                Some(jerk) => stop_angle(v + a * dt, a, acceleration_limit, jerk),
                None => (v + a * dt) * stop_s / 2.0,
            };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stop integrated finely (1 µs, its switching within a step: 1e-7 rad) as the profile says: −J to the
    /// deepest acceleration, held, +J to zero.
    fn integrated(speed: f64, acceleration: f64, a_max: f64, j_max: f64) -> f64 {
        let dt = 1e-6;
        let (mut v, mut a, mut turned) = (speed, acceleration, 0.0);
        loop {
            // ease off when the speed left equals what easing the (negative) acceleration to zero takes
            let easing = a * a / (2.0 * j_max);
            let jerk = if a < 0.0 && v <= easing { j_max } else { -j_max };
            let next_a = (a + jerk * dt).clamp(-a_max, a_max);
            let next_v = v + (a + next_a) / 2.0 * dt;
            turned += (v + next_v) / 2.0 * dt;
            (v, a) = (next_v, next_a);
            if v <= 0.0 || (a >= 0.0 && jerk > 0.0) {
                return turned;
            }
        }
    }

    #[test]
    fn the_stop_angle_is_the_integrated_stop_for_each_kind_of_profile() {
        // (speed, acceleration): held at −A; a triangle; speeding up first; braking already
        for (speed, acceleration) in [(1.0, 0.0), (0.02, 0.0), (1.0, 5.0), (0.05, 8.0), (2.0, -3.0)] {
            let exact = stop_angle(speed, acceleration, 10.0, 500.0);
            let fine = integrated(speed, acceleration, 10.0, 500.0);
            assert!(
                (exact - fine).abs() <= 1e-7 + 1e-5 * fine,
                "({speed}, {acceleration}): {exact} against {fine}"
            );
            assert_eq!(stop_angle(-speed, -acceleration, 10.0, 500.0), -exact, "symmetric");
        }
    }

    #[test]
    fn at_rest_nothing_turns_and_a_bad_number_is_no_bound() {
        assert_eq!(stop_angle(0.0, 0.0, 4.0, 100.0), 0.0);
        assert_eq!(stop_angle(f64::NAN, 0.0, 4.0, 100.0), f64::INFINITY);
        let mut angles = [0.0; 2];
        let limits =
            BrakingLimits { acceleration: &[4.0, 2.0], jerk: None, period_s: 0.001, tool_speed_m_s: 1.0 };
        stop_angles(&[2.0, -0.5], &[0.0, 0.0], &limits, &mut angles);
        // together: the first joint's 0.5 s stop sets the time for both
        assert!((angles[0] - (0.002 + 2.0 * 0.5 / 2.0)).abs() < 1e-12, "{angles:?}");
        assert!((angles[1] - (-0.0005 - 0.5 * 0.5 / 2.0)).abs() < 1e-12, "{angles:?}");
    }
}
