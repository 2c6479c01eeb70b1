//! The safe-stop path: a FIFO `safe_stop` in the instance's directory (docs/PROTOCOL.md, "The safe-stop
//! path"), a way to ask for a safe stop that no client can exhaust.
//!
//! The `command` service has 16 client slots; a process holding all of them blocks every command. The
//! FIFO has no slots: vservod makes it when it starts (a stale one replaced), owner-only (mode 0600, as the
//! instance's shared memory is: exactly the daemon's user may send commands, and may write it), keeps its
//! read end open and drains it without blocking every supervisor cycle ([`SafeStopReader`]). Any byte is a
//! request for a safe stop. A writer opens it with `O_NONBLOCK` ([`ask_for_safe_stop`]): with no reader
//! (no vservod runs the instance) the open fails at once (`ENXIO`); a pipe full of bytes not yet read is a
//! request already pending. A flood of bytes can only keep the cell in a safe stop, which is safe.

use std::fs::{File, OpenOptions};
use std::io::{ErrorKind, Read, Write};
use std::os::unix::fs::{FileTypeExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use crate::instance_dir::{InstanceDir, InstanceDirError};

/// The FIFO's name in the instance's directory.
pub const SAFE_STOP_FILE: &str = "safe_stop";
/// Its mode: the daemon's user only, who alone may send commands (the instance's shared memory is 0600).
pub const SAFE_STOP_MODE: u32 = 0o600;
/// The most bytes one drain takes (the rest wait for the next cycle; every byte asks the same).
const DRAIN_MAX_BYTES: usize = 64 * 1024;

impl InstanceDir {
    /// The instance's safe-stop FIFO.
    pub fn safe_stop_path(&self) -> PathBuf {
        self.path.join(SAFE_STOP_FILE)
    }
}

/// The daemon's read end of the safe-stop FIFO.
#[derive(Debug)]
pub struct SafeStopReader {
    file: File,
    path: PathBuf,
    /// The FIFO's device and inode: what is at the path must be it.
    identity: (u64, u64),
}

impl SafeStopReader {
    /// Makes the FIFO in `dir` (whatever was at its path before is replaced: a stale FIFO of an earlier run,
    /// or anything else) owner-only, and opens its read end without blocking.
    pub fn create(dir: &InstanceDir) -> Result<Self, InstanceDirError> {
        Self::create_at(&dir.safe_stop_path())
    }

    /// [`SafeStopReader::create`] at `path`.
    pub fn create_at(path: &Path) -> Result<Self, InstanceDirError> {
        let io = |what: &'static str| {
            let path = path.to_path_buf();
            move |source| InstanceDirError::Io { path, what, source }
        };
        match std::fs::remove_file(path) {
            Ok(()) => {}
            Err(e) if e.kind() == ErrorKind::NotFound => {}
            Err(e) => return Err(io("removing the stale safe-stop FIFO")(e)),
        }
        let mode = nix::sys::stat::Mode::from_bits_truncate(SAFE_STOP_MODE);
        nix::unistd::mkfifo(path, mode)
            .map_err(|errno| io("making the safe-stop FIFO")(std::io::Error::from(errno)))?;
        // the umask may have taken bits away; set exactly what is meant
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(SAFE_STOP_MODE))
            .map_err(io("setting the safe-stop FIFO's mode"))?;
        let file = OpenOptions::new()
            .read(true)
            .custom_flags(nix::libc::O_NONBLOCK | nix::libc::O_NOFOLLOW)
            .open(path)
            .map_err(io("opening the safe-stop FIFO"))?;
        let metadata = file.metadata().map_err(io("checking the safe-stop FIFO"))?;
        if !metadata.file_type().is_fifo() || metadata.uid() != nix::unistd::geteuid().as_raw() {
            return Err(InstanceDirError::Unsafe {
                path: path.to_path_buf(),
                reason: "is not the FIFO this daemon made".into(),
            });
        }
        Ok(Self { file, path: path.to_path_buf(), identity: (metadata.dev(), metadata.ino()) })
    }

    /// Whether the path is still this reader's FIFO: a process of the daemon's user may replace it (with a
    /// plain file, say, which swallows every request); the daemon then stops the cell and makes it again
    /// ([`SafeStopReader::remake`]).
    pub fn intact(&self) -> bool {
        std::fs::symlink_metadata(&self.path)
            .is_ok_and(|m| m.file_type().is_fifo() && (m.dev(), m.ino()) == self.identity)
    }

    /// Makes the FIFO again at its path, whatever is there now.
    pub fn remake(&mut self) -> Result<(), InstanceDirError> {
        *self = Self::create_at(&self.path)?;
        Ok(())
    }

    /// The FIFO's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Takes the bytes written since the last call, without blocking: how many (each a request for a safe
    /// stop; 0: none). At most 64 KiB a call; a read error counts as none (the FIFO stays open).
    pub fn drain(&mut self) -> usize {
        let mut buffer = [0u8; 4096];
        let mut taken = 0;
        while taken < DRAIN_MAX_BYTES {
            match self.file.read(&mut buffer) {
                // no writer has it open, or all it wrote was taken
                Ok(0) => break,
                Ok(n) => taken += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                // WouldBlock: a writer has it open, nothing more to read now
                Err(_) => break,
            }
        }
        taken
    }
}

