//! Where an instance lives, out of other users' reach (docs/PROTOCOL.md, "Where an instance lives").
//!
//! iceoryx2 keeps two kinds of resources: files under its root path (service descriptions, node
//! registrations, event sockets; `/tmp/iceoryx2/` by default, shared by every user) and POSIX shared-memory
//! objects in `/dev/shm` (one directory for the whole machine, writable by all). Each vservo instance
//! therefore lives in a base directory of the daemon's user (mode 0750 or 0700, `<base>/`), which holds
//! - `iceoryx2/`: iceoryx2's root path for the instances of that base (each under its own prefix);
//! - `<instance>/prefix`: the instance's shared-memory prefix, `vservo_<16 random hex digits>_`, which no
//!   other user can predict, so nobody can create a name the instance will need before it does;
//! - `<instance>/lock`: held by the running vservod (one daemon per instance), with its pid.
//!
//! The names stay short on purpose: iceoryx2's event sockets are `<base>/iceoryx2/<prefix><40-character
//! service hash>.event`, and a Unix socket's path has at most 107 bytes.
//!
//! Every shared-memory object iceoryx2 makes for the instance is the daemon's user's with mode 0600, except
//! one: iceoryx2's node counter, which it creates writable by every user. The daemon creates that segment
//! itself, owner-only, before iceoryx2 would ([`InstanceClaim`]), and refuses to run if any object of its
//! prefix is another user's or reachable by one. A prefix that meets such a file (another user created it
//! while the instance was stopped) is replaced by a fresh one.
//!
//! The base directory is `$VSERVO_RUNTIME_DIR` when set (the systemd unit sets `/run/vservo`), else
//! `/run/vservo` for root, else `$XDG_RUNTIME_DIR/vservo`, else `/tmp/vservo-<uid>`. A client looks in
//! `$VSERVO_RUNTIME_DIR` when set, else in `/run/vservo` and then in its own user's directory; it takes its
//! own user's instance wherever it finds one, and names another user only when no place holds one of its
//! user's (the system's `/run/vservo`, root's and closed to others, says nothing about a user's instance).

use std::fs::{File, OpenOptions};
use std::io::{ErrorKind, Read, Write};
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use iceoryx2::prelude::{Config, FileName, NodeBuilder, SignalHandlingMode, ipc};
use iceoryx2::prelude::{Path as IoxPath, SemanticString};

/// The environment variable naming the base directory of instances (the daemon passes it to its nodes).
pub const RUNTIME_DIR_ENV: &str = "VSERVO_RUNTIME_DIR";
/// The base directory of instances run by root or by the system service.
pub const SYSTEM_RUNTIME_DIR: &str = "/run/vservo";

/// The file in an instance's directory that holds the configuration its daemon runs.
pub const CONFIGURATION_FILE: &str = "config.toml";
/// The file in an instance's directory that says which protocol schema its daemon speaks
/// ([`crate::SCHEMA_VERSION`]); every client and driver checks it before it opens anything.
pub const SCHEMA_FILE: &str = "schema";
/// Where POSIX shared memory lives on Linux.
const SHM_DIR: &str = "/dev/shm";
/// The suffix iceoryx2 gives its node counter segment.
const NODE_COUNTER_SUFFIX: &str = ".global_mgmt";
/// The longest path of a Unix socket (`sun_path` less its terminating zero).
const SOCKET_PATH_MAX: usize = 107;
/// The random hex digits of a prefix (64 bits).
const PREFIX_HEX_DIGITS: usize = 16;

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

fn io(path: &Path, what: &'static str) -> impl FnOnce(std::io::Error) -> InstanceDirError + use<> {
    let path = path.to_path_buf();
    move |source| InstanceDirError::Io { path, what, source }
}

/// This process's effective user id.
fn effective_uid() -> u32 {
    nix::unistd::geteuid().as_raw()
}

/// The base directory a daemon of this user puts its instances in.
pub fn daemon_base() -> PathBuf {
    if let Some(dir) = std::env::var_os(RUNTIME_DIR_ENV).filter(|d| !d.is_empty()) {
        return PathBuf::from(dir);
    }
    if effective_uid() == 0 {
        return PathBuf::from(SYSTEM_RUNTIME_DIR);
    }
    user_base()
}

fn user_base() -> PathBuf {
    match std::env::var_os("XDG_RUNTIME_DIR").filter(|d| !d.is_empty()) {
        Some(dir) => PathBuf::from(dir).join("vservo"),
        None => PathBuf::from(format!("/tmp/vservo-{}", effective_uid())),
    }
}

