//! # vservo-control — the paper's visual-servo controller
//!
//! This crate owns the control law of Hashimoto, Ebine & Kimura (1996), Sections II–III, and the analysis
//! that tells a user what a choice of Q and R will do:
//! - [`image_jacobian`]: the point image Jacobian (eq. 3), the extended image Jacobian J⁺ (eq. 5), and
//!   the discrete model B = T·J⁺(ξ_d, Z_d) (eq. 12); with fx ≠ fy
//!   [`image_jacobian::point_image_jacobian_fx_fy`], the paper's formula when they are equal;
//! - [`weights`]: the weights Q (8×8, ⪰ 0) and R (6×6, ≻ 0), validated, with R written for a stated input
//!   unit (the paper's mm/s and mrad/s by default) and applied in SI;
//! - [`dare`]: the discrete algebraic Riccati equation — the closed form for A = I with a non-singular B_c,
//!   and a structure-preserving doubling solver for any A;
//! - [`lq`]: the LQ gain on the controllable/uncontrollable mode decomposition (eq. 19–41), and the
//!   delay-aware gain, LQ on the state augmented with the commands still in the image pipeline;
//! - [`law`]: the per-frame control law u = −K (ξ − ξ_d) − Σ K_j u(k−j), allocation-free, and what it does
//!   beyond the paper's when configured to: servo on the three marks left when one is missing, a gain
//!   scheduled on the current features ([`frame_design`]), a barrier that keeps the marks inside the image
//!   ([`border`]), and the target's own motion fed forward ([`target_motion`]);
//! - [`analysis`]: closed-loop eigenvalues with and without the pipeline delay, and the Corollary 1
//!   stability margins;
//! - [`pose_features`]: the features of the target's pose for the laws beyond image-based servoing (pose-based
//!   on the camera's or the target's straight line, and 2½-D) with their interaction matrices;
//! - [`pose_law`]: those laws on the per-frame path (`controller.law = "pbvs"`, `"pbvs-target"`, `"2.5d"`): the
//!   board's pose from the four marks, the pose error predicted through the pipeline, u = −λ L⁻¹ ê within speed
//!   caps; [`ServoLaw`] runs them with all four marks seen (and the barrier when set), and the delay-aware image
//!   law on three.
//!
//! Units: SI inside (m/s and rad/s for the camera twist u = [v; ω] in the camera frame), features in pixels,
//! so K is in m/s and rad/s per pixel.
//!
//! Gain synthesis runs off the hot path: `vservo-config` turns the configuration into a [`GainsSpec`], and
//! [`Gains::design`] makes the gains from it (at start, on a reload, for a new target); the servo then runs
//! [`ServoLaw::step`] once per frame. With an [`Interaction`] other than `Desired` (B at the mean of ξ_d's
//! and the current J⁺, or at the current) the servo designs the gain itself on every frame (the paper's
//! design on static matrices, [`frame_design`], tens of µs); on each new design it also designs the four
//! gains on three marks. [`LawOptions`] holds the options beyond the paper's law.
//!
//! ## The law beyond the paper
//!
//! All allocation-free, on the per-frame path ([`law`]):
//! - **Delay-aware.** The delay-aware law is the paper's gain on the features predicted through the pipeline:
//!   u(k) = −K (ξ̄(k−d) + B Σⱼ u(k−j)), i.e. K_ξ = K and K_j = K B (a test checks the general DARE's K_j
//!   against this). So it carries over to three marks and to a scheduled B unchanged: u = −K(B) (ξ̄ + B Σ u).
//! - **Three marks.** B with the missing mark's rows zeroed is 6 × 6 in effect; the paper's design on it has
//!   no uncontrollable modes.
//! - **Scheduled.** The depths come from the board pose the four features give
//!   (`vservo_scene::CameraIntrinsics::board_pose_from_features`); with three marks the last depths serve.
//! - **Feed-forward.** [`target_motion::TargetMotion`] takes the part of each mark's image motion that the
//!   camera's measured motion (`features.base_from_camera`, from the joint state at capture; for an external
//!   camera interpolated between the joint states around the exposure stamp) does not explain; the law adds
//!   it to the prediction over the delay and cancels it over the coming frame with B⁺.
//! - **Barrier.** [`border::Barrier`] changes a twist only when it would take a seen mark closer to the margin
//!   than half the distance left ([`border::APPROACH_PER_FRAME`]), by the least R⁻¹-weighted correction.
//! - **What the arm follows** ([`twist_rate`], for an arm whose reference keeps jerk limits: the servo stage
//!   sets an [`ArmResponse`]). Every twist the law computes, the paper's included, is shaped: slowed so that the
//!   arm can still stop before the goal, and its change from the last twist cut to what every joint's speed
//!   follows within the frame; the law remembers the twist sent (anti-windup). The prediction then adds the
//!   arm's lag: in each frame of the pipeline the camera moved (v − u)(τ/T)(1 − e^(−T/τ)) off its twist, it
//!   goes on by vτ once the twist is zero, and it moved by v since the capture for the time the image cannot
//!   show, v the camera's velocity estimated from the twists sent. The paper's ideal robot has no response
//!   set, and the paper's scenarios are unchanged bit for bit.
//!
//! With fewer than three marks there is no law to run: the servo stage (`vservo-cell`) steers the camera back
//! to where all four were last seen.

pub mod analysis;
pub mod border;
pub mod dare;
pub mod design;
pub mod frame_design;
pub mod image_jacobian;
pub mod law;
pub mod lq;
pub mod pose_features;
pub mod pose_law;
pub mod target_motion;
pub mod twist_rate;

pub use design::{ControlLaw, Gains, GainsError, GainsSpec, Interaction, LawOptions};
pub use law::{LawFlags, LawGains, LawGeometry, ServoLaw, pose_features_of};
pub use twist_rate::{ArmResponse, JointDynamics, TwistRateLimit};
pub use vservo_settings::control::MAX_DELAY_FRAMES;
pub use vservo_settings::weights::{self, InputUnits, InputWeight, StateWeight, WeightError};

/// The camera twist u = [v; ω] in the camera frame (m/s, rad/s).
pub type Twist = nalgebra::Vector6<f64>;
/// The discrete model B = T·J⁺ (pixels per m/s and per rad/s), 8 × 6.
pub type InteractionMatrix = nalgebra::SMatrix<f64, { vservo_scene::FEATURES }, 6>;
/// A feedback gain from features to twist, 6 × 8 (m/s and rad/s per pixel).
pub type FeatureGain = nalgebra::SMatrix<f64, 6, { vservo_scene::FEATURES }>;
