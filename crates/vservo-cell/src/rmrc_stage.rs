//! The rmrc stage: the 1 ms interpolator and the joint servo behind it, and how it follows the robot driver.
//!
//! The stage answers the driver's joint states ([`RmrcStage::follow`]). After a gap of more than
//! `robot.state_timeout_periods` between the stamps of two joint states it follows (a stalled driver), a tick
//! that does not advance or jumps by more than that many periods, or a new `driver_epoch` (a restarted
//! driver), the reference starts again at rest from the measured joints, so nothing accumulated while the
//! driver was away moves the arm when it comes back. Ticks it did not answer (states it took too late to
//! see) are stepped through before the next command (the reference is a function of time), so it never lags
//! the arm's clock. Both shells run this: the real-time node on every state it takes, the lockstep on every
//! tick (or, replaying a real-time run, on the states that run answered).

use vservo_arm::{JointVector, SerialArm};
use vservo_collision::{Assessment, BrakingLimits, Guard, Nearness};
use vservo_config::{CellConfig, CommandInterface};
use vservo_control::Twist;
use vservo_sim::interpolator::{Interpolator, InterpolatorSettings, Reference};
use vservo_sim::joint_servo::JointServo;

/// What the rmrc sends the robot driver for one period, in the interface the driver takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ActuatorCommand {
    /// Joint torques (N·m), for the dynamic plant and a real arm's torque-controlled drives.
    Torque(JointVector),
    /// The joint reference itself: the velocity q̇_d over the next period and the position q_d at its end.
    /// A velocity-commanded driver applies `qd`, a position-commanded one `q` (the kinematic plant both).
    Reference {
        /// q_d (rad).
        q: JointVector,
        /// q̇_d (rad/s).
        qd: JointVector,
    },
}

/// Which joint state of which driver: what the rmrc needs to tell a driver that carried on from one that
/// stalled or restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriverTick {
    /// The driver's epoch (a new one: a restarted driver).
    pub epoch: u64,
    /// The state's tick.
    pub tick: u64,
    /// The state's stamp on the driver's clock (ns).
    pub stamp_ns: u64,
    /// The driver says it holds the arm (`driver_status` holding: no valid command came in time, or it
    /// refused the last): the arm is not following the reference.
    pub holding: bool,
}

/// What the rmrc made of a joint state it follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Following {
    /// The first state, a new driver, the driver back after a gap, or a driver that holds the arm: the
    /// reference started again at rest from the measured joints, dropping the twist it held (it never runs
    /// ahead of an arm that is not following it).
    Resynced,
    /// The same driver, carried on; `missed_ticks` ticks since the last command were stepped through unanswered.
    Continued {
        /// Ticks the reference advanced through without a command (the node woke too late for them).
        missed_ticks: u64,
    },
}

/// The interpolator and the joint servo, and the driver state they follow.
#[derive(Debug, Clone)]
pub struct RmrcStage {
    interpolator: Interpolator,
    joint_servo: JointServo,
    command: CommandInterface,
    settings: InterpolatorSettings,
    arm: SerialArm,
    gap: Gap,
    /// The last state followed.
    followed: Option<DriverTick>,
    /// The tick the reference runs from (its start at rest).
    since_tick: u64,
    /// The next tick whose command the reference has not yet been stepped to.
    next_tick: u64,
    /// The joint move in force as planned: its goal, the share asked for and the share it runs at.
    planned_move: Option<PlannedMove>,
    /// The collision guard (`[collision]`), what it made of the last tick, and the distance it stopped the arm
    /// for, held until [`RmrcStage::release_guard`].
    guard: Option<Guard>,
    assessed: Option<Assessment>,
    guard_stop: Option<Nearness>,
}

/// A joint move as planned, once, when it is asked for: at the share asked for or, for a torque-driven arm,
/// less where the drives' torque requires it (`vservo_sim::joint_move_torque`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct PlannedMove {
    goal: JointVector,
    requested: f64,
    share: f64,
}

/// How far apart two joint states may be and still be the same driver carrying on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Gap {
    periods: u64,
    ns: u64,
}

