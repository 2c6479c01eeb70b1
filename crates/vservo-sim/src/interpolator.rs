//! The 1 ms resolved-motion-rate interpolator: from the camera twist the servo sends every vision frame to
//! a joint reference every tick.

use nalgebra::{Matrix6, Vector6};
use vservo_arm::{DH_JOINTS, Jacobian, JointLimits, JointVector, MAX_JOINTS, SerialArm};
use vservo_control::Twist;
use vservo_scene::CameraMount;

use crate::motion_limits::{JointMotion, MotionLimits, MotionState, velocity_headroom};
use crate::redundancy::{self, Damping, NullSpaceTask};
pub use vservo_settings::simulation::{InterpolatorSettings, TwistHold};

pub use vservo_arm::LIMIT_MARGIN;

/// The joint reference for one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    /// q_d (rad).
    pub q: JointVector,
    /// q̇_d (rad/s).
    pub qd: JointVector,
    /// q̈_d (rad/s²), the change of q̇_d over the tick.
    pub qdd: JointVector,
    /// Whether the twist is stale and the arm is being stopped.
    pub stopping: bool,
    /// Whether damping was used (near a singularity).
    pub damped: bool,
    /// Whether a joint speed was cut to its limit.
    pub velocity_limited: bool,
}

impl Reference {
    fn state(&self) -> MotionState {
        MotionState { q: self.q, qd: self.qd, qdd: self.qdd }
    }
}

/// The interpolator's state.
#[derive(Debug, Clone)]
pub struct Interpolator {
    /// The settings in force: the configured ones with the speed scale applied to the acceleration and jerk
    /// limits and the tool's caps.
    settings: InterpolatorSettings,
    /// The settings as configured (unscaled), which a new speed scale applies to.
    configured: InterpolatorSettings,
    arm: SerialArm,
    /// The joint limits in force, the speeds scaled; the slots past the arm's joints unused (kept here so that a
    /// tick borrows a slice).
    limits: [JointLimits; MAX_JOINTS],
    mount: CameraMount,
    latest: Twist,
    previous: Twist,
    latest_at_s: Option<f64>,
    reference: Reference,
    stop_scale: f64,
    /// A joint move in progress (the goal and the share of the speed limits), in place of the twists.
    joint_goal: Option<(JointVector, f64)>,
    /// The jerk-limited generator of the reference, where the arm has jerk limits.
    motion: Option<JointMotion>,
}

impl Interpolator {
    /// An interpolator whose reference starts at rest at `q`.
    pub fn new(settings: InterpolatorSettings, arm: SerialArm, mount: CameraMount, q: JointVector) -> Self {
        let motion =
            settings.jerk_limit.map(|_| JointMotion::new(arm.joint_count(), settings.control_period_s));
        let (scaled, limits) = scaled(&settings, &arm, settings.speed_scale);
        Self {
            settings: scaled,
            configured: settings,
            limits,
            arm,
            mount,
            latest: Twist::zeros(),
            previous: Twist::zeros(),
            latest_at_s: None,
            reference: Reference {
                q,
                qd: JointVector::zeros(),
                qdd: JointVector::zeros(),
                stopping: false,
                damped: false,
                velocity_limited: false,
            },
            stop_scale: 1.0,
            joint_goal: None,
            motion,
        }
    }

    /// Starts again at rest at `q`, no twist held and no joint move, the generator's state forgotten: what
    /// [`Interpolator::new`] gives, with the speed scale in force kept. Allocates nothing (a new interpolator's
    /// jerk-limited generator would).
    pub fn restart_at_rest(&mut self, q: JointVector) {
        self.latest = Twist::zeros();
        self.previous = Twist::zeros();
        self.latest_at_s = None;
        self.reference = Reference {
            q,
            qd: JointVector::zeros(),
            qdd: JointVector::zeros(),
            stopping: false,
            damped: false,
            velocity_limited: false,
        };
        self.stop_scale = 1.0;
        self.joint_goal = None;
        if let Some(motion) = self.motion.as_mut() {
            motion.reset();
        }
    }

