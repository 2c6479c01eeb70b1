//! # vservo-sim — the robot side of the loop
//!
//! This crate owns the pure, deterministic step functions of the 1 ms side of vservo (the lockstep runner in
//! `vservo-lockstep` composes them with the vision and the servo on one virtual clock):
//! - [`plant::Plant`]: the simulated PUMA 560 — full dynamics (armature and friction) advanced 1 ms per tick
//!   by RK4 substeps, torques held between ticks and saturated at the PUMA's limits, joint limits reported
//!   as faults; or, for any arm, a kinematic mode in which the joints follow the position or the velocity
//!   reference (at once, or through a first-order lag solved exactly over the tick);
//! - [`world::ObjectMotion`]: where the board is at each instant (hold, step, circle);
//! - [`interpolator::Interpolator`]: the resolved-motion-rate interpolator — the latest camera twist held
//!   (or interpolated), mapped to the base frame through `tool_from_camera`, q̇_d from the Jacobian (six
//!   joints: the 6×6 Jacobian's LU, damped least squares under a manipulability threshold; a seven-joint arm
//!   through [`redundancy`], its spare joint in the null space), the tool's speed limits, joint velocity,
//!   acceleration and (where the arm has them) jerk limits ([`motion_limits`]: Ruckig's online trajectory
//!   generation), and a stale-twist watchdog;
//! - [`joint_servo::JointServo`]: computed torque (with friction at q̇_d), or PD plus gravity;
//! - [`joint_move`]: a move of the joints to a goal at a share of their speed limits (what `vservoctl
//!   calibrate` asks of a running cell), speeding up and braking tick by tick at that share squared of their
//!   acceleration limits — the move scaled in time —, a joint faster than the move or moving away from its
//!   goal braking at its full limit, each joint limited on its own; [`joint_move::speed_fraction_ok`] is the
//!   one rule for the share, which the daemon and the rmrc apply. [`interpolator::Interpolator::move_joints_to`]
//!   follows it instead of the twists until `end_joint_move`;
//! - [`joint_move_torque`]: for a torque-driven arm, the share a move may use within the drives' torque (0.8
//!   of each limit by inverse dynamics along the move), planned once when the move is asked for;
//! - [`redundancy::resolve`]: a tool twist into joint rates for a chain of six or seven joints, the spare
//!   joint of a seven-joint arm moved in the null space away from its limits (and towards a posture); the
//!   interpolator calls it every tick for a seven-joint arm.
//!
//! The jerk-limited reference ([`motion_limits`]: Ruckig through `rsruckig`, seven degrees of freedom on the
//! stack, no clock): with the arm's jerk limits every tick of the interpolator — servoing (Ruckig's velocity
//! interface), a joint move (its position interface, the share's limits scaled in time), the ramp to rest —
//! is the next sample of a time-optimal trajectory within the arm's speed, acceleration and jerk limits
//! ([`interpolator::LIMIT_MARGIN`] inside them), the tool's speed capped first; without them (the PUMA 560)
//! the acceleration-limited reference, bit for bit as before.
//!
//! No I/O, clocks or allocation on the per-tick path.

pub mod interpolator;
pub mod joint_move;
pub mod joint_move_torque;
pub mod joint_servo;
pub mod motion_limits;
pub mod plant;
pub mod redundancy;
pub mod world;