/// How a request on the safe-stop path went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Asked {
    /// The byte was written: the daemon takes it within a supervisor cycle.
    Now,
    /// The FIFO is full of requests not yet taken: this one is among them.
    AlreadyPending,
}

/// Why a safe stop could not be asked for on the safe-stop path.
#[derive(Debug, thiserror::Error)]
pub enum SafeStopPathError {
    /// The FIFO is there but nobody reads it: no vservod runs the instance.
    #[error("{path}: no vservod reads the safe-stop path: the instance is not running")]
    NoDaemon {
        /// The FIFO.
        path: PathBuf,
    },
    /// There is no FIFO: no vservod of this version has run the instance.
    #[error(
        "{path}: no safe-stop path: no vservod (of a version that makes it) runs the instance, or it runs as another user"
    )]
    Missing {
        /// Where it was looked for.
        path: PathBuf,
    },
    /// Something else is at its path.
    #[error("{path}: not a FIFO: not the safe-stop path vservod makes")]
    NotAFifo {
        /// The path.
        path: PathBuf,
    },
    /// Opening or writing failed otherwise.
    #[error("{path}: {what}: {source}")]
    Io {
        /// The FIFO.
        path: PathBuf,
        /// What was being done.
        what: &'static str,
        /// The error.
        source: std::io::Error,
    },
}

/// What opening the FIFO for writing came to: an error's meaning for the one who asks.
fn open_refused(path: &Path, error: std::io::Error) -> SafeStopPathError {
    let path = path.to_path_buf();
    match error.raw_os_error() {
        // O_NONBLOCK and no reader
        Some(nix::libc::ENXIO) => SafeStopPathError::NoDaemon { path },
        Some(nix::libc::ENOENT) => SafeStopPathError::Missing { path },
        // O_NOFOLLOW on a symbolic link
        Some(nix::libc::ELOOP) => SafeStopPathError::NotAFifo { path },
        _ => SafeStopPathError::Io { path, what: "opening the safe-stop FIFO", source: error },
    }
}

/// What writing the byte came to.
fn write_outcome(path: &Path, written: std::io::Result<usize>) -> Result<Asked, SafeStopPathError> {
    match written {
        Ok(0) => Err(SafeStopPathError::Io {
            path: path.to_path_buf(),
            what: "writing the request",
            source: std::io::Error::from(ErrorKind::WriteZero),
        }),
        Ok(_) => Ok(Asked::Now),
        // full of bytes not yet read: requests are pending
        Err(e) if e.kind() == ErrorKind::WouldBlock => Ok(Asked::AlreadyPending),
        // the reader went away between the open and the write
        Err(e) if e.raw_os_error() == Some(nix::libc::EPIPE) => {
            Err(SafeStopPathError::NoDaemon { path: path.to_path_buf() })
        }
        Err(source) => {
            Err(SafeStopPathError::Io { path: path.to_path_buf(), what: "writing the request", source })
        }
    }
}

/// Asks the instance's daemon for a safe stop on the safe-stop path: one byte, written without blocking.
pub fn ask_for_safe_stop(dir: &InstanceDir) -> Result<Asked, SafeStopPathError> {
    ask_at(&dir.safe_stop_path())
}