impl Gap {
    /// Whether `now` is not a continuation of `before`: a new epoch, a tick that does not advance, or one
    /// beyond the gap (on the stamps, or on the ticks, which keeps the catch-up bounded).
    fn breaks(&self, before: &DriverTick, now: &DriverTick) -> bool {
        before.epoch != now.epoch
            || now.tick <= before.tick
            || now.stamp_ns.saturating_sub(before.stamp_ns) > self.ns
            || now.tick - before.tick > self.periods
    }
}

impl RmrcStage {
    pub(crate) fn new(
        config: &CellConfig,
        settings: InterpolatorSettings,
        arm: SerialArm,
        q: JointVector,
        guard: Option<Guard>,
    ) -> Self {
        let period_ns = vservo_time::nanos(settings.control_period_s);
        let periods = u64::from(config.robot.state_timeout_periods);
        Self {
            interpolator: Interpolator::new(settings, arm.clone(), config.mount(), q),
            joint_servo: JointServo::new(
                arm.clone(),
                config.joint_servo.law,
                config.joint_servo.kp,
                config.joint_servo.kv,
            ),
            command: config.command_interface(),
            settings,
            arm,
            gap: Gap { periods, ns: period_ns * periods },
            followed: None,
            since_tick: 0,
            next_tick: 0,
            planned_move: None,
            guard,
            assessed: None,
            guard_stop: None,
        }
    }

    /// Takes the joint state `at` (joints `q`, `qd`) as the one to answer next: starts again at rest from
    /// `q` if it does not carry on from the last state followed, else steps the reference through the ticks
    /// left unanswered since the last command. Allocates nothing.
    pub fn follow(&mut self, at: DriverTick, q: &JointVector, qd: &JointVector) -> Following {
        let carries_on = !at.holding && self.followed.is_some_and(|before| !self.gap.breaks(&before, &at));
        self.followed = Some(at);
        if !carries_on {
            self.restart_at_rest(q, at.tick);
            return Following::Resynced;
        }
        let missed_ticks = at.tick.saturating_sub(self.next_tick);
        for tick in self.next_tick..at.tick {
            self.step(tick, q, qd);
        }
        Following::Continued { missed_ticks }
    }

    /// The reference at rest at `q` from `tick` on, no twist held.
    fn restart_at_rest(&mut self, q: &JointVector, tick: u64) {
        self.interpolator.restart_at_rest(*q);
        self.since_tick = tick;
        self.next_tick = tick;
        self.planned_move = None;
    }

    /// The dynamics override: from the next tick on, every path of the reference keeps `speed_scale` (0–1]
    /// of the joints' speed, acceleration and jerk limits and of the tool's caps, a restart at rest included
    /// (another value is ignored). Allocates nothing.
    pub fn set_speed_scale(&mut self, speed_scale: f64) {
        if speed_scale > 0.0 && speed_scale <= 1.0 && speed_scale != self.settings.speed_scale {
            self.settings.speed_scale = speed_scale;
            self.interpolator.set_speed_scale(speed_scale);
        }
    }

    /// The dynamics override in force.
    pub fn speed_scale(&self) -> f64 {
        self.settings.speed_scale
    }

    /// The tick the reference runs from: the state it last started at rest from.
    pub fn since_tick(&self) -> u64 {
        self.since_tick
    }

    /// A new twist from the servo, taken in at `tick`, if `moves` (the servo's verdict lets the arm move)
    /// and it is finite and within `limits`; otherwise a zero twist, and `false` when the twist was refused
    /// (out of range: the arm is brought to rest rather than left on the last good twist).
    pub fn take_twist(&mut self, twist: &Twist, moves: bool, limits: &TwistLimits, tick: u64) -> bool {
        // any verdict but servoing (on four or three marks) or reacquiring means stop, whatever the numbers say
        let twist = if moves { *twist } else { Twist::zeros() };
        let within = limits.admit(&twist);
        self.set_twist(if within { twist } else { Twist::zeros() }, tick);
        within
    }

