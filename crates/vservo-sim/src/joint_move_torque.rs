//! The share of the speed limits a joint move may use within the drives' torque: planned once, when the move
//! is asked for, for an arm whose dynamics are known (a torque-driven one).
//!
//! A joint move at share s is the move at share 1 slowed in time (`vservo_sim::interpolator`: cruise at s of
//! each speed limit, speeding up and braking at s² of each acceleration limit), so at each point of its path
//! each joint's torque is τ(s) = s²·a + s·b + c: a the inertial and Coriolis torque (rigid body and armature)
//! at share 1, b the viscous friction at share 1, c gravity and Coulomb friction. The share-1 move is sampled
//! (each joint's rest-to-rest trapezoid, a triangle when short) and the share is the largest, up to the one
//! asked for, at which no joint needs more than [`TORQUE_MARGIN`] of its torque limit. Over 128 samples and
//! both sides of each joint's changes of phase, about 170 passes of Newton–Euler; nothing allocated.

use vservo_arm::{JointVector, SerialArm};

use crate::joint_move::MIN_SPEED_FRACTION;

/// The share of each joint's torque limit a planned move may ask of its drive: the rest is the joint servo's,
/// to correct what the reference does not foresee.
pub const TORQUE_MARGIN: f64 = 0.8;

/// Evenly spaced samples of the share-1 move, besides the changes of phase.
const SAMPLES: usize = 128;

/// One joint's rest-to-rest move at share 1.
#[derive(Debug, Clone, Copy, Default)]
struct Trapezoid {
    /// +1 or −1: the way to the goal.
    direction: f64,
    acceleration: f64,
    /// The speed it cruises at (the peak of a triangle).
    peak: f64,
    accelerating_s: f64,
    cruising_s: f64,
}

impl Trapezoid {
    fn new(distance: f64, speed: f64, acceleration: f64) -> Self {
        let length = distance.abs();
        if length == 0.0 || !(speed > 0.0 && acceleration > 0.0) {
            return Self::default();
        }
        let (peak, cruising_s) = if length >= speed * speed / acceleration {
            (speed, length / speed - speed / acceleration)
        } else {
            ((length * acceleration).sqrt(), 0.0)
        };
        Self {
            direction: distance.signum(),
            acceleration,
            peak,
            accelerating_s: peak / acceleration,
            cruising_s,
        }
    }

    fn duration_s(&self) -> f64 {
        2.0 * self.accelerating_s + self.cruising_s
    }

    /// Where its phases change (s).
    fn phase_changes(&self) -> [f64; 2] {
        [self.accelerating_s, self.accelerating_s + self.cruising_s]
    }

    /// Its way from the start, speed and acceleration at `t` (s).
    fn at(&self, t: f64) -> (f64, f64, f64) {
        let (a, ta, tc) = (self.acceleration, self.accelerating_s, self.cruising_s);
        let (way, speed, acceleration) = if t <= 0.0 || self.peak == 0.0 {
            (0.0, 0.0, if self.peak == 0.0 { 0.0 } else { a })
        } else if t < ta {
            (0.5 * a * t * t, a * t, a)
        } else if t < ta + tc {
            (0.5 * self.peak * ta + self.peak * (t - ta), self.peak, 0.0)
        } else if t < self.duration_s() {
            let left = self.duration_s() - t;
            (self.peak * (ta + tc) - 0.5 * a * left * left, a * left, -a)
        } else {
            (self.peak * (ta + tc), 0.0, 0.0)
        };
        (self.direction * way, self.direction * speed, self.direction * acceleration)
    }
}

/// The share of the speed limits the joint move from `start` to `goal` may use, at most `requested`: the
/// largest at which, along the whole move, every joint's inverse-dynamics torque stays within `margin` of its
/// limit (`acceleration`: each joint's acceleration limit, which the move uses at share 1). Never below
/// [`MIN_SPEED_FRACTION`]; `requested` as it is when the torque allows it (or when slowing cannot help: a joint
/// whose gravity alone is beyond the margin).
pub fn torque_limited_share(
    arm: &SerialArm,
    start: &JointVector,
    goal: &JointVector,
    acceleration: &JointVector,
    requested: f64,
    margin: f64,
) -> f64 {
    let joints = arm.joint_count();
    let mut moves = [Trapezoid::default(); vservo_arm::MAX_JOINTS];
    for (j, limits) in arm.limits().enumerate() {
        moves[j] = Trapezoid::new(goal[j] - start[j], limits.velocity_max, acceleration[j]);
    }
    let moves = &moves[..joints];
    let duration_s = moves.iter().map(Trapezoid::duration_s).fold(0.0, f64::max);
    if !duration_s.is_finite() || duration_s == 0.0 {
        return requested;
    }
    let mut share = requested;
    let mut check = |t: f64| share = share.min(share_at(arm, start, moves, t, margin));
    for i in 0..=SAMPLES {
        check(duration_s * i as f64 / SAMPLES as f64);
    }
    // both sides of each change of acceleration, where the torque jumps
    for change in moves.iter().flat_map(Trapezoid::phase_changes) {
        check(change * (1.0 - 1e-9));
        check(change * (1.0 + 1e-9));
    }
    share.max(MIN_SPEED_FRACTION.min(requested))
}

