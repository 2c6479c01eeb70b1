//! Jerk-limited motion of the joint reference: each tick's reference (q, q̇, q̈) is the next sample of a
//! time-optimal, jerk-limited trajectory from the last one, computed online by Ruckig (the `rsruckig` crate, a
//! pure-Rust port of Berscheid & Kröger's Ruckig, RSS 2021). A robot controller that differentiates the
//! commanded velocities (the Franka's does, and aborts a motion with
//! `joint_motion_generator_acceleration_discontinuity` above its limits) then sees every limit kept:
//! - servoing: [`JointMotion::velocity_step`] moves the reference's velocity towards the rate the twist asks
//!   for (Ruckig's velocity interface), within each joint's acceleration and jerk limits;
//! - a joint move: [`JointMotion::position_step`] moves it onto a goal and to rest there (Ruckig's position
//!   interface), within velocity, acceleration and jerk limits scaled by the move's share of them.
//!
//! The velocity limit is kept in the velocity interface by the target: a joint that is still speeding up
//! when it reaches its target goes past it by at most a²/2j (it must first bring its acceleration to zero at
//! the jerk limit), so targets are held [`velocity_headroom`] below the limit.
//!
//! Each joint follows its own time-optimal profile (`Synchronization::None`): with Ruckig's time
//! synchronization, rsruckig 3.0.1's velocity interface stepped a joint's acceleration within a tick when the
//! target moved (measured: a jerk of up to 6.9 times the limit, crates/vservo-sim/tests/jerk_limits.rs found
//! it), and a joint's speed is re-aimed at the twist every tick anyway, so the direction of motion is kept
//! where it matters, at the target.
//!
//! Ruckig runs here with seven degrees of freedom on the stack (a six-joint arm's seventh disabled), so a
//! tick allocates nothing; the crate is built without `std`, so it reads no clock either. Should it refuse a
//! state (it should not: the states are its own outputs), the tick falls back to bringing each joint's
//! acceleration to zero at the jerk limit, and the refusal is counted.

use rsruckig::prelude::{
    ControlInterface, InputParameter, OutputParameter, Ruckig, RuckigResult, Synchronization,
    ThrowErrorHandler,
};
use vservo_arm::{JointVector, MAX_JOINTS};

/// One sample of the reference: joint positions, velocities and accelerations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionState {
    /// q (rad).
    pub q: JointVector,
    /// q̇ (rad/s).
    pub qd: JointVector,
    /// q̈ (rad/s²).
    pub qdd: JointVector,
}

impl MotionState {
    /// At rest at `q`.
    pub fn at_rest(q: JointVector) -> Self {
        Self { q, qd: JointVector::zeros(), qdd: JointVector::zeros() }
    }
}

/// Each joint's limits for the reference's motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionLimits {
    /// Speed (rad/s).
    pub velocity: JointVector,
    /// Acceleration (rad/s²).
    pub acceleration: JointVector,
    /// Jerk (rad/s³).
    pub jerk: JointVector,
}

/// How far below its speed limit joint `j`'s velocity target must stay so that the reference, reaching it
/// while still speeding up at the acceleration limit, stays within the limit: a²/2j.
pub fn velocity_headroom(limits: &MotionLimits, j: usize) -> f64 {
    let a = limits.acceleration[j];
    a * a / (2.0 * limits.jerk[j])
}

/// The online trajectory generator of the reference, for an arm of six or seven joints.
#[derive(Debug, Clone)]
pub struct JointMotion {
    joints: usize,
    otg: Ruckig<MAX_JOINTS, ThrowErrorHandler>,
    input: InputParameter<MAX_JOINTS>,
    output: OutputParameter<MAX_JOINTS>,
    refusals: u64,
}

