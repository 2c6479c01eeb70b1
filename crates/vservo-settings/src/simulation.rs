//! The simulation's and the interpolator's settings: how the plant moves and its joint servo, how the board
//! moves, how the twist is held and resolved into joint rates.

use nalgebra::Vector3;
use vservo_arm::JointVector;

/// How the plant moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlantMode {
    /// Forward dynamics of the full model (armature and friction) under the commanded torques.
    #[default]
    Dynamic,
    /// The joints take the interpolator's reference exactly: the control law without robot dynamics.
    Kinematic,
}

impl PlantMode {
    /// The name used in configuration files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            PlantMode::Dynamic => "dynamic",
            PlantMode::Kinematic => "kinematic",
        }
    }
}

/// What the joints of the kinematic plant follow, and how fast.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KinematicResponse {
    /// The command the joints follow.
    pub follows: KinematicFollows,
    /// The time constant (s) of the first-order lag through which they follow it; 0: at once.
    pub lag_s: f64,
}

impl KinematicResponse {
    /// The paper's ideal robot: joints that are the position reference exactly (no lag). Any other response
    /// models a real arm's drives.
    pub fn is_ideal(&self) -> bool {
        self.follows == KinematicFollows::Position && self.lag_s == 0.0
    }
}

/// The command a kinematic arm's joints follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KinematicFollows {
    /// The position reference q_d (a position-commanded arm; with no lag, the paper's ideal robot, whose
    /// joints are the reference exactly).
    #[default]
    Position,
    /// The velocity reference q̇_d (a velocity-commanded arm), the position integrated from the velocity.
    Velocity,
}

impl KinematicFollows {
    /// The name in the configuration.
    pub fn name(&self) -> &'static str {
        match self {
            KinematicFollows::Position => "position",
            KinematicFollows::Velocity => "velocity",
        }
    }
}

/// The servo law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JointServoLaw {
    /// τ = M(q)(q̈_d + K_v ė + K_p e) + C q̇ + g + friction(q̇_d), with the model's armature (gains in 1/s²,
    /// 1/s).
    #[default]
    ComputedTorque,
    /// τ = K_p e + K_v ė + g(q) (gains in N·m/rad and N·m·s/rad).
    PdGravity,
}

impl JointServoLaw {
    /// The name used in configuration files.
    pub fn name(&self) -> &'static str {
        match self {
            JointServoLaw::ComputedTorque => "computed-torque",
            JointServoLaw::PdGravity => "pd-gravity",
        }
    }
}

/// How the board moves, in the frame of the camera at the desired pose ("the desired camera frame").
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ObjectMotion {
    /// It stays where the desired pose puts it.
    Hold,
    /// At `at_s` it jumps by `translation_m` (desired camera frame).
    Step {
        /// When (s).
        at_s: f64,
        /// By how much (m), in the desired camera frame.
        translation_m: Vector3<f64>,
    },
    /// A circle of `radius_m` in the desired camera frame's y–z plane, at `rev_per_min`, starting where the
    /// desired pose puts it: p(t) = p₀ + r·[sin ωt · y + (cos ωt − 1) · z] (docs/REPRODUCTION.md).
    Circle {
        /// Radius (m).
        radius_m: f64,
        /// Speed (revolutions per minute).
        rev_per_min: f64,
    },
}

impl ObjectMotion {
    /// The board's displacement at time `t_s` from its desired-pose position, in the desired camera frame.
    pub fn offset_in_desired_camera(&self, t_s: f64) -> Vector3<f64> {
        match *self {
            ObjectMotion::Hold => Vector3::zeros(),
            ObjectMotion::Step { at_s, translation_m } => {
                if t_s >= at_s {
                    translation_m
                } else {
                    Vector3::zeros()
                }
            }
            ObjectMotion::Circle { radius_m, rev_per_min } => {
                let omega = std::f64::consts::TAU * rev_per_min / 60.0;
                let (s, c) = (omega * t_s).sin_cos();
                Vector3::new(0.0, radius_m * s, radius_m * (c - 1.0))
            }
        }
    }
}

/// How the twist is held between vision frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TwistHold {
    /// The latest twist, unchanged until the next (the paper's).
    #[default]
    ZeroOrder,
    /// From the previous twist to the latest over one vision period, then held.
    Linear,
}

/// The lowest dynamics override taken (a thousandth of the arm's limits); what is below is not a motion.
pub const MIN_SPEED_SCALE: f64 = 0.001;