/// A user's name from /etc/passwd, or `uid N`.
fn user_name(uid: u32) -> String {
    let passwd = std::fs::read_to_string("/etc/passwd").unwrap_or_default();
    passwd
        .lines()
        .find_map(|line| {
            let fields: Vec<&str> = line.split(':').collect();
            (fields.get(2) == Some(&uid.to_string().as_str())).then(|| fields[0].to_string())
        })
        .unwrap_or_else(|| format!("uid {uid}"))
}

/// Where a client or node looks for `instance`, in order: `$VSERVO_RUNTIME_DIR/<instance>` when set, else
/// `/run/vservo/<instance>` and, for a user other than root, the user's own base.
fn candidate_paths(instance: &str) -> Vec<PathBuf> {
    if let Some(base) = std::env::var_os(RUNTIME_DIR_ENV).filter(|d| !d.is_empty()) {
        return vec![PathBuf::from(base).join(instance)];
    }
    let mut bases = vec![PathBuf::from(SYSTEM_RUNTIME_DIR)];
    if effective_uid() != 0 {
        bases.push(user_base());
    }
    bases.into_iter().map(|base| base.join(instance)).collect()
}

/// What a client sees at one of the places an instance could be.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Sighting {
    /// Nothing there.
    Absent,
    /// The instance's directory, of this process's user.
    Ours(PathBuf),
    /// Another user's: the instance's directory, whose owner is the instance's.
    OtherUsers {
        /// The owner of `path`.
        owner_uid: u32,
        /// The instance's directory.
        path: PathBuf,
    },
    /// A base this user may not search: whether the instance is there, and whose it would be, is unknown.
    Closed {
        /// The base.
        base: PathBuf,
        /// Its owner, if it can be told (never taken for the instance's).
        base_owner: Option<u32>,
    },
}

impl Sighting {
    /// What is at `path` (`<base>/<instance>`).
    fn look(path: &Path) -> Self {
        match std::fs::symlink_metadata(path) {
            Ok(metadata) if metadata.uid() == effective_uid() => Sighting::Ours(path.to_path_buf()),
            Ok(metadata) => Sighting::OtherUsers { owner_uid: metadata.uid(), path: path.to_path_buf() },
            Err(e) if e.kind() == ErrorKind::PermissionDenied => {
                // the base directory is not ours to search: the instance may be there, of a user unknown
                let base = path.parent().unwrap_or(Path::new("/"));
                let base_owner = std::fs::metadata(base).map(|m| m.uid()).ok();
                Sighting::Closed { base: base.to_path_buf(), base_owner }
            }
            Err(_) => Sighting::Absent,
        }
    }

    /// Which place tells where the instance is: the first of this user's, wherever it is (the system's
    /// `/run/vservo` existing, another user's and closed to this one, says nothing about this user's
    /// instance); else the first of another user's (the instance really is that user's); else the first base
    /// closed to this user (the instance may be there); else none.
    fn decide(sightings: &[Sighting]) -> Option<&Sighting> {
        let first = |wanted: fn(&Sighting) -> bool| sightings.iter().find(|s| wanted(s));
        first(|s| matches!(s, Sighting::Ours(_)))
            .or_else(|| first(|s| matches!(s, Sighting::OtherUsers { .. })))
            .or_else(|| first(|s| matches!(s, Sighting::Closed { .. })))
    }
}

/// An instance's runtime directory and the prefix of its shared memory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InstanceDir {
    /// The instance.
    pub instance: String,
    /// `<base>/<instance>`.
    pub path: PathBuf,
    /// `<base>`.
    pub base: PathBuf,
    /// The instance's shared-memory prefix.
    pub prefix: String,
}

impl InstanceDir {
    /// Finds a running (or once run) instance as a client or node does: in `$VSERVO_RUNTIME_DIR` when set,
    /// else in `/run/vservo` and (for a user other than root) in the user's own base; an instance of this
    /// process's user wherever it is, another user's only when none is ours ([`Sighting::decide`]).
    pub fn locate(instance: &str) -> Result<Self, InstanceDirError> {
        let candidates = candidate_paths(instance);
        let sightings: Vec<Sighting> = candidates.iter().map(|path| Sighting::look(path)).collect();
        match Sighting::decide(&sightings) {
            Some(Sighting::Ours(path)) => Self::open_ours(instance, path),
            Some(Sighting::OtherUsers { owner_uid, path }) => Err(InstanceDirError::OtherUser {
                instance: instance.to_string(),
                owner: user_name(*owner_uid),
                path: path.clone(),
            }),
            Some(Sighting::Closed { base, base_owner }) => Err(InstanceDirError::Closed {
                instance: instance.to_string(),
                base: base.clone(),
                base_owner: base_owner.map(user_name),
                looked_in: candidates,
            }),
            Some(Sighting::Absent) | None => {
                Err(InstanceDirError::NotRunning { instance: instance.to_string(), looked_in: candidates })
            }
        }
    }

