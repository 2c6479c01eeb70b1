//! A configuration file edited in place, as `vservoctl calibrate --apply` and `vservoctl teach` edit it: checked
//! to be editable before anything moves (a TOML file of the user's own, readable, writable, in a folder where
//! the edited file can be made); the edit made on the text with `toml_edit`, so every other key, comment and
//! layout stays; the configuration as it will be loaded and validated from a file beside the real one (so that
//! `extends` and relative paths resolve as they will) before anything is written; the file as it was kept
//! beside it (`<name>.<suffix>`); the new text written as a new file moved over the name ([`crate::new_file`]).

use std::path::{Path, PathBuf};

use crate::{Config, ConfigError, new_file};

/// Why an edit was refused or failed.
#[derive(Debug, thiserror::Error)]
pub enum EditError {
    /// The file cannot be edited as it stands (read-only, not TOML, a name that may not be written): the
    /// user's to act on; nothing was changed.
    #[error("{0}")]
    Refused(String),
    /// The file could not be read.
    #[error("{what} {}: {source}", path.display())]
    File {
        /// What was being done.
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
    /// The edited configuration does not load.
    #[error("{0}")]
    Invalid(ConfigError),
    /// A file whose name may not be written, or that failed to be.
    #[error(transparent)]
    NewFile(#[from] new_file::NewFileError),
}

/// A configuration file checked to be editable, and its text as it was.
pub struct ConfigEdit {
    path: PathBuf,
    before: String,
    kept: PathBuf,
    /// Who edits it, as its refusals begin ("--apply", "teach").
    by: &'static str,
}

impl ConfigEdit {
    /// Checks that the configuration at `path` can be edited by `by` (as its refusals begin), its text as it was
    /// to be kept at `<name>.<kept_suffix>`.
    pub fn check(path: &Path, by: &'static str, kept_suffix: &str) -> Result<Self, EditError> {
        let before = std::fs::read_to_string(path).map_err(|source| EditError::File {
            what: "reading",
            path: path.to_path_buf(),
            source,
        })?;
        before.parse::<toml_edit::DocumentMut>().map_err(|e| {
            EditError::Refused(format!("{by}: {} cannot be edited as TOML: {e}", path.display()))
        })?;
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(format!(".{kept_suffix}"));
        let kept = path.with_file_name(name);
        new_file::check(&kept, true)?;
        new_file::check(path, true)?;
        writable(path, by)?;
        Ok(Self { path: path.to_path_buf(), before, kept, by })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Its text as it was.
    pub fn before(&self) -> &str {
        &self.before
    }

    /// Its text as it was, parsed for editing.
    pub fn document(&self) -> Result<toml_edit::DocumentMut, EditError> {
        self.before
            .parse()
            .map_err(|e| EditError::Refused(format!("{}: parsing the configuration as TOML: {e}", self.by)))
    }

    /// The configuration `text` would be, loaded from a file beside this one.
    pub fn load_edited(&self, text: &str) -> Result<Config, EditError> {
        let trial = self.path.with_extension("edit-check.toml");
        new_file::write(&trial, text.as_bytes(), true, 0o600)?;
        let loaded = Config::load(&trial);
        let _ = std::fs::remove_file(&trial);
        loaded.map_err(EditError::Invalid)
    }

    /// Writes the text as it was beside the file (`<name>.<kept_suffix>`, the file's mode); where it went.
    pub fn keep_copy(&self) -> Result<&Path, EditError> {
        new_file::write(&self.kept, self.before.as_bytes(), true, mode_of(&self.path))?;
        Ok(&self.kept)
    }

    /// Writes `text` over the file (a new file moved over its name, with its mode).
    pub fn replace(&self, text: &str) -> Result<(), EditError> {
        new_file::write(&self.path, text.as_bytes(), true, mode_of(&self.path))?;
        Ok(())
    }
}

/// Refuses a configuration the user keeps read-only (no write permission for its owner: a 0444 file, which root
/// too must not replace) or cannot open for writing, and one in a folder where the edited file cannot be made (a
/// probe file is made there and removed).
fn writable(path: &Path, by: &str) -> Result<(), EditError> {
    use std::os::unix::fs::PermissionsExt;
    let metadata = std::fs::metadata(path).map_err(|source| EditError::File {
        what: "looking at",
        path: path.to_path_buf(),
        source,
    })?;
    let mode = metadata.permissions().mode() & 0o777;
    let opens = std::fs::OpenOptions::new().write(true).open(path).is_ok();
    if mode & 0o200 == 0 || !opens {
        return Err(EditError::Refused(format!(
            "{by}: {} is read-only (mode {mode:04o}): nothing was moved; make it writable (chmod u+w)",
            path.display()
        )));
    }
    new_file::can_make_beside(path).map_err(|e| {
        EditError::Refused(format!("{by}: {e}, where the edited configuration is written: nothing was moved"))
    })
}

fn mode_of(path: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).map_or(0o644, |m| m.permissions().mode() & 0o777)
}