    /// The dynamics override in force: every path of the reference keeps this share of the joints' speed,
    /// acceleration and jerk limits and of the tool's caps from the next tick on (a reference faster than the
    /// new limits is brought within them by the generator, within the new limits). `speed_scale` is taken as it
    /// is when in (0, 1]; any other value is ignored (the caller checks it, `vservo_config`'s range).
    pub fn set_speed_scale(&mut self, speed_scale: f64) {
        if !(speed_scale > 0.0 && speed_scale <= 1.0) {
            return;
        }
        (self.settings, self.limits) = scaled(&self.configured, &self.arm, speed_scale);
    }

    /// The dynamics override in force.
    pub fn speed_scale(&self) -> f64 {
        self.settings.speed_scale
    }

    /// How many ticks the jerk-limited generator refused (it fell back to easing the acceleration off).
    pub fn motion_refusals(&self) -> u64 {
        self.motion.as_ref().map_or(0, JointMotion::refusals)
    }

    /// The arm's motion limits for the generator: speed, acceleration and jerk, each scaled by `share` to its
    /// power (a move at a share of the speed is the same move slowed down in time), and kept
    /// [`LIMIT_MARGIN`] inside the arm's.
    fn motion_limits(&self, jerk: &JointVector, share: f64) -> MotionLimits {
        let velocity = JointVector::from_fn(|j, _| self.limits[j].velocity_max);
        let kept = share * LIMIT_MARGIN;
        MotionLimits {
            velocity: velocity * kept,
            acceleration: self.settings.acceleration_limit * (kept * kept),
            jerk: jerk * (kept * kept * kept),
        }
    }

    /// Moves the joints to `goal` at up to `speed_fraction` of their speed limits, speeding up at
    /// `speed_fraction`² of their acceleration limits, instead of following twists (`crate::joint_move`), until
    /// [`Interpolator::end_joint_move`]; twists set meanwhile are kept but not followed.
    pub fn move_joints_to(&mut self, goal: JointVector, speed_fraction: f64) {
        self.joint_goal = Some((goal, speed_fraction));
    }

    /// Ends a joint move: the reference goes on from where it is, following twists again (a zero twist ramps
    /// it to rest at the acceleration limits, as after a safe stop).
    pub fn end_joint_move(&mut self) {
        self.joint_goal = None;
    }

    /// Whether a joint move is in progress and the reference is on its goal, at rest.
    pub fn joint_move_arrived(&self) -> bool {
        self.joint_goal.is_some_and(|(goal, _)| {
            crate::joint_move::arrived(&goal, &self.reference.q, self.arm.joint_count())
                && self.reference.qd.iter().all(|v| *v == 0.0)
        })
    }

    /// A new camera twist from the servo, received at `now_s`.
    pub fn set_twist(&mut self, twist: Twist, now_s: f64) {
        // where the hold had got to becomes the start of the next interpolation
        self.previous = self.held_twist(now_s);
        self.latest = twist;
        self.latest_at_s = Some(now_s);
        self.stop_scale = 1.0;
    }

    /// The reference of the last tick.
    pub fn reference(&self) -> &Reference {
        &self.reference
    }

    fn held_twist(&self, now_s: f64) -> Twist {
        match (self.settings.hold, self.latest_at_s) {
            (_, None) => Twist::zeros(),
            (TwistHold::ZeroOrder, Some(_)) => self.latest,
            (TwistHold::Linear, Some(at)) => {
                let s = ((now_s - at) / self.settings.vision_period_s).clamp(0.0, 1.0);
                self.previous + (self.latest - self.previous) * s
            }
        }
    }

    /// Stops following the twist at once: the reference brakes to rest from the next tick within the limits in
    /// force, without the linear hold's blend to zero over a frame that a new zero twist gets (what a guard that
    /// finds the arm too near something needs). A joint move ends. Allocates nothing.
    pub fn brake(&mut self) {
        self.latest = Twist::zeros();
        self.previous = Twist::zeros();
        self.joint_goal = None;
    }

