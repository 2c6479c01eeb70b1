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
    /// The base a file `extends` could not be read.
    #[error("{file}: extends {base}, which cannot be read: {reason}")]
    Base {
        /// The file that names the base.
        file: String,
        /// The base, its path as resolved from the file's directory.
        base: String,
        /// The operating system's reason.
        reason: String,
    },
    /// A file extends itself, through its bases or directly.
    #[error("{file}: extends itself: {chain}")]
    Cycle {
        /// The file read first.
        file: String,
        /// The files in the order read, the repeated one last.
        chain: String,
    },
    /// Not TOML, an unknown key, a missing key, a value of the wrong type or an unknown name.
    #[error("{file}: {message}")]
    Parse {
        /// The file in which the bad key was written.
        file: String,
        /// The dotted key (the table holding it, for an unknown or missing key), when the parser knew one.
        key: Option<String>,
        /// The parser's message (the key, the value and, for a name, the accepted ones; the line where the
        /// parser had the file's text).
        message: String,
    },
    /// A key whose value is well-formed but not acceptable.
    #[error("{file}: {key} = {value}: {reason}")]
    Invalid {
        /// The file in which the key was written (the first file when it was left to its default).
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
            ConfigError::Parse { key, .. } => key.as_deref(),
            _ => None,
        }
    }

    /// The file the error names.
    pub fn file(&self) -> &str {
        match self {
            ConfigError::Read { file, .. }
            | ConfigError::Base { file, .. }
            | ConfigError::Cycle { file, .. }
            | ConfigError::Parse { file, .. }
            | ConfigError::Invalid { file, .. } => file,
        }
    }

    /// The same error, said of the overlay `culprit` whose keys made a key of `written_in` wrong.
    pub(crate) fn caused_by(self, culprit: &str, written_in: &str) -> Self {
        match self {
            ConfigError::Invalid { key, value, reason, .. } => ConfigError::Invalid {
                file: culprit.to_string(),
                reason: format!(
                    "{reason} ({key} is as {written_in} writes it, which is valid alone: this file's keys make it wrong)"
                ),
                key,
                value,
            },
            other => other,
        }
    }

    /// The same error, said of another file (the one in which its key was written).
    pub(crate) fn in_file(self, written_in: &str) -> Self {
        match self {
            ConfigError::Invalid { key, value, reason, .. } => {
                ConfigError::Invalid { file: written_in.to_string(), key, value, reason }
            }
            other => other,
        }
    }
}
