//! Why an instance's directory could not be found, made or trusted.

use std::path::PathBuf;

/// Why an instance's directory could not be found, made or trusted.
#[derive(Debug, thiserror::Error)]
pub enum InstanceDirError {
    /// No daemon has made the instance's directory (or it was removed).
    #[error("no vservod of instance {instance:?} is running (looked for {}) — is it running, and as which user? Start one with `scripts/run.sh [--config FILE]` in the source tree, `vservod --config FILE`, or `systemctl start vservo` (the Debian package)", .looked_in.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" and "))]
    NotRunning {
        /// The instance.
        instance: String,
        /// The directories looked for.
        looked_in: Vec<PathBuf>,
    },
    /// The instance belongs to another user: its resources are that user's only.
    #[error(
        "instance {instance:?} is run by user {owner:?} ({path} is that user's), and its shared memory is that user's only: run the client as that user (for example `sudo -u {owner} vservoctl …`)"
    )]
    OtherUser {
        /// The instance.
        instance: String,
        /// The owning user's name (or `uid N`).
        owner: String,
        /// The directory that told.
        path: PathBuf,
    },
    /// None of this user's, and a base this user may not search may hold another user's: whose instance it
    /// would be cannot be told (the base's owner is not the instance's).
    #[error(
        "no vservod of instance {instance:?} of this user is running (looked for {}); {base} is closed to this user \
         ({}) and may hold another user's: if the instance runs there, run the client as the user who started its \
         daemon (for example `sudo -u <that user> vservoctl …`)",
        .looked_in.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(" and "),
        .base_owner.as_ref().map_or_else(|| "whose it is cannot be told".to_string(), |owner| format!("the directory is user {owner:?}'s"))
    )]
    Closed {
        /// The instance.
        instance: String,
        /// The base this user may not search.
        base: PathBuf,
        /// Its owner's name (or `uid N`), if it can be told.
        base_owner: Option<String>,
        /// The directories looked for.
        looked_in: Vec<PathBuf>,
    },
    /// The instance's daemon speaks another protocol schema than this program.
    #[error(
        "instance {instance:?} speaks protocol schema {daemon}, this program schema {ours}: update the older side \
         (docs/PROTOCOL.md, \"Changelog\", says what changed and how to migrate)"
    )]
    Schema {
        /// The instance.
        instance: String,
        /// The daemon's schema (its directory's `schema` file).
        daemon: u32,
        /// This program's.
        ours: u32,
    },
    /// Another vservod holds the instance.
    #[error(
        "instance {instance:?} is already run by vservod (pid {pid}); stop it first, or give this configuration another [instance] name"
    )]
    AlreadyRunning {
        /// The instance.
        instance: String,
        /// The running daemon's pid, as it wrote it (empty if not yet written).
        pid: String,
    },
    /// A directory or file is not safe to use: another user could change it.
    #[error("{path}: {reason}")]
    Unsafe {
        /// The path.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// A file operation failed.
    #[error("{path}: {what}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// What was being done.
        what: &'static str,
        /// The error.
        source: std::io::Error,
    },
    /// iceoryx2 refused the configuration or the node counter could not be prepared.
    #[error("iceoryx2 for instance {instance:?}: {reason}")]
    Iceoryx2 {
        /// The instance.
        instance: String,
        /// What went wrong.
        reason: String,
    },
}