    /// The instance in `path`, a directory of this process's user: checked private, with its prefix.
    fn open_ours(instance: &str, path: &Path) -> Result<Self, InstanceDirError> {
        let metadata =
            std::fs::symlink_metadata(path).map_err(io(path, "reading the instance's directory"))?;
        check_private_dir(path, &metadata)?;
        let prefix_path = path.join("prefix");
        match std::fs::read_to_string(&prefix_path) {
            Ok(prefix) => {
                check_schema(instance, path)?;
                Ok(Self {
                    instance: instance.to_string(),
                    path: path.to_path_buf(),
                    base: path.parent().unwrap_or(Path::new("/")).to_path_buf(),
                    prefix: valid_prefix(prefix.trim(), &prefix_path)?,
                })
            }
            Err(e) if e.kind() == ErrorKind::NotFound => Err(InstanceDirError::NotRunning {
                instance: instance.to_string(),
                looked_in: vec![prefix_path],
            }),
            Err(e) => Err(io(&prefix_path, "reading the instance's prefix")(e)),
        }
    }

    /// [`InstanceDir::locate`], waiting up to `timeout` while no daemon has made the instance's directory
    /// yet (a driver started with or before vservod); any other refusal is at once.
    pub fn locate_waiting(instance: &str, timeout: std::time::Duration) -> Result<Self, InstanceDirError> {
        let until = std::time::Instant::now() + timeout;
        loop {
            match Self::locate(instance) {
                Err(InstanceDirError::NotRunning { .. }) if std::time::Instant::now() < until => {
                    std::thread::sleep(std::time::Duration::from_millis(20));
                }
                result => return result,
            }
        }
    }

    /// [`InstanceDir::locate`], waiting while no daemon has made the instance's directory, until `give_up()`
    /// says so (`Ok(None)` then); `waiting` is told why, once, when the wait begins (for the log).
    pub fn locate_until(
        instance: &str,
        mut give_up: impl FnMut() -> bool,
        waiting: impl FnOnce(&InstanceDirError),
    ) -> Result<Option<Self>, InstanceDirError> {
        let mut waiting = Some(waiting);
        loop {
            if give_up() {
                return Ok(None);
            }
            match Self::locate_waiting(instance, std::time::Duration::from_secs(1)) {
                Err(why @ InstanceDirError::NotRunning { .. }) => {
                    if let Some(tell) = waiting.take() {
                        tell(&why);
                    }
                }
                result => return result.map(Some),
            }
        }
    }

    /// The configuration the instance's daemon runs (resolved: every key it is run with), written by the
    /// daemon when it starts ([`InstanceClaim::write_configuration`]): how a client that found the instance
    /// by its name learns its arm and camera.
    pub fn configuration(&self) -> PathBuf {
        self.path.join(CONFIGURATION_FILE)
    }

    /// iceoryx2's root path for the instances of this base.
    pub fn iceoryx2_root(&self) -> PathBuf {
        self.base.join("iceoryx2")
    }

    /// The iceoryx2 configuration of the instance: the defaults with the instance's root path and prefix.
    pub fn iceoryx2_config(&self) -> Result<Config, InstanceDirError> {
        let refused = |what: &str, e: String| InstanceDirError::Iceoryx2 {
            instance: self.instance.clone(),
            reason: format!("{what}: {e}"),
        };
        let mut config = Config::default();
        config.global.prefix =
            FileName::new(self.prefix.as_bytes()).map_err(|e| refused("the prefix", format!("{e:?}")))?;
        let mut root = self.iceoryx2_root().display().to_string();
        root.push('/');
        config.global.set_root_path(
            &IoxPath::new(root.as_bytes()).map_err(|e| refused("the root path", format!("{e:?}")))?,
        );
        Ok(config)
    }
}

/// A prefix as the daemon writes it; anything else in the file is refused (it would name other files).
fn valid_prefix(prefix: &str, path: &Path) -> Result<String, InstanceDirError> {
    let random = prefix.strip_prefix("vservo_").and_then(|rest| rest.strip_suffix('_'));
    match random {
        Some(hex) if hex.len() == PREFIX_HEX_DIGITS && hex.bytes().all(|b| b.is_ascii_hexdigit()) => {
            Ok(prefix.to_string())
        }
        _ => Err(InstanceDirError::Unsafe {
            path: path.to_path_buf(),
            reason: format!(
                "{prefix:?} is not a prefix vservod writes (vservo_<{PREFIX_HEX_DIGITS} hex digits>_)"
            ),
        }),
    }
}

