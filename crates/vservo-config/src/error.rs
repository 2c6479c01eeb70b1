//! Configuration errors: each names the file, and where it can, the key and the value.

/// Why a configuration was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{file}: cannot read: {reason}")]
    Read {
        /// The file.
        file: String,
        /// The operating system's reason.
        reason: String,
    },
    /// Not TOML, an unknown key, a missing key, or a value of the wrong type.
    #[error("{file}: {message}")]
    Parse {
        /// The file.
        file: String,
        /// The parser's message (it shows the line, the key and the value).
        message: String,
    },
    /// A key whose value is well-formed but not acceptable.
    #[error("{file}: {key} = {value}: {reason}")]
    Invalid {
        /// The file.
        file: String,
        /// The dotted key, e.g. `controller.r`.
        key: String,
        /// The value as written (or as understood).
        value: String,
        /// What is wrong with it.
        reason: String,
    },
}

impl ConfigError {
    /// The dotted key the error is about, when it is about one.
    pub fn key(&self) -> Option<&str> {
        match self {
            ConfigError::Invalid { key, .. } => Some(key),
            _ => None,
        }
    }
}