/// [`ask_for_safe_stop`] on the FIFO at `path`.
pub fn ask_at(path: &Path) -> Result<Asked, SafeStopPathError> {
    let mut file = OpenOptions::new()
        .write(true)
        .custom_flags(nix::libc::O_NONBLOCK | nix::libc::O_NOFOLLOW)
        .open(path)
        .map_err(|e| open_refused(path, e))?;
    let is_fifo = file.metadata().is_ok_and(|m| m.file_type().is_fifo());
    if !is_fifo {
        return Err(SafeStopPathError::NotAFifo { path: path.to_path_buf() });
    }
    write_outcome(path, file.write(b"!"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vsv-stop-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch directory");
        dir.join(SAFE_STOP_FILE)
    }

    #[test]
    fn a_byte_written_is_one_request_taken_without_blocking() {
        let path = scratch("byte");
        let mut reader = SafeStopReader::create_at(&path).expect("made");
        let mode = std::fs::symlink_metadata(&path).expect("there").mode();
        assert_eq!(mode & 0o777, SAFE_STOP_MODE, "owner-only");
        assert_eq!(reader.drain(), 0, "nothing asked yet: no block, no request");
        assert_eq!(ask_at(&path).expect("asked"), Asked::Now);
        assert_eq!(ask_at(&path).expect("asked"), Asked::Now);
        assert_eq!(reader.drain(), 2);
        assert_eq!(reader.drain(), 0, "taken once");
        let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
    }

    #[test]
    fn with_no_reader_the_writer_is_told_at_once_that_no_daemon_runs() {
        let path = scratch("noreader");
        assert!(matches!(ask_at(&path), Err(SafeStopPathError::Missing { .. })));
        let reader = SafeStopReader::create_at(&path).expect("made");
        drop(reader);
        let started = std::time::Instant::now();
        let refused = ask_at(&path).expect_err("no reader");
        assert!(matches!(refused, SafeStopPathError::NoDaemon { .. }), "{refused}");
        assert!(refused.to_string().contains("not running"), "{refused}");
        assert!(started.elapsed() < std::time::Duration::from_secs(1));
        std::fs::remove_file(&path).expect("removed");
        std::fs::write(&path, b"x").expect("a plain file");
        assert!(matches!(ask_at(&path), Err(SafeStopPathError::NotAFifo { .. })));
        let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
    }

    #[test]
    fn a_stale_fifo_or_file_is_replaced_and_a_flood_only_keeps_requests_pending() {
        let path = scratch("flood");
        std::fs::write(&path, b"stale").expect("a stale file");
        let mut reader = SafeStopReader::create_at(&path).expect("replaced");
        assert!(std::fs::symlink_metadata(&path).expect("there").file_type().is_fifo());
        // fill the pipe: every write after it is full says the request is pending, none blocks
        let mut outcomes = Vec::new();
        for _ in 0..70_000 {
            outcomes.push(ask_at(&path).expect("asked"));
        }
        assert!(outcomes.contains(&Asked::AlreadyPending), "the pipe fills");
        let mut taken = 0;
        loop {
            let n = reader.drain();
            assert!(n <= DRAIN_MAX_BYTES, "bounded per drain");
            if n == 0 {
                break;
            }
            taken += n;
        }
        assert_eq!(taken, outcomes.iter().filter(|o| **o == Asked::Now).count());
        let _ = std::fs::remove_dir_all(path.parent().expect("dir"));
    }

    #[test]
    fn the_write_outcomes_mean_what_they_say() {
        let path = Path::new("/x/safe_stop");
        assert_eq!(write_outcome(path, Ok(1)).expect("ok"), Asked::Now);
        assert_eq!(
            write_outcome(path, Err(std::io::Error::from(ErrorKind::WouldBlock))).expect("pending"),
            Asked::AlreadyPending
        );
        let broken = std::io::Error::from_raw_os_error(nix::libc::EPIPE);
        assert!(matches!(write_outcome(path, Err(broken)), Err(SafeStopPathError::NoDaemon { .. })));
        let no_reader = std::io::Error::from_raw_os_error(nix::libc::ENXIO);
        assert!(matches!(open_refused(path, no_reader), SafeStopPathError::NoDaemon { .. }));
    }
}