impl JointMotion {
    /// A generator stepping by `dt` (s) for the first `joints` joints (the rest stay at rest).
    pub fn new(joints: usize, dt: f64) -> Self {
        let mut input = InputParameter::new(None);
        input.synchronization = Synchronization::None;
        for j in joints.min(MAX_JOINTS)..MAX_JOINTS {
            input.enabled[j] = false;
        }
        Self {
            joints: joints.min(MAX_JOINTS),
            otg: Ruckig::new(None, dt),
            input,
            output: OutputParameter::new(None),
            refusals: 0,
        }
    }

    /// Forgets the trajectory in progress: the next step plans anew from the state it is given.
    pub fn reset(&mut self) {
        self.otg.reset();
    }

    /// How many ticks the generator refused and fell back to [`JointMotion::coast`].
    pub fn refusals(&self) -> u64 {
        self.refusals
    }

    /// The next tick of `from` towards the velocity `target_qd` (reached with zero acceleration), each joint
    /// within its acceleration and jerk limits; `target_qd` is taken as it is (the caller keeps it
    /// [`velocity_headroom`] inside the speed limits). Allocation-free.
    pub fn velocity_step(
        &mut self,
        from: &MotionState,
        target_qd: &JointVector,
        limits: &MotionLimits,
    ) -> MotionState {
        self.input.control_interface = ControlInterface::Velocity;
        self.load(from, limits);
        for j in 0..self.joints {
            self.input.target_velocity[j] = target_qd[j];
            self.input.target_acceleration[j] = 0.0;
            self.input.target_position[j] = from.q[j];
        }
        self.run(from, limits)
    }

    /// The next tick of `from` towards rest on `goal`, each joint within `limits` (a joint move's share of
    /// the arm's). Allocation-free.
    pub fn position_step(
        &mut self,
        from: &MotionState,
        goal: &JointVector,
        limits: &MotionLimits,
    ) -> MotionState {
        self.input.control_interface = ControlInterface::Position;
        self.load(from, limits);
        for j in 0..self.joints {
            self.input.target_position[j] = goal[j];
            self.input.target_velocity[j] = 0.0;
            self.input.target_acceleration[j] = 0.0;
        }
        self.run(from, limits)
    }

    fn load(&mut self, from: &MotionState, limits: &MotionLimits) {
        for j in 0..self.joints {
            self.input.current_position[j] = from.q[j];
            self.input.current_velocity[j] = from.qd[j];
            self.input.current_acceleration[j] = from.qdd[j];
            self.input.max_velocity[j] = limits.velocity[j];
            self.input.max_acceleration[j] = limits.acceleration[j];
            self.input.max_jerk[j] = limits.jerk[j];
        }
    }

    /// One update of the generator. Once the target is reached, the state is the target exactly (the
    /// velocity, or the goal at rest), not its integration to within rounding, so that a reference at rest is
    /// exactly at rest.
    fn run(&mut self, from: &MotionState, limits: &MotionLimits) -> MotionState {
        let result = self.otg.update(&self.input, &mut self.output);
        let planned = matches!(result, Ok(RuckigResult::Working | RuckigResult::Finished));
        let finished = matches!(result, Ok(RuckigResult::Finished));
        let mut next = MotionState::at_rest(JointVector::zeros());
        for j in 0..self.joints {
            next.q[j] = self.output.new_position[j];
            next.qd[j] = self.output.new_velocity[j];
            next.qdd[j] = self.output.new_acceleration[j];
            if finished {
                next.qd[j] = self.input.target_velocity[j];
                next.qdd[j] = 0.0;
                if self.input.control_interface == ControlInterface::Position {
                    next.q[j] = self.input.target_position[j];
                }
            }
        }
        let finite = next.q.iter().chain(next.qd.iter()).chain(next.qdd.iter()).all(|v| v.is_finite());
        if planned && finite {
            next
        } else {
            self.refusals += 1;
            self.otg.reset();
            self.coast(from, limits)
        }
    }