    /// A twist set as it is, at `tick` (a zero twist: the interpolator ramps to rest and holds), or a zero one
    /// while the guard holds the arm.
    pub fn set_twist(&mut self, twist: Twist, tick: u64) {
        let twist = if self.guard_stop.is_some() { Twist::zeros() } else { twist };
        self.interpolator.set_twist(twist, tick as f64 * self.settings.control_period_s);
    }

    /// Moves the joints to `goal` at up to `speed_fraction` of their speed limits instead of following twists,
    /// until [`RmrcStage::end_joint_move`] (the interpolator's joint move; a restart at rest drops it, so the
    /// caller asks again while the move is in force). For a torque-driven arm the move is planned, once, within
    /// the drives' torque: slower than asked where the torque requires it. A goal the daemon would refuse (not inside the arm's
    /// joint limits by `vservo_arm::GOAL_MARGIN_RAD`, or not finite) or a share outside
    /// `vservo_sim::joint_move::speed_fraction_ok` is refused (`false`): the move ends and a zero twist brings
    /// the arm to rest.
    pub fn move_joints_to(&mut self, goal: JointVector, speed_fraction: f64, tick: u64) -> bool {
        let within = self.arm.limits().zip(goal.iter()).all(|(limits, q)| limits.holds_goal(*q))
            && vservo_sim::joint_move::speed_fraction_ok(speed_fraction)
            && self.guard_stop.is_none();
        if within {
            let share = self.planned_share(goal, speed_fraction);
            self.interpolator.move_joints_to(goal, share);
        } else {
            self.end_joint_move();
            self.set_twist(Twist::zeros(), tick);
        }
        within
    }

    /// The share the move to `goal` asked at `requested` runs at: planned when it is asked for (from where the
    /// reference is), the same while it is asked again.
    fn planned_share(&mut self, goal: JointVector, requested: f64) -> f64 {
        match self.planned_move {
            Some(planned) if planned.goal == goal && planned.requested == requested => planned.share,
            _ => {
                let share = match self.command {
                    CommandInterface::Torque => vservo_sim::joint_move_torque::torque_limited_share(
                        &self.arm,
                        &self.interpolator.reference().q,
                        &goal,
                        &self.settings.acceleration_limit,
                        requested,
                        vservo_sim::joint_move_torque::TORQUE_MARGIN,
                    ),
                    _ => requested,
                };
                self.planned_move = Some(PlannedMove { goal, requested, share });
                share
            }
        }
    }

    /// Ends a joint move (none in progress: nothing happens): the reference follows twists again, a zero one
    /// ramping it to rest at the acceleration limits.
    pub fn end_joint_move(&mut self) {
        self.interpolator.end_joint_move();
        self.planned_move = None;
    }

    /// The command interface of the driver.
    pub fn command_interface(&self) -> CommandInterface {
        self.command
    }

    /// The reference of the last tick.
    pub fn reference(&self) -> &Reference {
        self.interpolator.reference()
    }

    /// The command for the period from `tick` to the next, given the measured joints at its start.
    pub fn step(&mut self, tick: u64, q: &JointVector, qd: &JointVector) -> ActuatorCommand {
        let dt = self.settings.control_period_s;
        let reference = self.guarded_step(tick as f64 * dt + dt);
        self.next_tick = tick + 1;
        match self.command {
            CommandInterface::Velocity | CommandInterface::Position => {
                ActuatorCommand::Reference { q: reference.q, qd: reference.qd }
            }
            CommandInterface::Torque => ActuatorCommand::Torque(self.joint_servo.torque(q, qd, &reference)),
        }
    }
}

