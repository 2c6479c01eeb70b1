//! # vservo-sim — the robot side of the loop
//!
//! This crate owns the pure, deterministic step functions of the 1 ms side of vservo (the lockstep runner in
//! `vservo-lockstep` composes them with the vision and the servo on one virtual clock):
//! - [`plant::Plant`]: the simulated PUMA 560 — full dynamics (armature and friction) advanced 1 ms per tick
//!   by RK4 substeps, torques held between ticks and saturated at the PUMA's limits, joint limits reported
//!   as faults; or, for any arm, a kinematic mode in which the joints follow the reference (at once, or
//!   through a first-order lag);
//! - [`world::ObjectMotion`]: where the board is at each instant (hold, step, circle);
//! - [`interpolator::Interpolator`]: the resolved-motion-rate interpolator — the latest camera twist held
//!   (or interpolated), mapped to the base frame through `tool_from_camera`, q̇_d from the Jacobian with
//!   damped least squares near singularities (a seven-joint arm through [`redundancy`], its spare joint in
//!   the null space), the tool's speed limits, joint velocity, acceleration and (where the arm has them) jerk
//!   limits ([`motion_limits`]: Ruckig's online trajectory generation), and a stale-twist watchdog;
//! - [`joint_servo::JointServo`]: computed torque, or PD plus gravity;
//! - [`redundancy::resolve`]: a tool twist into joint rates for a chain of six or seven joints, the spare
//!   joint of a seven-joint arm moved in the null space away from its limits (and towards a posture).
//!
//! No I/O, clocks or allocation on the per-tick path.

pub mod interpolator;
pub mod joint_move;
pub mod joint_servo;
pub mod motion_limits;
pub mod plant;
pub mod redundancy;
pub mod world;