/// A directory of ours that nobody else may change: not a symbolic link, ours, writable by us only.
fn check_private_dir(path: &Path, metadata: &std::fs::Metadata) -> Result<(), InstanceDirError> {
    let unsafe_because = |reason: String| Err(InstanceDirError::Unsafe { path: path.to_path_buf(), reason });
    if !metadata.file_type().is_dir() {
        return unsafe_because("is not a directory (a symbolic link or a file is not trusted)".into());
    }
    if metadata.uid() != effective_uid() && metadata.uid() != 0 {
        return unsafe_because(format!(
            "belongs to user {}, not to this process's user",
            user_name(metadata.uid())
        ));
    }
    if metadata.mode() & 0o022 != 0 {
        return unsafe_because(format!(
            "mode {:o}: other users could change what is in it",
            metadata.mode() & 0o7777
        ));
    }
    Ok(())
}

/// Makes (or checks) a directory of ours with `mode`.
fn private_dir(path: &Path, mode: u32) -> Result<(), InstanceDirError> {
    match std::fs::DirBuilder::new().mode(mode).create(path) {
        Ok(()) => {
            // the umask may have taken bits away; set exactly what was meant
            std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
                .map_err(io(path, "setting the directory's mode"))?;
        }
        Err(e) if e.kind() == ErrorKind::AlreadyExists => {}
        Err(e) => return Err(io(path, "creating the directory")(e)),
    }
    let metadata = std::fs::symlink_metadata(path).map_err(io(path, "reading the directory"))?;
    check_private_dir(path, &metadata)?;
    // made earlier with more rights for others (an older vservo, a hand): take them back
    if metadata.uid() == effective_uid() && metadata.mode() & 0o777 & !mode != 0 {
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
            .map_err(io(path, "taking other users' rights away"))?;
    }
    Ok(())
}

/// The daemon's hold on its instance: the lock, the directory and the prefix of this run.
#[derive(Debug)]
pub struct InstanceClaim {
    dir: InstanceDir,
    /// Held while the daemon runs; the lock goes with the process.
    _lock: File,
    /// Why the prefix was replaced (another user's or an exposed file under the old one), if it was.
    pub renewed_because: Option<String>,
}

impl InstanceClaim {
    /// Claims `instance` in [`daemon_base`].
    pub fn claim(instance: &str) -> Result<Self, InstanceDirError> {
        Self::claim_in(&daemon_base(), instance)
    }

    /// Claims `instance` in `base`: makes the directories, takes the lock, keeps the prefix of the last run
    /// (so that drivers still running find the instance again) unless a file under it is another user's
    /// or reachable by one, and prepares iceoryx2's node counter owner-only.
    pub fn claim_in(base: &Path, instance: &str) -> Result<Self, InstanceDirError> {
        let root = base.join("iceoryx2");
        check_socket_room(instance, &root)?;
        private_dir(base, if base == Path::new(SYSTEM_RUNTIME_DIR) { 0o750 } else { 0o700 })?;
        private_dir(&root, 0o750)?;
        let path = base.join(instance);
        private_dir(&path, 0o750)?;
        let lock_path = path.join("lock");
        let mut lock = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .mode(0o640)
            .custom_flags(nix::libc::O_NOFOLLOW)
            .open(&lock_path)
            .map_err(io(&lock_path, "opening the instance's lock"))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut pid = String::new();
                let _ = lock.read_to_string(&mut pid);
                return Err(InstanceDirError::AlreadyRunning {
                    instance: instance.to_string(),
                    pid: pid.trim().to_string(),
                });
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(io(&lock_path, "locking the instance")(e)),
        }
        lock.set_len(0).map_err(io(&lock_path, "writing the daemon's pid"))?;
        writeln!(lock, "{}", std::process::id()).map_err(io(&lock_path, "writing the daemon's pid"))?;

