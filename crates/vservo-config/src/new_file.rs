//! Files vservo writes where others may plant one (a shared folder): recordings, calibration output and board
//! drawings, and a configuration the calibration edits. What is at the name already is refused, naming it — a symbolic link (never followed, never
//! replaced), another user's file, or anything but a regular file — and so is the user's own file unless
//! `--force` is given. The file is made new beside the name (`O_CREAT | O_EXCL | O_NOFOLLOW`, mode 0600 unless
//! said), written, flushed and then moved to the name: a file that does not finish leaves nothing behind, and
//! what another user plants at the name meanwhile is replaced, never written through (in a sticky folder the
//! system refuses the move over another user's file). A folder vservo writes its files into ([`folder`]) is made
//! new, or must already be the user's own folder — not a link to one, not another user's.

use std::fs::{File, OpenOptions};
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// Why a name cannot be written.
#[derive(Debug, thiserror::Error)]
pub enum NameRefused {
    /// A symbolic link is at the name.
    #[error("{0} is a symbolic link: vservo neither writes through one nor replaces it; choose another name")]
    Link(PathBuf),
    /// Another user's file is at the name.
    #[error(
        "{path} is user {owner}'s file: vservo does not replace another user's file; choose another name"
    )]
    OtherUsers {
        /// The name.
        path: PathBuf,
        /// Its owner (a name, or `uid N`).
        owner: String,
    },
    /// Something that is not a regular file is at the name.
    #[error("{0} is not a regular file; choose another name")]
    NotAFile(PathBuf),
    /// The user's own file is at the name.
    #[error("{0} exists: --force replaces it")]
    Exists(PathBuf),
    /// The folder named is a symbolic link.
    #[error(
        "{0} is a symbolic link: vservo writes only into a folder of the user's own; choose another folder"
    )]
    FolderLink(PathBuf),
    /// The folder named is another user's.
    #[error(
        "{path} is user {owner}'s folder: vservo writes only into a folder of the user's own; choose another"
    )]
    OtherUsersFolder {
        /// The folder.
        path: PathBuf,
        /// Its owner (a name, or `uid N`).
        owner: String,
    },
    /// Something that is not a folder is at the name.
    #[error("{0} is not a folder; choose another name")]
    NotAFolder(PathBuf),
}

/// Why a new file could not be written: its name refused, or the system's error doing it.
#[derive(Debug, thiserror::Error)]
pub enum NewFileError {
    /// What is at the name may not be replaced.
    #[error(transparent)]
    Refused(#[from] NameRefused),
    /// Looking at, making, writing or moving the file failed.
    #[error("{what} {}: {source}", path.display())]
    Io {
        /// What was being done (`looking at`, `creating`, `writing`, `moving the file to`).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
}

impl NewFileError {
    fn io(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Io { what, path, source }
    }
}

/// Checks, before any work, that `path` may be written: nothing there, or with `force` the user's own regular
/// file.
pub fn check(path: &Path, force: bool) -> Result<(), NewFileError> {
    let metadata = match std::fs::symlink_metadata(path) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(NewFileError::io("looking at", path)(e)),
    };
    let refused = if metadata.file_type().is_symlink() {
        NameRefused::Link(path.to_path_buf())
    } else if metadata.uid() != nix::unistd::geteuid().as_raw() {
        NameRefused::OtherUsers { path: path.to_path_buf(), owner: user_name(metadata.uid()) }
    } else if !metadata.file_type().is_file() {
        NameRefused::NotAFile(path.to_path_buf())
    } else if force {
        return Ok(());
    } else {
        NameRefused::Exists(path.to_path_buf())
    };
    Err(refused.into())
}

fn user_name(uid: u32) -> String {
    match nix::unistd::User::from_uid(nix::unistd::Uid::from_raw(uid)) {
        Ok(Some(user)) => format!("{:?}", user.name),
        _ => format!("uid {uid}"),
    }
}

/// A file being written beside its name, moved there by [`NewFile::publish`]; removed if never published.
pub struct NewFile {
    partial: PathBuf,
    target: PathBuf,
    force: bool,
    published: bool,
}

impl NewFile {
    /// Checks `path` ([`check`]) and makes the file beside it, mode `mode`.
    pub fn create(path: &Path, force: bool, mode: u32) -> Result<(File, NewFile), NewFileError> {
        check(path, force)?;
        let name = path.file_name().ok_or_else(|| NameRefused::NotAFile(path.to_path_buf()))?;
        let partial =
            path.with_file_name(format!(".{}.{}.partial", name.to_string_lossy(), std::process::id()));
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(mode)
            .custom_flags(nix::libc::O_NOFOLLOW)
            .open(&partial)
            .map_err(NewFileError::io("creating", &partial))?;
        Ok((file, NewFile { partial, target: path.to_path_buf(), force, published: false }))
    }

