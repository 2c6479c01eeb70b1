//! A move of the joints to a goal (what `vservoctl calibrate` asks of a running cell between its views): each
//! joint runs at up to a share of its speed limit and brakes at a given acceleration so as to stop on the goal
//! (overshooting by less than 1e-5 rad where the cruise turns into braking between two ticks). The change of
//! each joint's rate must then be limited joint by joint (a joint move keeps no common direction; scaling the
//! change as a whole, as the twist path does, would slow one joint's braking for another's start and
//! overshoot). Allocation-free, for the 1 ms path.

use vservo_arm::{JointLimits, JointVector};

/// Below this distance (rad) a joint is on its goal.
pub const ARRIVED_RAD: f64 = 1e-6;

/// The smallest share of the speed limits a move may ask for: slower, a move would take hours.
pub const MIN_SPEED_FRACTION: f64 = 0.01;

/// Whether `speed_fraction` is a share of the speed limits a move may use: in [[`MIN_SPEED_FRACTION`], 1].
pub fn speed_fraction_ok(speed_fraction: f64) -> bool {
    (MIN_SPEED_FRACTION..=1.0).contains(&speed_fraction)
}

/// The joint rates for the coming tick of `dt` that take `q` towards `goal`: per joint, towards the goal at
/// `speed_fraction` of its speed limit at most, no faster than braking at `acceleration` tick by tick allows
/// (v²/2a + v·dt/2 = |e|), and no further than the goal in one tick. Joints past `limits` stay still; a non-finite
/// input gives zero rates.
pub fn rates_toward(
    goal: &JointVector,
    q: &JointVector,
    limits: &[JointLimits],
    acceleration: &JointVector,
    speed_fraction: f64,
    dt: f64,
) -> JointVector {
    let mut qd = JointVector::zeros();
    let fraction = if speed_fraction.is_finite() { speed_fraction.clamp(0.0, 1.0) } else { 0.0 };
    for (j, limit) in limits.iter().enumerate() {
        let error = goal[j] - q[j];
        if !error.is_finite() || error.abs() < ARRIVED_RAD {
            continue;
        }
        let cruise = fraction * limit.velocity_max;
        // the fastest speed from which braking by a·dt a tick stops on the goal (v²/2a + v·dt/2 = |e|)
        let a_dt = acceleration[j] * dt;
        let braking = a_dt * ((0.25 + 2.0 * error.abs() / (a_dt * dt)).sqrt() - 0.5);
        let this_tick = error.abs() / dt;
        let speed = cruise.min(braking).min(this_tick);
        if speed.is_finite() {
            qd[j] = speed.copysign(error);
        }
    }
    qd
}

/// Whether every joint of `limits`' count is within [`ARRIVED_RAD`] of its goal.
pub fn arrived(goal: &JointVector, q: &JointVector, joints: usize) -> bool {
    (0..joints).all(|j| (goal[j] - q[j]).abs() < ARRIVED_RAD)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vservo_arm::puma560;

    /// What the tick-by-tick braking can overshoot by (rad).
    const MAX_OVERSHOOT_RAD: f64 = 1e-5;

    /// Steps a reference with each joint's acceleration limit on the change of its rate (a joint move needs
    /// no common direction, so each joint brakes on its own).
    fn run(goal: JointVector, start: JointVector, fraction: f64) -> (Vec<JointVector>, Vec<JointVector>) {
        let arm = puma560::puma560();
        let limits: Vec<JointLimits> = arm.limits().collect();
        let acceleration = JointVector::from([22.5, 22.5, 45.0, 90.0, 90.0, 90.0, 90.0]);
        let dt = 0.001;
        let (mut q, mut qd) = (start, JointVector::zeros());
        let (mut qs, mut qds) = (vec![q], vec![qd]);
        for _ in 0..20_000 {
            let wanted = rates_toward(&goal, &q, &limits, &acceleration, fraction, dt);
            for j in 0..6 {
                let step = acceleration[j] * dt;
                qd[j] += (wanted[j] - qd[j]).clamp(-step, step);
            }
            q += qd * dt;
            qs.push(q);
            qds.push(qd);
            if arrived(&goal, &q, 6) && qd.norm() == 0.0 {
                break;
            }
        }
        (qs, qds)
    }

    #[test]
    fn the_joints_reach_the_goal_within_their_limits_and_stop_on_it() {
        let start = puma560::QN;
        let goal = start + vservo_arm::six_joints([0.4, -0.3, 0.25, -1.0, 0.6, 1.5]);
        let (qs, qds) = run(goal, start, 0.25);
        let end = qs.last().expect("steps");
        assert!(arrived(&goal, end, 6), "{end} against {goal}");
        assert_eq!(qds.last().map(|qd| qd.norm()), Some(0.0), "at rest on the goal");
        let arm = puma560::puma560();
        for (qd, q) in qds.iter().zip(&qs) {
            for (j, limit) in arm.limits().enumerate() {
                assert!(qd[j].abs() <= 0.25 * limit.velocity_max + 1e-12, "joint {j} at {}", qd[j]);
                // never past the goal, seen from the start
                let (from, to) = (start[j], goal[j]);
                assert!(
                    (q[j] - from) * (to - from).signum() <= (to - from).abs() + MAX_OVERSHOOT_RAD,
                    "joint {j} overshoots by {}",
                    (q[j] - from) * (to - from).signum() - (to - from).abs()
                );
            }
        }
    }

    #[test]
    fn bad_numbers_give_no_motion() {
        let arm = puma560::puma560();
        let limits: Vec<JointLimits> = arm.limits().collect();
        let a = JointVector::repeat(10.0);
        let mut goal = puma560::QN;
        goal[2] = f64::NAN;
        let qd = rates_toward(&goal, &puma560::QN, &limits, &a, 0.5, 0.001);
        assert_eq!(qd, JointVector::zeros());
        let qd = rates_toward(&(puma560::QN * 2.0), &puma560::QN, &limits, &a, f64::NAN, 0.001);
        assert_eq!(qd, JointVector::zeros());
    }
}
