//! What the configuration's test files share: the annotated default and a line of it changed.

use vservo_config::{Config, ConfigError};

/// config/vservo.toml as shipped.
pub const DEFAULT: &str = include_str!("../../../../config/vservo.toml");

/// The default with the first `old` replaced by `new` (which the default must hold).
pub fn with(old: &str, new: &str) -> String {
    assert!(DEFAULT.contains(old), "the default config holds {old:?}");
    DEFAULT.replacen(old, new, 1)
}

/// The configuration `text` refused.
pub fn refused(text: &str) -> ConfigError {
    Config::from_toml(text, "test.toml").expect_err("refused")
}
