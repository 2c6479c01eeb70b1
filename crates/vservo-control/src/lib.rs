//! # vservo-control — the paper's visual-servo controller
//!
//! This crate owns the control law of Hashimoto, Ebine & Kimura (1996), Sections II–III, and the analysis
//! that tells a user what a choice of Q and R will do:
//! - [`image_jacobian`]: the point image Jacobian (eq. 3), the extended image Jacobian J⁺ (eq. 5), and
//!   the discrete model B = T·J⁺(ξ_d, Z_d) (eq. 12);
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
//!   stability margins.
//!
//! Units: SI inside (m/s and rad/s for the camera twist u = [v; ω] in the camera frame), features in pixels,
//! so K is in m/s and rad/s per pixel.

pub mod analysis;
pub mod border;
pub mod dare;
pub mod design;
pub mod frame_design;
pub mod image_jacobian;
pub mod law;
pub mod lq;
pub mod target_motion;
pub mod weights;

pub use design::{ControlLaw, Gains, GainsError, GainsSpec, Interaction, LawOptions};
pub use law::{LawFlags, LawGains, LawGeometry, ServoLaw};
pub use weights::{InputUnits, InputWeight, StateWeight, WeightError};

/// The camera twist u = [v; ω] in the camera frame (m/s, rad/s).
pub type Twist = nalgebra::Vector6<f64>;
/// The discrete model B = T·J⁺ (pixels per m/s and per rad/s), 8 × 6.
pub type InteractionMatrix = nalgebra::SMatrix<f64, { vservo_scene::FEATURES }, 6>;
/// A feedback gain from features to twist, 6 × 8 (m/s and rad/s per pixel).
pub type FeatureGain = nalgebra::SMatrix<f64, 6, { vservo_scene::FEATURES }>;
/// The longest image-pipeline delay the delay-aware law supports, in vision frames.
pub const MAX_DELAY_FRAMES: usize = 4;