        let prefix_path = path.join("prefix");
        let last = std::fs::read_to_string(&prefix_path)
            .ok()
            .and_then(|t| valid_prefix(t.trim(), &prefix_path).ok());
        let mut dir = InstanceDir {
            instance: instance.to_string(),
            path: path.clone(),
            base: base.to_path_buf(),
            prefix: String::new(),
        };
        let renewed_because = match last {
            Some(prefix) => {
                let reason = foreign_or_exposed(&prefix);
                dir.prefix = prefix;
                if reason.is_some() {
                    forget_prefix(&dir);
                    dir.prefix = new_prefix()?;
                }
                reason
            }
            None => {
                dir.prefix = new_prefix()?;
                None
            }
        };
        let renewed_because = match prepare_node_counter(&dir)? {
            CounterMade::Owner => renewed_because,
            CounterMade::ByAnother(name) => {
                // a client of the last run's prefix made it in the moment between the check and now (iceoryx2
                // makes it for every user to write): that prefix is done with; a new one no client can know
                // yet (it is written below)
                forget_prefix(&dir);
                dir.prefix = new_prefix()?;
                match prepare_node_counter(&dir)? {
                    CounterMade::Owner => {}
                    CounterMade::ByAnother(name) => {
                        return Err(InstanceDirError::Iceoryx2 {
                            instance: instance.to_string(),
                            reason: format!("{SHM_DIR}/{name} appeared under a prefix just drawn"),
                        });
                    }
                }
                Some(format!(
                    "{SHM_DIR}/{name} was made by a client of the last run's prefix as this daemon was starting"
                ))
            }
        };
        // the schema before the prefix: whoever finds the instance finds the schema it speaks
        write_file_atomically(&path.join(SCHEMA_FILE), format!("{}\n", crate::SCHEMA_VERSION).as_bytes())?;
        write_file_atomically(&prefix_path, format!("{}\n", dir.prefix).as_bytes())?;
        Ok(Self { dir, _lock: lock, renewed_because })
    }

    /// The instance's directory and prefix.
    pub fn dir(&self) -> &InstanceDir {
        &self.dir
    }

    /// The base directory, for the daemon's nodes ([`RUNTIME_DIR_ENV`]).
    pub fn base(&self) -> &Path {
        &self.dir.base
    }

    /// Writes the configuration the daemon runs into the instance's directory ([`InstanceDir::configuration`];
    /// readable by the instance's group only, as the directory is).
    pub fn write_configuration(&self, text: &str) -> Result<(), InstanceDirError> {
        write_file_atomically(&self.dir.configuration(), text.as_bytes())
    }

    /// Refuses if any shared-memory object of the instance is another user's or reachable by another user.
    pub fn check_private(&self) -> Result<(), InstanceDirError> {
        match foreign_or_exposed(&self.dir.prefix) {
            None => Ok(()),
            Some(reason) => Err(InstanceDirError::Unsafe { path: PathBuf::from(SHM_DIR), reason }),
        }
    }
}

/// A fresh prefix.
fn new_prefix() -> Result<String, InstanceDirError> {
    let urandom = Path::new("/dev/urandom");
    let mut bytes = [0u8; PREFIX_HEX_DIGITS / 2];
    File::open(urandom)
        .and_then(|mut f| f.read_exact(&mut bytes))
        .map_err(io(urandom, "drawing the instance's prefix"))?;
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    Ok(format!("vservo_{hex}_"))
}

