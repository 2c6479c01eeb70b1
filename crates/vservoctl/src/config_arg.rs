//! The `--config FILE` option shared by the commands that read a configuration.

use std::path::PathBuf;

use clap::{Args, ValueEnum};
use vservo_config::Config;
use vservo_control::lq::{DelayAwareGain, delay_aware_gain};
use vservo_control::{ControlLaw, Gains};

use crate::UsageError;

/// Where the configuration comes from.
#[derive(Args, Debug, Clone)]
pub struct ConfigArg {
    /// The configuration file.
    #[arg(long, value_name = "FILE", default_value = "config/vservo.toml")]
    pub config: PathBuf,
}

impl ConfigArg {
    /// Loads and validates the file; a bad file is the user's to fix (exit code 2).
    pub fn load(&self) -> Result<Config, UsageError> {
        Config::load(&self.config).map_err(|e| UsageError(e.to_string()))
    }
}

/// A control law on the command line (`--controller`, `--law`), overriding `controller.law`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LawArg {
    /// The paper's LQ law.
    Paper,
    /// LQ on the state augmented with the commands in the pipeline.
    DelayAware,
    /// Pose-based, the camera on a straight line.
    Pbvs,
    /// Pose-based, the marks' centre on a straight line.
    PbvsTarget,
    /// 2½-D.
    #[value(name = "2.5d")]
    TwoAndAHalfD,
}

impl LawArg {
    /// The configuration's law of this name.
    pub fn law(self) -> ControlLaw {
        match self {
            LawArg::Paper => ControlLaw::Paper,
            LawArg::DelayAware => ControlLaw::DelayAware,
            LawArg::Pbvs => ControlLaw::Pbvs,
            LawArg::PbvsTarget => ControlLaw::PbvsTarget,
            LawArg::TwoAndAHalfD => ControlLaw::TwoAndAHalfD,
        }
    }
}

/// Designs the configured gains; a design that fails is a configuration the user must change.
pub fn design_gains(config: &Config) -> Result<Gains, UsageError> {
    Gains::design(&config.cell.gains_spec())
        .map_err(|e| UsageError(format!("{}: controller: the gain cannot be designed: {e}", config.origin)))
}

/// The delay-aware gain for the configured delay, designed on the same decomposition as `gains`, for
/// showing beside the configured law whichever it is.
pub fn design_delay_aware(config: &Config, gains: &Gains) -> Result<DelayAwareGain, UsageError> {
    let spec = config.cell.gains_spec();
    delay_aware_gain(&gains.decomposition, &spec.q, &spec.r.si(), config.cell.timing.pipeline_delay_frames)
        .map_err(|e| UsageError(format!("{}: the delay-aware gain cannot be designed: {e}", config.origin)))
}