    /// The limits the reference brakes within now: each joint's acceleration and, where the arm has them, jerk
    /// (rad/s², rad/s³), as the generator keeps them.
    pub fn braking_limits(&self) -> (JointVector, Option<JointVector>) {
        match self.settings.jerk_limit {
            Some(jerk) => {
                let limits = self.motion_limits(&jerk, 1.0);
                (limits.acceleration, Some(limits.jerk))
            }
            None => (self.settings.acceleration_limit, None),
        }
    }

    /// The tool's speed limit in force (m/s), the speed scale applied.
    pub fn tool_speed_limit_m_s(&self) -> f64 {
        self.settings.tool_speed_limit_m_s
    }

    /// Advances the reference by one tick ending at `now_s`.
    pub fn step(&mut self, now_s: f64) -> &Reference {
        self.step_guarded(now_s, &mut |_, _| 1.0)
    }

    /// Advances the reference by one tick ending at `now_s`, the joint speeds the twist asks for scaled by what
    /// `guard` answers (from 0 to 1; given the reference before the tick and those speeds). During a joint move
    /// `guard` is asked with the move's speeds as they are and its answer is not applied: the move is stopped
    /// or not by its caller.
    pub fn step_guarded(
        &mut self,
        now_s: f64,
        guard: &mut dyn FnMut(&Reference, &JointVector) -> f64,
    ) -> &Reference {
        if let Some((goal, speed_fraction)) = self.joint_goal {
            guard(&self.reference, &self.reference.qd);
            return self.step_joint_move(&goal, speed_fraction);
        }
        let s = &self.settings;
        let dt = s.control_period_s;
        let stale = self.latest_at_s.is_none_or(|at| now_s - at > s.stale_after_s);
        if stale {
            self.stop_scale = (self.stop_scale - dt / s.stop_ramp_s).max(0.0);
        }
        let twist = self.held_twist(now_s) * self.stop_scale;
        let q = self.reference.q;
        // the camera twist (camera frame) as the tool's twist in the base frame, for the camera's mount
        let (base_from_tool, jacobian) = self.arm.base_from_tool_and_jacobian(&q);
        let tool_twist = self.mount.tool_twist(&base_from_tool, &twist);
        let tool_twist = within_tool_speeds(tool_twist, s.tool_speed_limit_m_s, s.tool_rotation_limit_rad_s);

        let joints = self.arm.joint_count();
        let (mut qd, damped) = if joints == DH_JOINTS {
            six_joint_rates(&jacobian, &tool_twist, s)
        } else {
            let damping =
                Damping { manipulability_threshold: s.manipulability_threshold, max_damping: s.max_damping };
            // the spare joint's own motion stops with the twist's: a stale twist brings the whole arm to rest
            let null_space = NullSpaceTask {
                limit_gain: s.null_space.limit_gain * self.stop_scale,
                posture_gain: s.null_space.posture_gain * self.stop_scale,
                ..s.null_space
            };
            let rates = redundancy::resolve(
                &jacobian,
                &q,
                &self.limits[..joints],
                &tool_twist,
                &damping,
                &null_space,
            );
            (rates.qd, rates.damped)
        };
        // joint speed limits: scale the whole vector, keeping the direction of motion (with jerk limits, as
        // far inside them as the reference may go past its target)
        let motion_limits = s.jerk_limit.map(|jerk| self.motion_limits(&jerk, 1.0));
        let mut worst: f64 = 1.0;
        for (j, limits) in self.limits[..joints].iter().enumerate() {
            let headroom = motion_limits.as_ref().map_or(0.0, |m| velocity_headroom(m, j));
            worst = worst.max(qd[j].abs() / (limits.velocity_max - headroom).max(f64::MIN_POSITIVE));
        }
        let velocity_limited = worst > 1.0;
        if velocity_limited || !worst.is_finite() {
            qd /= if worst.is_finite() { worst } else { f64::INFINITY };
        }
        if !qd.iter().all(|v| v.is_finite()) {
            qd = JointVector::zeros();
        }
        let share = guard(&self.reference, &qd);
        if share.is_nan() || share < 1.0 {
            qd *= if share > 0.0 { share } else { 0.0 };
        }
        if let (Some(motion), Some(limits)) = (self.motion.as_mut(), motion_limits) {
            let next = motion.velocity_step(&self.reference.state(), &qd, &limits);
            self.reference = Reference {
                q: next.q,
                qd: next.qd,
                qdd: next.qdd,
                stopping: stale,
                damped,
                velocity_limited,
            };
            return &self.reference;
        }
        // acceleration limits, the change scaled as a whole
        let change = qd - self.reference.qd;
        let mut over: f64 = 1.0;
        for j in 0..joints {
            over = over.max(change[j].abs() / (s.acceleration_limit[j] * dt));
        }
        if over > 1.0 {
            qd = self.reference.qd + change / over;
        }
        let qdd = (qd - self.reference.qd) / dt;
        let q_next = q + qd * dt;
        self.reference = Reference { q: q_next, qd, qdd, stopping: stale, damped, velocity_limited };
        &self.reference
    }
}