/// Removes what is ours of a prefix given up: iceoryx2's registrations of its dead nodes, and our own
/// shared-memory objects under it (another user's stay where they are, unused).
fn forget_prefix(dir: &InstanceDir) {
    if let Ok(config) = dir.iceoryx2_config()
        && let Ok(node) = NodeBuilder::new()
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
    {
        let _ = node.try_cleanup_dead_nodes();
    }
    let own = effective_uid();
    for name in shm_names(&dir.prefix) {
        let path = Path::new(SHM_DIR).join(name);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.uid() == own) {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// Refuses a base whose path leaves no room for iceoryx2's event sockets.
fn check_socket_room(instance: &str, root: &Path) -> Result<(), InstanceDirError> {
    // `<root>/<prefix><40-character service hash><event suffix>`
    let suffix = Config::default().global.service.event_connection_suffix.to_string();
    let longest = root.as_os_str().len() + 1 + "vservo_".len() + PREFIX_HEX_DIGITS + 1 + 40 + suffix.len();
    if longest > SOCKET_PATH_MAX {
        return Err(InstanceDirError::Iceoryx2 {
            instance: instance.to_string(),
            reason: format!(
                "{}: the runtime directory's path is too long: iceoryx2's event sockets would need {longest} bytes, \
                 Unix sockets allow {SOCKET_PATH_MAX} (choose a shorter ${RUNTIME_DIR_ENV})",
                root.display()
            ),
        });
    }
    Ok(())
}

/// The first shared-memory object under `prefix` that another user owns or could open, described.
fn foreign_or_exposed(prefix: &str) -> Option<String> {
    let own = effective_uid();
    let entries = std::fs::read_dir(SHM_DIR).ok()?;
    entries.flatten().find_map(|entry| {
        let name = entry.file_name().to_string_lossy().to_string();
        if !name.starts_with(prefix) {
            return None;
        }
        let metadata = entry.metadata().ok()?;
        if metadata.uid() != own {
            Some(format!("{SHM_DIR}/{name} belongs to user {}", user_name(metadata.uid())))
        } else if metadata.mode() & 0o077 != 0 {
            Some(format!("{SHM_DIR}/{name} has mode {:o}: other users can open it", metadata.mode() & 0o7777))
        } else {
            None
        }
    })
}

/// Who made iceoryx2's node counter of an instance's prefix.
enum CounterMade {
    /// The daemon, owner-only (or it was there, ours and private, from the last run).
    Owner,
    /// Another process, since the daemon looked (its name in /dev/shm).
    ByAnother(String),
}

/// iceoryx2 creates its node counter segment for every user to write (mode 0666). The daemon makes it
/// first, owner-only: the name is learnt from a throwaway node under a second random prefix (whose
/// segment is removed at once), the content is iceoryx2's version word and a zero counter. A client that
/// read the last run's prefix may make it first, between the daemon's look and its making:
/// [`CounterMade::ByAnother`].
fn prepare_node_counter(dir: &InstanceDir) -> Result<CounterMade, InstanceDirError> {
    let refused = |reason: String| InstanceDirError::Iceoryx2 { instance: dir.instance.clone(), reason };
    let existing = shm_names(&dir.prefix).into_iter().find(|n| n.ends_with(NODE_COUNTER_SUFFIX));
    if existing.is_some() {
        return Ok(CounterMade::Owner); // ours and private: foreign_or_exposed said so
    }
    let scratch = InstanceDir { prefix: new_prefix()?, ..dir.clone() };
    let node = NodeBuilder::new()
        .config(&scratch.iceoryx2_config()?)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| refused(format!("a throwaway node to learn the node counter's name: {e:?}")));
    drop(node);
    let made = shm_names(&scratch.prefix);
    for name in &made {
        let _ = std::fs::remove_file(Path::new(SHM_DIR).join(name));
    }
    let [counter] = made.as_slice() else {
        return Err(refused(format!(
            "a new node made {} shared-memory objects ({made:?}), where iceoryx2 0.10 makes one node counter",
            made.len()
        )));
    };
    let Some(rest) = counter.strip_prefix(&scratch.prefix).filter(|r| r.ends_with(NODE_COUNTER_SUFFIX))
    else {
        return Err(refused(format!("{counter:?} is not iceoryx2 0.10's node counter")));
    };
    let path = Path::new(SHM_DIR).join(format!("{}{rest}", dir.prefix));
    // iceoryx2's dynamic storage: a u64 version word, then the data (a u32 counter), padded to 16 bytes
    let mut content = [0u8; 16];
    let version = iceoryx2_bb_elementary::package_version::PackageVersion::get().to_u64();
    content[..8].copy_from_slice(&version.to_ne_bytes());
    let opened = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .custom_flags(nix::libc::O_NOFOLLOW)
        .open(&path);
    let mut file = match opened {
        Ok(file) => file,
        Err(e) if e.kind() == ErrorKind::AlreadyExists => {
            return Ok(CounterMade::ByAnother(format!("{}{rest}", dir.prefix)));
        }
        Err(e) => return Err(io(&path, "creating iceoryx2's node counter owner-only")(e)),
    };
    file.write_all(&content).map_err(io(&path, "writing iceoryx2's node counter"))?;
    Ok(CounterMade::Owner)
}

/// The names in /dev/shm that start with `prefix`.
fn shm_names(prefix: &str) -> Vec<String> {
    std::fs::read_dir(SHM_DIR)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| e.file_name().to_string_lossy().to_string())
                .filter(|n| n.starts_with(prefix))
                .collect()
        })
        .unwrap_or_default()
}

/// Writes `path` through a temporary file and a rename: a reader sees the old content or the new, whole.
/// The schema the instance in `path` speaks is this program's: its `schema` file says so (a directory without one,
/// of a daemon from before the file, is taken as it is: its messages' own schema field still refuses a mismatch).
fn check_schema(instance: &str, path: &Path) -> Result<(), InstanceDirError> {
    let schema_path = path.join(SCHEMA_FILE);
    let text = match std::fs::read_to_string(&schema_path) {
        Ok(text) => text,
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io(&schema_path, "reading the instance's schema")(e)),
    };
    let daemon: u32 = text.trim().parse().map_err(|_| InstanceDirError::Unsafe {
        path: schema_path.clone(),
        reason: format!("{:?} is not a schema number", text.trim()),
    })?;
    if daemon != crate::SCHEMA_VERSION {
        return Err(InstanceDirError::Schema {
            instance: instance.to_string(),
            daemon,
            ours: crate::SCHEMA_VERSION,
        });
    }
    Ok(())
}

