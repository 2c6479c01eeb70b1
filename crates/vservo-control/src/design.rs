//! From a specification (camera, desired features, period, weights, law) to the gains the servo runs.

use nalgebra::Matrix6;
use vservo_scene::{FeatureVector, MarkDepths};

use crate::image_jacobian::interaction_matrix;
use crate::lq::{self, LqError, ModeDecomposition, PaperGain};
use crate::{FeatureGain, InteractionMatrix, MAX_DELAY_FRAMES};
pub use vservo_settings::control::{ControlLaw, GainsSpec, Interaction, LawOptions};
use vservo_settings::weights::StateWeight;

/// Why gains could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GainsError {
    /// The LQ design failed.
    #[error(transparent)]
    Lq(#[from] LqError),
    /// The period is not a positive finite number.
    #[error("the vision period {0} s must be positive")]
    Period(f64),
    /// The pose-based laws' λ is not positive or more than one per vision period.
    #[error(
        "the pose-based law's gain λ = {gain_per_s} 1/s must be positive and at most 1/T ({most_per_s} 1/s)"
    )]
    PoseGain {
        /// λ (1/s).
        gain_per_s: f64,
        /// 1/T (1/s).
        most_per_s: f64,
    },
    /// A desired mark is at or behind the camera.
    #[error("desired depth of mark {mark} is {depth_m} m; it must be in front of the camera")]
    Depth {
        /// One-based mark number.
        mark: usize,
        /// The depth.
        depth_m: f64,
    },
}

/// The gains the servo runs, with the design quantities kept for analysis and display.
#[derive(Debug, Clone, PartialEq)]
pub struct Gains {
    /// The law these gains implement.
    pub law: ControlLaw,
    /// B = T·J⁺(ξ_d, Z_d).
    pub b: InteractionMatrix,
    /// The mode decomposition of B.
    pub decomposition: ModeDecomposition,
    /// The paper's gain (always designed: the delay-aware law is compared against it).
    pub paper: PaperGain,
    /// The gain on the feature error for the selected law (K for the paper's law, K_ξ for the other).
    pub feature_gain: FeatureGain,
    /// K_j on the command sent j frames ago (zero for the paper's law); the first `delay_frames` are used.
    pub past_input_gains: [Matrix6<f64>; MAX_DELAY_FRAMES],
    /// The pipeline delay the gains were designed for (frames).
    pub delay_frames: usize,
    /// ξ_d.
    pub desired_features: FeatureVector,
    /// Z_d (m).
    pub desired_depths: MarkDepths,
    /// Q.
    pub q: StateWeight,
    /// R in SI units.
    pub r_si: Matrix6<f64>,
    /// What the law does beyond the paper's.
    pub options: LawOptions,
}

impl Gains {
    /// Designs the gains: B, its decomposition, the paper's gain, and the delay-aware one when selected.
    pub fn design(spec: &GainsSpec) -> Result<Gains, GainsError> {
        if !(spec.period_s.is_finite() && spec.period_s > 0.0) {
            return Err(GainsError::Period(spec.period_s));
        }
        if let Some(mark) = spec.desired_depths.iter().position(|z| !(z.is_finite() && *z > 0.0)) {
            return Err(GainsError::Depth { mark: mark + 1, depth_m: spec.desired_depths[mark] });
        }
        if spec.delay_frames > MAX_DELAY_FRAMES {
            return Err(LqError::DelayTooLong(spec.delay_frames).into());
        }
        let pose_gain = spec.options.pose_gain_per_s;
        if spec.law.is_pose_based() && !(pose_gain > 0.0 && pose_gain * spec.period_s <= 1.0) {
            return Err(GainsError::PoseGain { gain_per_s: pose_gain, most_per_s: 1.0 / spec.period_s });
        }
        let b = interaction_matrix(&spec.camera, &spec.desired_features, &spec.desired_depths, spec.period_s);
        let decomposition = ModeDecomposition::of(&b)?;
        let r_si = spec.r.si();
        let paper = lq::paper_gain(&decomposition, &spec.q, &r_si)?;
        let mut past_input_gains = [Matrix6::zeros(); MAX_DELAY_FRAMES];
        let feature_gain = match spec.law {
            ControlLaw::Paper => paper.k,
            // the pose-based laws run the delay-aware image law on a frame with three marks
            ControlLaw::DelayAware | ControlLaw::Pbvs | ControlLaw::PbvsTarget | ControlLaw::TwoAndAHalfD => {
                let gain = lq::delay_aware_gain(&decomposition, &spec.q, &r_si, spec.delay_frames)?;
                for (slot, k) in past_input_gains.iter_mut().zip(&gain.past_input_gains) {
                    *slot = *k;
                }
                gain.feature_gain
            }
        };
        Ok(Gains {
            law: spec.law,
            b,
            decomposition,
            paper,
            feature_gain,
            past_input_gains,
            delay_frames: spec.delay_frames,
            desired_features: spec.desired_features,
            desired_depths: spec.desired_depths,
            q: spec.q,
            r_si,
            options: spec.options,
        })
    }

    /// The gains on past commands that the law uses (empty for the paper's law).
    pub fn active_past_input_gains(&self) -> &[Matrix6<f64>] {
        if self.law.predicts_through_delay() { &self.past_input_gains[..self.delay_frames] } else { &[] }
    }
}