    /// Flushes `file` to disk and moves it to its name (checked again: what appeared there meanwhile is
    /// refused as before).
    pub fn publish(mut self, file: File) -> Result<(), NewFileError> {
        file.sync_all().map_err(NewFileError::io("writing", &self.partial))?;
        check(&self.target, self.force)?;
        std::fs::rename(&self.partial, &self.target)
            .map_err(NewFileError::io("moving the file to", &self.target))?;
        self.published = true;
        Ok(())
    }
}

impl Drop for NewFile {
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

/// The folder `path`, for files of the user's: made new (mode 0755, its parents as `mkdir -p` makes them), or
/// already the user's own folder ([`check_folder`]). Write into it with [`write`] and `force` (the user's own files
/// at the names are replaced; links and other users' files there are still refused).
pub fn folder(path: &Path) -> Result<(), NewFileError> {
    if check_folder(path)? {
        return Ok(());
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(NewFileError::io("making", parent))?;
    }
    // a name taken meanwhile (a link planted after the check) is refused by the system: nothing is followed
    std::fs::create_dir(path).map_err(NewFileError::io("making", path))
}

/// Checks, before any work, that `path` may be a folder of the user's files: `false` if nothing is there (it
/// will be made), `true` if it is the user's own folder. A symbolic link at the name (to a folder or not),
/// another user's folder, or anything else is refused, naming it.
pub fn check_folder(path: &Path) -> Result<bool, NewFileError> {
    let metadata = match std::fs::symlink_metadata(path) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(false),
        Err(e) => return Err(NewFileError::io("looking at", path)(e)),
    };
    let refused = if metadata.file_type().is_symlink() {
        NameRefused::FolderLink(path.into())
    } else if !metadata.is_dir() {
        NameRefused::NotAFolder(path.into())
    } else if metadata.uid() != nix::unistd::geteuid().as_raw() {
        NameRefused::OtherUsersFolder { path: path.into(), owner: user_name(metadata.uid()) }
    } else {
        return Ok(true);
    };
    Err(refused.into())
}

/// Whether a new file can be made beside `path` (in its folder), as [`NewFile`] will make one: a probe file is made
/// and removed. For a check before any work.
pub fn can_make_beside(path: &Path) -> Result<(), NewFileError> {
    let name = path.file_name().map_or("file".into(), |n| n.to_string_lossy());
    let probe = path.with_file_name(format!(".{name}.{}.probe", std::process::id()));
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .custom_flags(nix::libc::O_NOFOLLOW)
        .open(&probe)
        .map_err(NewFileError::io("making a file beside", path))?;
    std::fs::remove_file(&probe).map_err(NewFileError::io("removing", &probe))
}

/// Writes `bytes` to `path` as a new file of mode `mode` ([`NewFile`]).
pub fn write(path: &Path, bytes: &[u8], force: bool, mode: u32) -> Result<(), NewFileError> {
    use std::io::Write;
    let (mut file, new) = NewFile::create(path, force, mode)?;
    file.write_all(bytes).map_err(NewFileError::io("writing", path))?;
    new.publish(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("vservoctl-new-file-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("a folder");
        dir
    }

    #[test]
    fn a_new_name_is_written_and_an_own_file_replaced_only_with_force() {
        let dir = folder("own");
        let path = dir.join("out.txt");
        write(&path, b"first", false, 0o600).expect("a new name");
        assert_eq!(std::fs::read(&path).expect("read"), b"first");
        assert_eq!(std::fs::metadata(&path).expect("metadata").mode() & 0o777, 0o600);
        let refused = write(&path, b"second", false, 0o600).expect_err("exists");
        assert!(refused.to_string().contains("--force"), "{refused}");
        assert_eq!(std::fs::read(&path).expect("read"), b"first", "unchanged");
        write(&path, b"second", true, 0o644).expect("replaced with --force");
        assert_eq!(std::fs::read(&path).expect("read"), b"second");
        assert_eq!(std::fs::read_dir(&dir).expect("the folder").count(), 1, "nothing left beside it");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_link_or_a_folder_at_the_name_is_refused_even_with_force() {
        let dir = folder("link");
        let victim = dir.join("victim.txt");
        std::fs::write(&victim, b"precious").expect("the victim");
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink(&victim, &link).expect("a link");
        let refused = write(&link, b"bad", true, 0o600).expect_err("a link");
        assert!(refused.to_string().contains("symbolic link"), "{refused}");
        assert_eq!(std::fs::read(&victim).expect("read"), b"precious");
        assert!(std::fs::symlink_metadata(&link).expect("still there").file_type().is_symlink());
        let refused = write(&dir, b"bad", true, 0o600).expect_err("a folder");
        assert!(refused.to_string().contains("not a regular file"), "{refused}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_folder_is_made_new_or_must_be_the_users_own_and_no_link() {
        let dir = folder("folders");
        let made = dir.join("a/b/out");
        super::folder(&made).expect("made, with its parents");
        assert!(made.is_dir());
        super::folder(&made).expect("the user's own: taken again");
        let link = dir.join("linked");
        std::os::unix::fs::symlink(&made, &link).expect("a link");
        let refused = super::folder(&link).expect_err("a link to a folder");
        assert!(refused.to_string().contains("symbolic link"), "{refused}");
        let file = dir.join("file");
        std::fs::write(&file, b"x").expect("a file");
        assert!(super::folder(&file).expect_err("a file").to_string().contains("not a folder"));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