fn write_file_atomically(path: &Path, content: &[u8]) -> Result<(), InstanceDirError> {
    let temporary = path.with_extension("new");
    let _ = std::fs::remove_file(&temporary);
    let mut file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o640)
        .custom_flags(nix::libc::O_NOFOLLOW)
        .open(&temporary)
        .map_err(io(&temporary, "writing"))?;
    file.write_all(content).map_err(io(&temporary, "writing"))?;
    std::fs::rename(&temporary, path).map_err(io(path, "replacing"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_base(name: &str) -> PathBuf {
        // short: iceoryx2's sockets go below it
        let base = std::env::temp_dir().join(format!("vsv-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&base);
        base
    }

    fn remove_shm(prefix: &str) {
        for name in shm_names(prefix) {
            let _ = std::fs::remove_file(Path::new(SHM_DIR).join(name));
        }
    }

    #[test]
    fn a_claim_makes_private_directories_a_secret_prefix_and_an_owner_only_node_counter() {
        let base = scratch_base("claim");
        let instance = format!("unit-claim-{}", std::process::id());
        let claim = InstanceClaim::claim_in(&base, &instance).expect("claimed");
        let dir = claim.dir().clone();
        assert!(dir.prefix.starts_with("vservo_"), "{}", dir.prefix);
        let mode = |p: &Path| std::fs::symlink_metadata(p).expect("exists").mode() & 0o777;
        assert_eq!(mode(&base), 0o700);
        assert_eq!(mode(&dir.path), 0o750);
        assert_eq!(mode(&dir.iceoryx2_root()), 0o750);
        // a node of the instance uses the counter made owner-only, and makes nothing reachable by others
        let node = NodeBuilder::new()
            .config(&dir.iceoryx2_config().expect("config"))
            .create::<ipc::Service>()
            .expect("a node");
        let names = shm_names(&dir.prefix);
        assert_eq!(names.iter().filter(|n| n.ends_with(NODE_COUNTER_SUFFIX)).count(), 1, "{names:?}");
        for name in &names {
            assert_eq!(mode(&Path::new(SHM_DIR).join(name)) & 0o077, 0, "{name}");
        }
        claim.check_private().expect("private");
        // a second daemon is refused while the first holds the lock
        let second = InstanceClaim::claim_in(&base, &instance).expect_err("locked");
        assert!(matches!(second, InstanceDirError::AlreadyRunning { .. }), "{second}");
        drop(node);
        drop(claim);
        // the next run keeps the prefix (drivers still running find the instance again)
        let again = InstanceClaim::claim_in(&base, &instance).expect("claimed again");
        assert_eq!(again.dir().prefix, dir.prefix);
        assert!(again.renewed_because.is_none());
        remove_shm(&dir.prefix);
        let _ = std::fs::remove_dir_all(&base);
    }

    /// The daemon says which schema it speaks; a client of another finds out in one sentence naming both.
    #[test]
    fn an_instance_of_another_schema_is_refused_naming_both() {
        let base = scratch_base("schema");
        let instance = format!("unit-schema-{}", std::process::id());
        let claim = InstanceClaim::claim_in(&base, &instance).expect("claimed");
        let path = claim.dir().path.clone();
        let written = std::fs::read_to_string(path.join(SCHEMA_FILE)).expect("the schema file");
        assert_eq!(written.trim(), crate::SCHEMA_VERSION.to_string());
        InstanceDir::open_ours(&instance, &path).expect("the same schema is found");
        write_file_atomically(&path.join(SCHEMA_FILE), format!("{}\n", crate::SCHEMA_VERSION - 1).as_bytes())
            .expect("rewritten");
        let refused = InstanceDir::open_ours(&instance, &path).expect_err("another schema");
        let text = refused.to_string();
        assert!(
            text.contains(&format!("speaks protocol schema {}", crate::SCHEMA_VERSION - 1))
                && text.contains(&format!("this program schema {}", crate::SCHEMA_VERSION))
                && text.contains("Changelog"),
            "{text}"
        );
        let prefix = claim.dir().prefix.clone();
        drop(claim);
        remove_shm(&prefix);
        let _ = std::fs::remove_dir_all(&base);
    }

    #[test]
    fn a_prefix_under_which_a_file_is_exposed_is_replaced() {
        let base = scratch_base("exposed");
        let instance = format!("unit-exposed-{}", std::process::id());
        let first = InstanceClaim::claim_in(&base, &instance).expect("claimed").dir().clone();
        // as another user would: a name of the instance's prefix, open to all
        let planted = Path::new(SHM_DIR).join(format!("{}planted.dynamic", first.prefix));
        std::fs::write(&planted, b"garbage").expect("planted");
        std::fs::set_permissions(&planted, std::fs::Permissions::from_mode(0o666)).expect("mode");
        let second = InstanceClaim::claim_in(&base, &instance).expect("claimed with a new prefix");
        assert_ne!(second.dir().prefix, first.prefix);
        let reason = second.renewed_because.clone().expect("a reason");
        assert!(reason.contains("planted.dynamic") && reason.contains("666"), "{reason}");
        remove_shm(&first.prefix);
        remove_shm(&second.dir().prefix);
        let _ = std::fs::remove_dir_all(&base);
    }

    #[test]
    fn a_base_too_long_for_unix_sockets_is_refused() {
        let base = std::env::temp_dir().join("v".repeat(60));
        let refused = InstanceClaim::claim_in(&base, "long").expect_err("refused");
        assert!(refused.to_string().contains("too long"), "{refused}");
        let _ = std::fs::remove_dir_all(&base);
    }

    #[test]
    fn a_client_takes_its_own_users_instance_wherever_it_is() {
        let system_closed = Sighting::Closed { base: PathBuf::from(SYSTEM_RUNTIME_DIR), base_owner: Some(0) };
        let own = Sighting::Ours(PathBuf::from("/tmp/vservo-65534/x"));
        // the system's /run/vservo exists (root's, closed to this user) and the user's daemon runs in /tmp
        assert_eq!(Sighting::decide(&[system_closed.clone(), own.clone()]), Some(&own));
        // the user's own instance under /run/vservo (the system service's user) comes first
        let own_system = Sighting::Ours(PathBuf::from("/run/vservo/x"));
        assert_eq!(Sighting::decide(&[own_system.clone(), own.clone()]), Some(&own_system));
        assert_eq!(Sighting::decide(&[Sighting::Absent, own.clone()]), Some(&own));
    }

    #[test]
    fn another_user_is_named_only_when_the_instance_is_none_of_ours() {
        let system_closed = Sighting::Closed { base: PathBuf::from(SYSTEM_RUNTIME_DIR), base_owner: Some(0) };
        assert_eq!(Sighting::decide(&[system_closed.clone(), Sighting::Absent]), Some(&system_closed));
        let others = Sighting::OtherUsers { owner_uid: 999, path: PathBuf::from("/run/vservo/x") };
        assert_eq!(Sighting::decide(&[others.clone(), Sighting::Absent]), Some(&others));
        // an instance seen to be another user's tells more than a closed base that may hold one
        assert_eq!(Sighting::decide(&[system_closed.clone(), others.clone()]), Some(&others));
        assert_eq!(Sighting::decide(&[Sighting::Absent, Sighting::Absent]), None);
        assert_eq!(Sighting::decide(&[]), None);
    }

    #[test]
    fn a_closed_base_names_no_owner_for_the_instance() {
        let closed = |base_owner: Option<&str>| InstanceDirError::Closed {
            instance: "x".to_string(),
            base: PathBuf::from(SYSTEM_RUNTIME_DIR),
            base_owner: base_owner.map(str::to_string),
            looked_in: vec![PathBuf::from("/run/vservo/x"), PathBuf::from("/tmp/vservo-1000/x")],
        };
        for text in [closed(Some("root")).to_string(), closed(None).to_string()] {
            assert!(!text.contains("is run by user"), "{text}");
            assert!(
                text.contains("/run/vservo is closed to this user") && text.contains("/tmp/vservo-1000/x")
            );
        }
        assert!(closed(Some("root")).to_string().contains("the directory is user \"root\"'s"));
        assert!(closed(None).to_string().contains("whose it is cannot be told"));
    }

    #[test]
    fn a_prefix_file_naming_other_files_is_refused() {
        let path = Path::new("/x/prefix");
        assert!(valid_prefix("vservo_0123456789abcdef_", path).is_ok());
        for bad in
            ["vservo_0123456789abcdeg_", "vservo_../../etc/passwd_", "", "vservo__", "iox2_0123456789abcdef_"]
        {
            assert!(valid_prefix(bad, path).is_err(), "{bad}");
        }
    }
}