    /// The fallback tick: each joint's acceleration brought towards zero at its jerk limit, the velocity and
    /// position integrated (a non-finite state is replaced by rest where it is, or at zero).
    fn coast(&self, from: &MotionState, limits: &MotionLimits) -> MotionState {
        let dt = self.otg.delta_time;
        let mut next = *from;
        for j in 0..self.joints {
            let step = limits.jerk[j] * dt;
            let a = from.qdd[j] - from.qdd[j].clamp(-step, step);
            let v = from.qd[j] + 0.5 * (from.qdd[j] + a) * dt;
            next.qdd[j] = if a.is_finite() { a } else { 0.0 };
            next.qd[j] = if v.is_finite() { v } else { 0.0 };
            next.q[j] = from.q[j] + 0.5 * (from.qd[j] + next.qd[j]) * dt;
            if !next.q[j].is_finite() {
                next.q[j] = if from.q[j].is_finite() { from.q[j] } else { 0.0 };
            }
        }
        next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fr3() -> MotionLimits {
        MotionLimits {
            velocity: JointVector::from([2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26]),
            acceleration: JointVector::repeat(10.0),
            jerk: JointVector::repeat(5000.0),
        }
    }

    /// Per joint, the largest speed, and the largest first and second differences of a sampled velocity: the
    /// acceleration and jerk a controller measures.
    fn max_measured(samples: &[MotionState], dt: f64) -> (JointVector, JointVector, JointVector) {
        let (mut v, mut a, mut j) = (JointVector::zeros(), JointVector::zeros(), JointVector::zeros());
        for w in samples.windows(3) {
            let a1 = (w[1].qd - w[0].qd) / dt;
            let a2 = (w[2].qd - w[1].qd) / dt;
            v = v.zip_map(&w[2].qd, |m, x| m.max(x.abs()));
            a = a.zip_map(&a2, |m, x| m.max(x.abs()));
            j = j.zip_map(&((a2 - a1) / dt), |m, x| m.max(x.abs()));
        }
        (v, a, j)
    }

    /// Whether each joint's value is within its limit, up to rounding.
    fn within(values: &JointVector, limits: &JointVector) -> bool {
        values.iter().zip(limits.iter()).all(|(v, l)| *v <= l * (1.0 + 1e-9))
    }

    #[test]
    fn a_velocity_step_is_reached_within_the_acceleration_and_jerk_limits() {
        let limits = fr3();
        let dt = 0.001;
        let mut motion = JointMotion::new(7, dt);
        let mut state = MotionState::at_rest(JointVector::zeros());
        let target = JointVector::from([1.0, -0.5, 0.2, 0.0, 2.0, -1.0, 0.3]);
        let mut samples = vec![state];
        for _ in 0..1000 {
            state = motion.velocity_step(&state, &target, &limits);
            samples.push(state);
        }
        assert!((state.qd - target).amax() < 1e-9, "{}", state.qd);
        let (_, a, j) = max_measured(&samples, dt);
        assert!(within(&a, &limits.acceleration), "acceleration {a}");
        assert!(within(&j, &limits.jerk), "jerk {j}");
        assert!(j.amax() > 4000.0, "the step used the jerk it may: {j}");
        assert_eq!(motion.refusals(), 0);
    }

    #[test]
    fn a_move_to_a_goal_ends_at_rest_on_it_within_every_limit() {
        let limits = fr3();
        let dt = 0.001;
        let mut motion = JointMotion::new(6, dt);
        let mut state = MotionState::at_rest(JointVector::zeros());
        let goal = JointVector::from([0.5, -0.3, 1.0, 0.0, -0.7, 0.2, 0.0]);
        let mut samples = vec![state];
        for _ in 0..5000 {
            state = motion.position_step(&state, &goal, &limits);
            samples.push(state);
        }
        assert!((state.q - goal).amax() < 1e-9, "{}", state.q);
        assert_eq!(state.qd, JointVector::zeros());
        assert_eq!(state.q[6], 0.0, "the seventh joint of a six-joint arm stays");
        let (v, a, j) = max_measured(&samples, dt);
        assert!(within(&v, &limits.velocity), "speed {v}");
        assert!(within(&a, &limits.acceleration), "acceleration {a}");
        assert!(within(&j, &limits.jerk), "jerk {j}");
    }
}