impl Interpolator {
    /// One tick of a joint move: each joint's rate towards the goal, its change limited joint by joint. The
    /// share of the speed limits scales the move in time (as a controller's speed override does): speeding up
    /// and the planned braking onto the goal at the square of the share of the acceleration limits, so that a
    /// slow move also asks the drives for less torque. A joint faster than the move goes or moving away from its
    /// goal (the move began while the arm moved, or replaced a faster one) brakes at its full limit, as a safe
    /// stop does.
    fn step_joint_move(&mut self, goal: &JointVector, speed_fraction: f64) -> &Reference {
        if let Some(jerk) = self.settings.jerk_limit {
            return self.step_jerk_limited_joint_move(goal, speed_fraction, &jerk);
        }
        let s = &self.settings;
        let dt = s.control_period_s;
        let joints = self.arm.joint_count();
        let q = self.reference.q;
        let share = if speed_fraction.is_finite() { speed_fraction.clamp(0.0, 1.0) } else { 0.0 };
        let acceleration = s.acceleration_limit * (share * share);
        let wanted =
            crate::joint_move::rates_toward(goal, &q, &self.limits[..joints], &acceleration, share, dt);
        let mut qd = self.reference.qd;
        for (j, limit) in self.limits[..joints].iter().enumerate() {
            // faster than this move goes, or away from its goal: a motion the move did not start
            let error = goal[j] - q[j];
            let slowing = qd[j].abs() > share * limit.velocity_max || qd[j] * error < 0.0;
            let step = if slowing { s.acceleration_limit[j] } else { acceleration[j] } * dt;
            qd[j] += (wanted[j] - qd[j]).clamp(-step, step);
        }
        if !qd.iter().all(|v| v.is_finite()) {
            qd = JointVector::zeros();
        }
        let qdd = (qd - self.reference.qd) / dt;
        self.reference =
            Reference { q: q + qd * dt, qd, qdd, stopping: false, damped: false, velocity_limited: false };
        &self.reference
    }
}

impl Interpolator {
    /// One tick of a joint move within the arm's jerk limits: the time-optimal move onto the goal within the
    /// share's limits (speed × share, acceleration × share², jerk × share³). A reference outside those (the
    /// move began while the arm moved faster) is first brought to rest within the full limits, as a safe stop
    /// does, since braking within a small share's would carry it far.
    fn step_jerk_limited_joint_move(
        &mut self,
        goal: &JointVector,
        speed_fraction: f64,
        jerk: &JointVector,
    ) -> &Reference {
        let share = if speed_fraction.is_finite() { speed_fraction.clamp(0.0, 1.0) } else { 0.0 };
        let full = self.motion_limits(jerk, 1.0);
        let scaled = self.motion_limits(jerk, share);
        let from = self.reference.state();
        let joints = self.arm.joint_count();
        // (rounding aside: the generator's own output meets its limits up to it, and must not be taken for a
        // motion the move did not start)
        let inside = |value: f64, limit: f64| value.abs() <= limit * (1.0 + 1e-6);
        let within = (0..joints)
            .all(|j| inside(from.qd[j], scaled.velocity[j]) && inside(from.qdd[j], scaled.acceleration[j]));
        let Some(motion) = self.motion.as_mut() else {
            return &self.reference;
        };
        let next = if within {
            motion.position_step(&from, goal, &scaled)
        } else {
            motion.velocity_step(&from, &JointVector::zeros(), &full)
        };
        self.reference = Reference {
            q: next.q,
            qd: next.qd,
            qdd: next.qdd,
            stopping: false,
            damped: false,
            velocity_limited: false,
        };
        &self.reference
    }
}