/// The interpolator's tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterpolatorSettings {
    /// How the twist is held.
    pub hold: TwistHold,
    /// The vision period (s): the time over which `Linear` moves to a new twist.
    pub vision_period_s: f64,
    /// The tick (s).
    pub control_period_s: f64,
    /// Below this manipulability the Jacobian is inverted with damping (Nakamura's damped least squares).
    pub manipulability_threshold: f64,
    /// The damping λ at zero manipulability (rad/s per m/s, roughly); it falls to 0 at the threshold.
    pub max_damping: f64,
    /// A twist older than this is stale (two vision periods by default).
    pub stale_after_s: f64,
    /// Once the twist is stale, the joint velocity ramps to zero over this time (s).
    pub stop_ramp_s: f64,
    /// The most each joint's reference speed may change per second (rad/s²). A new twist is a step in
    /// velocity; passed on raw, its acceleration (Δq̇/1 ms) would ask the joint servo for more torque than
    /// the motors have. The change is scaled as a whole, so the direction of motion is kept.
    pub acceleration_limit: JointVector,
    /// The most each joint's reference acceleration may change per second (rad/s³), where the arm declares
    /// it. With it, the reference is jerk-limited on every path (`vservo_sim::motion_limits`): its acceleration
    /// ramps rather than steps. Without it (`None`, the PUMA 560's case: no jerk limit is published for it),
    /// the acceleration may step to its limit within a tick, as before jerk limits.
    pub jerk_limit: Option<JointVector>,
    /// The tool's speed (m/s) the twist is scaled down to, whole, where it asks for more (infinite: none).
    pub tool_speed_limit_m_s: f64,
    /// The tool's angular speed (rad/s) the twist is scaled down to, whole, where it asks for more.
    pub tool_rotation_limit_rad_s: f64,
    /// What a seven-joint arm does with the joint it has to spare (a six-joint arm has none).
    pub null_space: NullSpaceTask,
    /// The dynamics override, in (0, 1]: the joints' speed, acceleration and jerk limits and the tool's caps
    /// are each this share of the arm's (`[robot] speed_scale`, and live `vservoctl speed`), as a pendant's
    /// speed slider scales them.
    pub speed_scale: f64,
}

impl InterpolatorSettings {
    /// The defaults for a vision period and a tick.
    pub fn new(vision_period_s: f64, control_period_s: f64) -> Self {
        // the PUMA 560's; a seventh joint, a wrist's, as the PUMA's wrist
        let mut acceleration_limit = vservo_arm::puma560::ACCELERATION_LIMITS_RAD_S2;
        acceleration_limit[6] = acceleration_limit[5];
        Self {
            hold: TwistHold::ZeroOrder,
            vision_period_s,
            control_period_s,
            manipulability_threshold: 0.01,
            max_damping: 0.05,
            stale_after_s: 2.0 * vision_period_s,
            stop_ramp_s: 0.2,
            acceleration_limit,
            jerk_limit: None,
            tool_speed_limit_m_s: f64::INFINITY,
            tool_rotation_limit_rad_s: f64::INFINITY,
            null_space: NullSpaceTask::default(),
            speed_scale: 1.0,
        }
    }
}

/// The secondary task of a redundant arm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NullSpaceTask {
    /// How far from a limit (rad) the push away from it starts.
    pub limit_zone_rad: f64,
    /// How hard a joint inside the zone is pushed away: rad/s per rad of depth into the zone.
    pub limit_gain: f64,
    /// A posture to stay near (rad), if any.
    pub posture: Option<JointVector>,
    /// How hard the joints are pulled towards the posture (1/s).
    pub posture_gain: f64,
}

impl Default for NullSpaceTask {
    fn default() -> Self {
        Self { limit_zone_rad: 0.3, limit_gain: 2.0, posture: None, posture_gain: 0.5 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_circle_starts_at_the_desired_position_and_has_its_radius() {
        let circle = ObjectMotion::Circle { radius_m: 0.1, rev_per_min: 5.0 };
        assert_eq!(circle.offset_in_desired_camera(0.0), Vector3::zeros());
        // a quarter turn (3 s at 5 rev/min): up by r along y, towards the camera by r along z
        let quarter = circle.offset_in_desired_camera(3.0);
        assert!((quarter - Vector3::new(0.0, 0.1, -0.1)).norm() < 1e-12, "{quarter}");
        let half = circle.offset_in_desired_camera(6.0);
        assert!((half - Vector3::new(0.0, 0.0, -0.2)).norm() < 1e-12);
        let step = ObjectMotion::Step { at_s: 1.0, translation_m: Vector3::x() };
        assert_eq!(step.offset_in_desired_camera(0.999), Vector3::zeros());
        assert_eq!(step.offset_in_desired_camera(1.0), Vector3::x());
    }
}