/// The largest share at which no joint's torque at `t` of the share-1 move is beyond `margin` of its limit.
fn share_at(arm: &SerialArm, start: &JointVector, moves: &[Trapezoid], t: f64, margin: f64) -> f64 {
    let (mut q, mut qd, mut qdd) = (*start, JointVector::zeros(), JointVector::zeros());
    for (j, m) in moves.iter().enumerate() {
        let (way, speed, acceleration) = m.at(t);
        q[j] += way;
        qd[j] = speed;
        qdd[j] = acceleration;
    }
    let gravity = arm.gravity_torque(&q);
    let rigid = arm.rne_rigid(&q, &qd, &qdd);
    let mut share = f64::INFINITY;
    for (j, link) in arm.links.iter().enumerate().take(moves.len()) {
        let drive = &link.drive;
        let viscous = drive.gear_ratio * drive.gear_ratio * drive.viscous_friction * qd[j];
        let inertial = rigid[j] - gravity[j] + drive.reflected_inertia() * qdd[j];
        let still = gravity[j] + drive.friction_torque(qd[j]) - viscous;
        share = share.min(first_reaching(inertial, viscous, still, margin * link.limits.torque_max));
    }
    share
}

/// The smallest s > 0 at which |a·s² + b·s + c| reaches `limit`; infinite when it never does, or when |c|
/// is there already (slowing down cannot help).
fn first_reaching(a: f64, b: f64, c: f64, limit: f64) -> f64 {
    if c.abs() >= limit || c.is_nan() {
        return f64::INFINITY;
    }
    [c - limit, c + limit]
        .into_iter()
        .flat_map(|constant| positive_roots(a, b, constant))
        .fold(f64::INFINITY, f64::min)
}

/// The positive roots of a·s² + b·s + c (none: infinite).
fn positive_roots(a: f64, b: f64, c: f64) -> [f64; 2] {
    let positive = |s: f64| if s > 0.0 && s.is_finite() { s } else { f64::INFINITY };
    if a == 0.0 {
        return [positive(-c / b), f64::INFINITY];
    }
    let discriminant = b * b - 4.0 * a * c;
    if discriminant < 0.0 {
        return [f64::INFINITY; 2];
    }
    let root = discriminant.sqrt();
    [positive((-b - root) / (2.0 * a)), positive((-b + root) / (2.0 * a))]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interpolator::{Interpolator, InterpolatorSettings};
    use vservo_arm::{puma560, six_joints};

    /// Far apart: the waist most of its range, the wrist 4.5 rad.
    fn far_goal() -> JointVector {
        six_joints([2.6, -0.6, 0.6, -1.8, -1.6, 4.5])
    }

    /// The worst share of a torque limit the reference asks, by inverse dynamics, over the move at `share`
    /// (the reference stepped tick by tick to its goal).
    fn worst_torque_share(share: f64) -> f64 {
        let arm = puma560::puma560();
        let settings = InterpolatorSettings::new(0.085, 0.001);
        let mut interpolator = Interpolator::new(
            settings,
            arm.clone(),
            vservo_scene::CameraMount::Hand { tool_from_camera: vservo_arm::Transform::identity() },
            puma560::QN,
        );
        interpolator.move_joints_to(far_goal(), share);
        let mut worst = 0.0f64;
        for tick in 0..20_000 {
            let r = *interpolator.step(tick as f64 * 0.001);
            let torque = arm.rne(&r.q, &r.qd, &r.qdd);
            for (j, limits) in arm.limits().enumerate() {
                worst = worst.max(torque[j].abs() / limits.torque_max);
            }
            if interpolator.joint_move_arrived() {
                return worst;
            }
        }
        panic!("the move at {share} did not arrive");
    }

    #[test]
    fn a_far_move_at_full_speed_is_slowed_to_what_the_drives_can_give() {
        let arm = puma560::puma560();
        let acceleration = InterpolatorSettings::new(0.085, 0.001).acceleration_limit;
        let share = torque_limited_share(&arm, &puma560::QN, &far_goal(), &acceleration, 1.0, TORQUE_MARGIN);
        // the premise: at full speed the move asks beyond what the plant takes (1.5 times a limit)
        let unplanned = worst_torque_share(1.0);
        assert!(unplanned > 1.5, "{unplanned}");
        let planned = worst_torque_share(share);
        println!("share {share:.3}: worst torque {planned:.3} of a limit (unplanned at 1.0: {unplanned:.3})");
        assert!((0.3..1.0).contains(&share), "{share}");
        // within the margin, give or take the tick-by-tick reference's steps
        assert!(planned <= TORQUE_MARGIN * 1.02, "{planned}");
        // and not slowed more than needed
        assert!(planned >= TORQUE_MARGIN * 0.95, "{planned}");
    }

    #[test]
    fn a_move_the_drives_can_give_keeps_its_share() {
        let arm = puma560::puma560();
        let acceleration = InterpolatorSettings::new(0.085, 0.001).acceleration_limit;
        let near = puma560::QN + six_joints([0.2, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(torque_limited_share(&arm, &puma560::QN, &near, &acceleration, 0.2, TORQUE_MARGIN), 0.2);
        assert_eq!(
            torque_limited_share(&arm, &puma560::QN, &puma560::QN, &acceleration, 0.7, TORQUE_MARGIN),
            0.7
        );
    }

    #[test]
    fn the_first_share_that_reaches_a_limit_is_a_root_of_the_quadratic() {
        // 2s² + 1 = 3 at s = 1; −(s²) − 1 = −2 at s = 1
        assert!((first_reaching(2.0, 0.0, 1.0, 3.0) - 1.0).abs() < 1e-12);
        assert!((first_reaching(-1.0, 0.0, -1.0, 2.0) - 1.0).abs() < 1e-12);
        assert!((first_reaching(0.0, 2.0, 0.0, 1.0) - 0.5).abs() < 1e-12);
        assert_eq!(first_reaching(0.0, 0.0, 0.5, 1.0), f64::INFINITY, "never");
        assert_eq!(first_reaching(1.0, 0.0, 5.0, 1.0), f64::INFINITY, "beyond at rest: slowing cannot help");
    }
}
