//! The `--config FILE` option shared by the commands that read a configuration.

use std::path::PathBuf;

use clap::Args;
use vservo_config::Config;
use vservo_control::Gains;
use vservo_control::lq::{DelayAwareGain, delay_aware_gain};

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