impl RmrcStage {
    /// One tick of the interpolator, through the guard where there is one: the asked joint speeds slowed by its
    /// share (nothing while it holds the arm), and the arm braked at once when it finds a distance the reference
    /// cannot brake for before the stop distance. Allocates nothing.
    fn guarded_step(&mut self, now_s: f64) -> vservo_sim::interpolator::Reference {
        let Self { interpolator, guard, arm, settings, guard_stop, assessed, .. } = self;
        let Some(guard) = guard.as_mut() else { return *interpolator.step(now_s) };
        let (acceleration, jerk) = interpolator.braking_limits();
        let tool_speed_m_s = interpolator.tool_speed_limit_m_s();
        let holding = guard_stop.is_some();
        let mut judged = None;
        let reference = *interpolator.step_guarded(now_s, &mut |reference, asked| {
            let limits = BrakingLimits {
                acceleration: acceleration.as_slice(),
                jerk: jerk.as_ref().map(|j| j.as_slice()),
                period_s: settings.control_period_s,
                tool_speed_m_s,
            };
            let placement = arm.placement(&reference.q);
            let assessment = guard.assess(&placement, (&reference.qd, &reference.qdd), asked, &limits);
            judged = Some(assessment);
            if holding { 0.0 } else { assessment.speed_share }
        });
        *assessed = judged;
        if let Some(stop) = judged.and_then(|a| a.stop)
            && guard_stop.is_none()
        {
            *guard_stop = Some(stop);
            interpolator.brake();
            self.planned_move = None;
        }
        reference
    }

    /// The arm it drives.
    pub fn arm(&self) -> &SerialArm {
        &self.arm
    }

    /// The collision guard, if `[collision]` gives one.
    pub fn guard(&self) -> Option<&Guard> {
        self.guard.as_ref()
    }

    /// What the guard made of the last tick.
    pub fn assessed(&self) -> Option<&Assessment> {
        self.assessed.as_ref()
    }

    /// The distance the guard stopped the arm for, while it holds it: twists are zeroed and joint moves refused.
    pub fn guard_stop(&self) -> Option<&Nearness> {
        self.guard_stop.as_ref()
    }

    /// Lets the guard's stop go (a resume): twists are followed again, slowed or held where they close a
    /// distance within the slowdown distance, so that a motion away is taken and one towards is not.
    pub fn release_guard(&mut self) {
        self.guard_stop = None;
    }
}

/// The camera speeds a twist may ask for: linear (m/s) and angular (rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwistLimits {
    /// Linear speed (m/s).
    pub linear_m_s: f64,
    /// Angular speed (rad/s).
    pub angular_rad_s: f64,
}

impl TwistLimits {
    /// The robot's camera limits of the configuration (`robot.max_camera_speed_m_s`,
    /// `robot.max_camera_rotation_rad_s`).
    pub fn of(config: &CellConfig) -> Self {
        Self {
            linear_m_s: config.robot.max_camera_speed_m_s,
            angular_rad_s: config.robot.max_camera_rotation_rad_s,
        }
    }

