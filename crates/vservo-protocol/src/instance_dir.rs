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
use shared_memory::{CounterMade, SHM_DIR, foreign_or_exposed, forget_prefix, prepare_node_counter};

mod error;
mod shared_memory;

pub use error::InstanceDirError;

/// The environment variable naming the base directory of instances (the daemon passes it to its nodes).
pub const RUNTIME_DIR_ENV: &str = "VSERVO_RUNTIME_DIR";
/// The base directory of instances run by root or by the system service.
pub const SYSTEM_RUNTIME_DIR: &str = "/run/vservo";

/// The file in an instance's directory that holds the configuration its daemon runs.
pub const CONFIGURATION_FILE: &str = "config.toml";
/// The file in an instance's directory that says which protocol schema its daemon speaks
/// ([`crate::SCHEMA_VERSION`]); every client and driver checks it before it opens anything.
pub const SCHEMA_FILE: &str = "schema";
/// The longest path of a Unix socket (`sun_path` less its terminating zero).
const SOCKET_PATH_MAX: usize = 107;
/// The random hex digits of a prefix (64 bits).
const PREFIX_HEX_DIGITS: usize = 16;

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

    /// Writes the configuration the daemon runs, as [`InstanceClaim::write_configuration`] does; the daemon
    /// writes it again after a reload (a reader sees the old text or the new, whole).
    pub fn write_configuration(&self, text: &str) -> Result<(), InstanceDirError> {
        write_file_atomically(&self.configuration(), text.as_bytes())
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
        self.dir.write_configuration(text)
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

/// Writes `path` through a temporary file and a rename: a reader sees the old content or the new, whole.
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
mod tests;