/// The settings and joint limits in force at `speed_scale`: the joints' speeds, accelerations and jerks and
/// the tool's caps, each that share of the configured ones (unchanged at 1).
fn scaled(
    configured: &InterpolatorSettings,
    arm: &SerialArm,
    speed_scale: f64,
) -> (InterpolatorSettings, [JointLimits; MAX_JOINTS]) {
    let settings = InterpolatorSettings {
        acceleration_limit: configured.acceleration_limit * speed_scale,
        jerk_limit: configured.jerk_limit.map(|jerk| jerk * speed_scale),
        tool_speed_limit_m_s: configured.tool_speed_limit_m_s * speed_scale,
        tool_rotation_limit_rad_s: configured.tool_rotation_limit_rad_s * speed_scale,
        speed_scale,
        ..*configured
    };
    let limits = arm
        .links
        .map(|link| JointLimits { velocity_max: link.limits.velocity_max * speed_scale, ..link.limits });
    (settings, limits)
}

/// The tool twist scaled down, whole, so that its linear part is at most `speed_m_s` and its angular part at
/// most `rotation_rad_s` (the direction kept).
fn within_tool_speeds(twist: Vector6<f64>, speed_m_s: f64, rotation_rad_s: f64) -> Vector6<f64> {
    let over =
        (twist.fixed_rows::<3>(0).norm() / speed_m_s).max(twist.fixed_rows::<3>(3).norm() / rotation_rad_s);
    if over > 1.0 && over.is_finite() { twist / over } else { twist }
}

/// A six-joint arm's rates: the Jacobian inverted where it is well conditioned, by damped least squares near
/// a singularity; and whether damping was used.
fn six_joint_rates(
    jacobian: &Jacobian,
    tool_twist: &Vector6<f64>,
    s: &InterpolatorSettings,
) -> (JointVector, bool) {
    let jacobian: Matrix6<f64> = jacobian.fixed_columns::<DH_JOINTS>(0).into_owned();
    // one LU gives both the manipulability |det J| and, away from singularities, the solution
    let lu = jacobian.lu();
    let manipulability = lu.determinant().abs();
    let (qd, damped) = if manipulability >= s.manipulability_threshold {
        match lu.solve(tool_twist) {
            Some(qd) => (qd, false),
            None => (damped_solve(&jacobian, tool_twist, s.max_damping), true),
        }
    } else {
        let ratio = 1.0 - manipulability / s.manipulability_threshold;
        (damped_solve(&jacobian, tool_twist, s.max_damping * ratio), true)
    };
    let mut padded = JointVector::zeros();
    padded.fixed_rows_mut::<DH_JOINTS>(0).copy_from(&qd);
    (padded, damped)
}

/// q̇ = Jᵀ(JJᵀ + λ²I)⁻¹ V.
fn damped_solve(jacobian: &Matrix6<f64>, twist: &Vector6<f64>, damping: f64) -> Vector6<f64> {
    let inner = jacobian * jacobian.transpose() + Matrix6::identity() * (damping * damping).max(1e-12);
    match inner.cholesky() {
        Some(c) => jacobian.transpose() * c.solve(twist),
        None => Vector6::zeros(),
    }
}