    /// Whether a twist is finite and inside the limits.
    pub fn admit(&self, twist: &Twist) -> bool {
        twist.iter().all(|v| v.is_finite())
            && twist.fixed_rows::<3>(0).norm() <= self.linear_m_s
            && twist.fixed_rows::<3>(3).norm() <= self.angular_rad_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Cell;

    fn stage() -> (RmrcStage, JointVector, u64) {
        let config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default config loads")
                .cell;
        let cell = Cell::new(&config).expect("the default cell");
        let q = *cell.start_joints();
        let period_ns = vservo_time::nanos(config.robot.period_s);
        (cell.rmrc(&q), q, period_ns)
    }

    fn at(epoch: u64, tick: u64, period_ns: u64) -> DriverTick {
        DriverTick { epoch, tick, stamp_ns: tick * period_ns, holding: false }
    }

    #[test]
    fn the_first_state_a_new_epoch_a_stall_and_a_tick_going_back_start_again_at_rest() {
        let (mut rmrc, q, period_ns) = stage();
        let qd = JointVector::zeros();
        assert_eq!(rmrc.follow(at(7, 100, period_ns), &q, &qd), Following::Resynced);
        assert_eq!(rmrc.since_tick(), 100);
        rmrc.step(100, &q, &qd);
        assert_eq!(rmrc.follow(at(7, 101, period_ns), &q, &qd), Following::Continued { missed_ticks: 0 });
        rmrc.step(101, &q, &qd);
        // a restarted driver
        assert_eq!(rmrc.follow(at(8, 102, period_ns), &q, &qd), Following::Resynced);
        assert_eq!(rmrc.since_tick(), 102);
        rmrc.step(102, &q, &qd);
        // the tick does not advance
        assert_eq!(rmrc.follow(at(8, 102, period_ns), &q, &qd), Following::Resynced);
        rmrc.step(102, &q, &qd);
        // the next tick, but stamped after the stall deadline (50 periods)
        let stalled =
            DriverTick { epoch: 8, tick: 103, stamp_ns: 102 * period_ns + 51 * period_ns, holding: false };
        assert_eq!(rmrc.follow(stalled, &q, &qd), Following::Resynced);
        assert_eq!(rmrc.since_tick(), 103);
        rmrc.step(103, &q, &qd);
        // a jump of more ticks than the deadline allows
        assert_eq!(rmrc.follow(at(8, 103 + 51, period_ns), &q, &qd), Following::Resynced);
        rmrc.step(103 + 51, &q, &qd);
        // the driver holds the arm: the reference starts again from where it is, and carries on after
        let holding = DriverTick { holding: true, ..at(8, 103 + 52, period_ns) };
        assert_eq!(rmrc.follow(holding, &q, &qd), Following::Resynced);
        assert_eq!(rmrc.since_tick(), 103 + 52);
        rmrc.step(103 + 52, &q, &qd);
        assert_eq!(
            rmrc.follow(at(8, 103 + 53, period_ns), &q, &qd),
            Following::Continued { missed_ticks: 0 }
        );
    }

    #[test]
    fn ticks_not_answered_are_stepped_through_as_if_each_had_been() {
        let (mut caught_up, q, period_ns) = stage();
        let mut each = caught_up.clone();
        let qd = JointVector::zeros();
        let twist = Twist::new(0.01, 0.0, 0.0, 0.0, 0.0, 0.02);
        for rmrc in [&mut caught_up, &mut each] {
            assert_eq!(rmrc.follow(at(1, 0, period_ns), &q, &qd), Following::Resynced);
            rmrc.set_twist(twist, 0);
            rmrc.step(0, &q, &qd);
        }
        for tick in 1..10 {
            assert_eq!(
                each.follow(at(1, tick, period_ns), &q, &qd),
                Following::Continued { missed_ticks: 0 }
            );
            each.step(tick, &q, &qd);
        }
        // woke at tick 10 only: ticks 1–9 (within the deadline) are stepped through
        assert_eq!(caught_up.follow(at(1, 10, period_ns), &q, &qd), Following::Continued { missed_ticks: 9 });
        assert_eq!(caught_up.since_tick(), 0);
        assert_eq!(caught_up.step(10, &q, &qd), each.step(10, &q, &qd));
        assert!(caught_up.reference().qd.amax() > 0.0, "the twist moved the reference");
    }

    #[test]
    fn a_twist_is_refused_beyond_the_limits_and_zeroed_on_a_verdict_that_does_not_move() {
        let (mut rmrc, q, period_ns) = stage();
        let qd = JointVector::zeros();
        rmrc.follow(at(1, 0, period_ns), &q, &qd);
        let limits = TwistLimits { linear_m_s: 0.1, angular_rad_s: 0.5 };
        let fast = Twist::new(0.2, 0.0, 0.0, 0.0, 0.0, 0.0);
        assert!(!rmrc.take_twist(&fast, true, &limits, 0));
        assert!(!rmrc.take_twist(&Twist::from_element(f64::NAN), true, &limits, 0));
        // a verdict that does not move: zero, which is within the limits
        assert!(rmrc.take_twist(&Twist::from_element(f64::NAN), false, &limits, 0));
        rmrc.step(0, &q, &qd);
        assert_eq!(rmrc.reference().qd, JointVector::zeros());
        assert!(rmrc.take_twist(&Twist::new(0.05, 0.0, 0.0, 0.0, 0.0, 0.1), true, &limits, 1));
    }
}
