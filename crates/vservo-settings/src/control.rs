//! The control law's settings: which law, its options, and everything its gains are designed from.

use vservo_scene::{CameraIntrinsics, FeatureVector, MarkDepths};

use crate::weights::{InputWeight, StateWeight};

/// The longest image-pipeline delay the delay-aware law supports, in vision frames.
pub const MAX_DELAY_FRAMES: usize = 4;

/// Which control law the servo runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ControlLaw {
    /// The paper's: u = −K (ξ − ξ_d), designed as if there were no pipeline delay.
    #[default]
    Paper,
    /// LQ on the delay-augmented state: u = −K_ξ (ξ − ξ_d) − Σ K_j u(k − j).
    DelayAware,
}

impl ControlLaw {
    /// The name used in configuration files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            ControlLaw::Paper => "paper",
            ControlLaw::DelayAware => "delay-aware",
        }
    }
}

/// Where the servo's model B = T·J⁺ is evaluated (`controller.interaction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Interaction {
    /// At ξ_d and Z_d, once: the paper's fixed gain.
    #[default]
    Desired,
    /// The mean of J⁺ at ξ_d, Z_d and at the current features and depths, the gain designed anew on every
    /// frame: the camera's path stays near a straight line for large displacements and rolls.
    Mean,
    /// At the current features and depths, designed anew on every frame (classic IBVS's choice).
    Current,
}

impl Interaction {
    /// The name in configuration files.
    pub fn name(&self) -> &'static str {
        match self {
            Interaction::Desired => "desired",
            Interaction::Mean => "mean",
            Interaction::Current => "current",
        }
    }
}

/// What the law does beyond the paper's (all off by default: the paper's law as published).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LawOptions {
    /// Where B is evaluated.
    pub interaction: Interaction,
    /// Keep every seen mark this far inside the image (px); 0 for no barrier (`vservo_control::border`).
    pub border_margin_px: f64,
    /// Estimate the target's image motion and feed it forward through the delay
    /// (`vservo_control::target_motion`).
    pub feedforward: bool,
}

impl LawOptions {
    /// Whether the law needs the current mark depths (from the board pose the features give).
    pub fn needs_depths(&self) -> bool {
        self.interaction != Interaction::Desired || self.feedforward
    }
}

/// Everything a gain is designed from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainsSpec {
    /// The camera.
    pub camera: CameraIntrinsics,
    /// ξ_d (px).
    pub desired_features: FeatureVector,
    /// Z_d, the mark depths at the desired pose (m).
    pub desired_depths: MarkDepths,
    /// The vision period T (s).
    pub period_s: f64,
    /// The image pipeline's delay in vision frames.
    pub delay_frames: usize,
    /// Q.
    pub q: StateWeight,
    /// R.
    pub r: InputWeight,
    /// The law to run.
    pub law: ControlLaw,
    /// What it does beyond the paper's.
    pub options: LawOptions,
}
