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
    /// Pose-based: on the board's pose from its four marks, the camera on a straight line to the desired pose,
    /// u = −λ L⁻¹ ê with ê the pose error predicted through the pipeline.
    Pbvs,
    /// Pose-based with the board's origin on a straight line in the image (it stays in view).
    PbvsTarget,
    /// 2½-D (Malis): the board origin's image point, its log depth and the rotation.
    TwoAndAHalfD,
}

impl ControlLaw {
    /// The name used in configuration files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            ControlLaw::Paper => "paper",
            ControlLaw::DelayAware => "delay-aware",
            ControlLaw::Pbvs => "pbvs",
            ControlLaw::PbvsTarget => "pbvs-target",
            ControlLaw::TwoAndAHalfD => "2.5d",
        }
    }

    /// Every law, in the order the documentation lists them.
    pub const ALL: [ControlLaw; 5] = [
        ControlLaw::Paper,
        ControlLaw::DelayAware,
        ControlLaw::Pbvs,
        ControlLaw::PbvsTarget,
        ControlLaw::TwoAndAHalfD,
    ];

    /// Whether the law servoes on the board's pose (with all four marks seen) rather than on the image.
    pub fn is_pose_based(&self) -> bool {
        matches!(self, ControlLaw::Pbvs | ControlLaw::PbvsTarget | ControlLaw::TwoAndAHalfD)
    }

    /// Whether the law predicts the features through the pipeline's delay (every law but the paper's).
    pub fn predicts_through_delay(&self) -> bool {
        *self != ControlLaw::Paper
    }
}

/// λT of the pose-based laws when `controller.pose_gain_per_s` is not written: the share of the error predicted
/// through the pipeline that one vision period takes away (λ = 6 per s at the paper's 85 ms).
pub const DEFAULT_POSE_GAIN_PER_PERIOD: f64 = 0.51;

/// [`DEFAULT_POSE_GAIN_PER_PERIOD`] at the paper's vision period of 85 ms, in [`LawOptions::default`] (1/s).
pub const DEFAULT_POSE_GAIN_PER_S: f64 = 6.0;

/// The pose-based laws' camera speed caps when `controller.pose_max_speed_m_s` and
/// `controller.pose_max_rotation_rad_s` are not written: a twist above either is scaled down whole (its
/// direction, so the path, kept).
pub const DEFAULT_POSE_MAX_SPEED_M_S: f64 = 0.5;
/// See [`DEFAULT_POSE_MAX_SPEED_M_S`].
pub const DEFAULT_POSE_MAX_ROTATION_RAD_S: f64 = 2.0;

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
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LawOptions {
    /// Where B is evaluated.
    pub interaction: Interaction,
    /// Keep every seen mark this far inside the image (px); 0 for no barrier (`vservo_control::border`).
    pub border_margin_px: f64,
    /// Estimate the target's image motion and feed it forward through the delay
    /// (`vservo_control::target_motion`).
    pub feedforward: bool,
    /// λ of the pose-based laws, u = −λ L⁻¹ ê (1/s; [`DEFAULT_POSE_GAIN_PER_PERIOD`] per vision period unless
    /// written); the image laws do not use it.
    pub pose_gain_per_s: f64,
    /// The pose-based laws' linear speed cap (m/s): a faster twist is scaled down whole.
    pub pose_max_speed_m_s: f64,
    /// The pose-based laws' angular speed cap (rad/s): a faster twist is scaled down whole.
    pub pose_max_rotation_rad_s: f64,
}

impl Default for LawOptions {
    fn default() -> Self {
        Self {
            interaction: Interaction::Desired,
            border_margin_px: 0.0,
            feedforward: false,
            pose_gain_per_s: DEFAULT_POSE_GAIN_PER_S,
            pose_max_speed_m_s: DEFAULT_POSE_MAX_SPEED_M_S,
            pose_max_rotation_rad_s: DEFAULT_POSE_MAX_ROTATION_RAD_S,
        }
    }
}

impl LawOptions {
    /// Whether the image law runs as designed: B at ξ_d, no barrier, no feed-forward (the pose-based laws'
    /// settings do not change the image law).
    pub fn image_law_as_designed(&self) -> bool {
        self.interaction == Interaction::Desired && self.border_margin_px == 0.0 && !self.feedforward
    }

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
