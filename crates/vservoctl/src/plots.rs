//! The paper's figures from a run (filled in by the plotting commit).

use std::path::Path;

use anyhow::Result;
use vservo_config::Config;
use vservo_lockstep::Trace;

/// Draws the figures into `dir`.
pub fn draw(_trace: &Trace, _config: &Config, _dir: &Path) -> Result<()> {
    Ok(())
}
