//! The run's seal key for a driver process vservod starts: handed on its stdin as the nodes get it (one key line,
//! `vservo_wire::seal::read_key_line`), read before anything else, with the process's memory made private first.

use std::os::fd::AsFd;

use vservo_wire::seal::SealKey;

/// Reading the key failed.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    /// The memory could not be made private (the key would be readable by the user's other processes).
    #[error("making the process's memory private before it holds the seal key: {0}")]
    Private(std::io::Error),
    /// stdin could not be read, or its first line is no key line.
    #[error("reading the run's seal key from stdin (--seal-key-stdin): {0}")]
    Read(std::io::Error),
    /// stdin held no key line.
    #[error(
        "--seal-key-stdin, but stdin holds no key line (the driver is started by vservod, which hands it over)"
    )]
    Missing,
}

/// With `from_stdin`, the key from stdin (vservod started the driver); else none, said in a warning: without the
/// key no command is the rmrc's, and the driver takes none (docs/DRIVERS.md, "Seals").
pub fn seal_key(from_stdin: bool) -> Result<Option<SealKey>, KeyError> {
    if !from_stdin {
        tracing::warn!(
            "no seal key (the driver was not started by vservod): no command can be the rmrc's and none is taken"
        );
        return Ok(None);
    }
    vservo_wire::seal::keep_memory_private().map_err(|e| KeyError::Private(e.into()))?;
    let fd = std::io::stdin().as_fd().try_clone_to_owned().map_err(KeyError::Read)?;
    let (key, _) = vservo_wire::seal::read_key_line(&mut std::fs::File::from(fd)).map_err(KeyError::Read)?;
    key.map(Some).ok_or(KeyError::Missing)
}
