//! A file and the bases it `extends`: read, merged (each file's own keys over its base's), and traced back,
//! so that an error names the file in which the bad key was written.
//!
//! A file may start with `extends = "PATH"` (relative to the file itself): the base is read first, and the
//! file's keys are merged over it: a table merges key by key, any other value (an array too) replaces the
//! base's. A base may extend another; a cycle and a missing base are refused, naming them.
//!
//! The camera's lens is one value ([`LENS_KEYS`]): a file that writes any of its keys replaces its base's
//! whole lens (a file giving `fx_px`/`fy_px` or a `calibration_file` is not mixed with its base's
//! `focal_px`); so is its mount ([`MOUNT_KEYS`]: a fixed camera's file drops its base's `tool_from_camera`). A relative `camera.calibration_file` or `robot.arm.urdf` is made relative to the file that
//! wrote it here, so the merged text names it wherever it is read.

use std::path::{Path, PathBuf};

use crate::ConfigError;
use crate::raw::RawConfig;

/// The key that names a file's base.
pub const EXTENDS: &str = "extends";

/// One file of the chain.
#[derive(Debug)]
struct Layer {
    /// Its path (or name), for messages.
    file: String,
    /// Its text, for the parser's line numbers.
    text: String,
    /// Its keys, `extends` taken out.
    table: toml::Table,
}

/// A file and its bases, the file first.
#[derive(Debug)]
pub struct Layers {
    layers: Vec<Layer>,
}

impl Layers {
    /// Reads `path` and every base it extends.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let mut layers: Vec<Layer> = Vec::new();
        let mut seen: Vec<PathBuf> = Vec::new();
        let mut next = Some(path.to_path_buf());
        let mut read_bytes = 0u64;
        while let Some(path) = next.take() {
            let file = path.display().to_string();
            let extended_by = layers.last().map(|layer| layer.file.clone());
            let text = read_text(&path, &file, extended_by.as_deref())?;
            refuse_a_cycle(&path, &file, &mut seen, &layers)?;
            read_bytes += text.len() as u64;
            refuse_a_long_chain(read_bytes, &file, &layers)?;
            let mut table = parse_table(&text, &file)?;
            next = take_extends(&mut table, &path, &file)?;
            anchor_calibration_file(&mut table, &path);
            anchor_urdf(&mut table, &path);
            layers.push(Layer { file, text, table });
        }
        Ok(Self { layers })
    }

    /// Text given directly (no path to find a base by): `extends` is refused.
    pub fn from_text(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let table = parse_table(text, origin)?;
        if let Some(value) = table.get(EXTENDS) {
            return Err(ConfigError::Invalid {
                file: origin.to_string(),
                key: EXTENDS.into(),
                value: value.to_string(),
                reason: "a base is merged only when the file is read by its path (Config::load)".into(),
            });
        }
        Ok(Self { layers: vec![Layer { file: origin.to_string(), text: text.to_string(), table }] })
    }

    /// Every file's keys merged, the bases' first.
    pub fn merged(&self) -> toml::Table {
        merge_layers(&self.layers)
    }

    /// The merged keys as TOML text: what the file means, with no base left to find.
    pub fn resolved_text(&self) -> Result<String, ConfigError> {
        toml::to_string(&self.merged()).map_err(|e| ConfigError::Parse {
            file: self.layers[0].file.clone(),
            key: None,
            message: format!("the merged configuration cannot be written as TOML: {e}"),
        })
    }

    /// The file that wrote `key` (a dotted key, `[i]` indices allowed) or, failing that, the nearest table
    /// holding it; the first file when none did (a key left to its default).
    pub fn file_of(&self, key: &str) -> &str {
        if let Some(layer) = self.lens_layer(key) {
            return &layer.file;
        }
        let path: Vec<&str> = key.split('.').map(|part| part.split('[').next().unwrap_or(part)).collect();
        (1..=path.len())
            .rev()
            .find_map(|depth| self.layers.iter().find(|layer| holds(&layer.table, &path[..depth])))
            .map_or(&self.layers[0].file, |layer| &layer.file)
    }

    /// The file whose keys, over its bases', first make `fails` true: the lowest layer (the base of them all
    /// first) from which the configuration parses and fails; none when no part of the stack does alone.
    pub fn first_failing(&self, fails: impl Fn(RawConfig) -> bool) -> Option<&str> {
        let count = self.layers.len();
        (1..=count)
            .map(|n| count - n)
            .find(|&index| deserialize(merge_layers(&self.layers[index..])).is_ok_and(&fails))
            .map(|index| self.layers[index].file.as_str())
    }

    /// For a key of the camera's lens ([`LENS_KEYS`]): the file whose lens is in force (the first, file
    /// first, that writes any lens key), whether or not it wrote this one.
    fn lens_layer(&self, key: &str) -> Option<&Layer> {
        let leaf = key.strip_prefix("camera.")?.split(['.', '[']).next()?;
        if !LENS_KEYS.contains(&leaf) {
            return None;
        }
        self.layers.iter().find(|layer| writes_a_lens(&layer.table))
    }

    /// The raw configuration; a parser's error (unknown key, wrong type, unknown name) names the file that
    /// brought the bad key in and the dotted key.
    pub fn raw_config(&self) -> Result<RawConfig, ConfigError> {
        match deserialize(self.merged()) {
            Ok(raw) => Ok(raw),
            Err(error) => Err(self.blame(error)),
        }
    }

    /// Finds the first file, base upward, whose keys make the error; words the error for it.
    fn blame(&self, error: toml::de::Error) -> ConfigError {
        let count = self.layers.len();
        let shown = error.to_string();
        // a base that is not whole on its own is not to blame for what its overlay got wrong
        let first_bad = (1..=count)
            .map(|n| count - n)
            .find(|&index| {
                deserialize(merge_layers(&self.layers[index..])).is_err_and(|e| e.to_string() == shown)
            })
            .unwrap_or(0);
        let layer = &self.layers[first_bad];
        let key = key_of(&error);
        let slip = misspelt(&shown);
        // an unknown key is found on its own line, not its table's
        let written_key = match (&key, &slip) {
            (Some(table), Some(slip)) if slip.is_key => Some(format!("{table}.{}", slip.written)),
            (None, Some(slip)) if slip.is_key => Some(slip.written.clone()),
            _ => key.clone(),
        };
        let message = if first_bad == count - 1 {
            // the base of them all is a whole file: its own parser error shows the line
            match toml::from_str::<RawConfig>(&layer.text) {
                Err(text_error) => with_key(text_error.to_string(), key.as_deref()),
                Ok(_) => error.to_string(),
            }
        } else {
            match written_key.as_deref().and_then(|key| line_of(&layer.text, key)) {
                Some(line) => format!("line {line}: {error}"),
                None => error.to_string(),
            }
        };
        let suggestion = slip
            .as_ref()
            .and_then(|slip| did_you_mean(&slip.written, slip.accepted.iter().map(String::as_str)))
            .map(|nearest| format!("\ndid you mean `{nearest}`?"))
            .unwrap_or_default();
        ConfigError::Parse {
            file: layer.file.clone(),
            key,
            message: format!("{}{suggestion}", message.trim_end()),
        }
    }
}

/// The layers merged, the last (the base of them all) first.
fn merge_layers(layers: &[Layer]) -> toml::Table {
    let mut merged = toml::Table::new();
    for layer in layers.iter().rev() {
        merge(&mut merged, &layer.table);
    }
    tag_board(&mut merged, layers);
    merged
}

/// A tag's board is its own: when `[target] kind = "apriltag"` (or `"bundle"`) is in force and neither the file that set it nor
/// a file over it writes `object.board_extent_m`, the extent a base wrote (for its own board) gives way and the
/// tag's sheet is derived from the tag (`validate/object.rs`).
fn tag_board(merged: &mut toml::Table, layers: &[Layer]) {
    let kind = merged.get("target").and_then(|t| t.get("kind")).and_then(toml::Value::as_str);
    if kind != Some("apriltag") && kind != Some("bundle") {
        return;
    }
    let Some(kind_set_in) = layers.iter().position(|layer| holds(&layer.table, &["target", "kind"])) else {
        return;
    };
    let written_for_the_tag =
        layers[..=kind_set_in].iter().any(|layer| holds(&layer.table, &["object", "board_extent_m"]));
    if !written_for_the_tag && let Some(toml::Value::Table(object)) = merged.get_mut("object") {
        object.remove("board_extent_m");
    }
}

/// The `[camera]` keys that describe the lens together: a file writing any of them replaces all its base's.
pub const LENS_KEYS: [&str; 8] = [
    "focal_px",
    "fx_px",
    "fy_px",
    "principal_point_px",
    "distortion",
    "calibration_file",
    "width_px",
    "height_px",
];

/// The keys of the camera's mount, one value as the lens is: a file that writes any of them replaces its base's
/// mount whole, and one that writes `mount` `[camera.truth]`'s pose too (a fixed camera over a hand camera's
/// file does not inherit its `tool_from_camera`).
pub const MOUNT_KEYS: [&str; 3] = ["mount", "tool_from_camera", "base_from_camera"];

/// `overlay`'s keys over `base`'s: tables key by key, any other value replaced; the camera's lens and its
/// mount each whole.
fn merge(base: &mut toml::Table, overlay: &toml::Table) {
    for keys in [&LENS_KEYS[..], &MOUNT_KEYS[..]] {
        if writes_any(overlay, keys)
            && let Some(toml::Value::Table(camera)) = base.get_mut("camera")
        {
            camera.retain(|key, _| !keys.contains(&key));
            // a file that sets the mount's kind has a truth of its own: the base's `[camera.truth]` pose was of
            // the base's mount
            if keys == MOUNT_KEYS
                && writes_any(overlay, &["mount"])
                && let Some(toml::Value::Table(truth)) = camera.get_mut("truth")
            {
                truth.retain(|key, _| !keys.contains(&key));
            }
        }
    }
    merge_tables(base, overlay);
}

/// Whether a file's `[camera]` holds any of `keys`.
fn writes_any(table: &toml::Table, keys: &[&str]) -> bool {
    table
        .get("camera")
        .and_then(toml::Value::as_table)
        .is_some_and(|camera| keys.iter().any(|key| camera.contains_key(*key)))
}

/// Whether a file's keys hold any key of the camera's lens.
fn writes_a_lens(table: &toml::Table) -> bool {
    writes_any(table, &LENS_KEYS)
}

/// `overlay`'s keys over `base`'s: tables key by key, any other value replaced.
fn merge_tables(base: &mut toml::Table, overlay: &toml::Table) {
    for (key, value) in overlay {
        match (base.get_mut(key), value) {
            (Some(toml::Value::Table(below)), toml::Value::Table(above)) => merge_tables(below, above),
            _ => {
                base.insert(key.clone(), value.clone());
            }
        }
    }
}

fn deserialize(table: toml::Table) -> Result<RawConfig, toml::de::Error> {
    toml::Value::Table(table).try_into()
}

/// Whether `table` holds the key path.
fn holds(table: &toml::Table, path: &[&str]) -> bool {
    match path {
        [] => true,
        [first, rest @ ..] => match table.get(*first) {
            Some(toml::Value::Table(inner)) => holds(inner, rest),
            Some(_) => rest.is_empty(),
            None => false,
        },
    }
}

/// An unknown key or name as serde reports it: what was written, and what the table or key takes.
struct Misspelt {
    written: String,
    accepted: Vec<String>,
    /// A key (`unknown field`), or a name a key takes (`unknown variant`).
    is_key: bool,
}

/// The unknown key or name a parser error reports (``unknown field `x`, expected one of `a`, `b` ``), if any.
fn misspelt(shown: &str) -> Option<Misspelt> {
    let (is_key, rest) = match (shown.split_once("unknown field `"), shown.split_once("unknown variant `")) {
        (Some((_, rest)), _) => (true, rest),
        (None, Some((_, rest))) => (false, rest),
        (None, None) => return None,
    };
    let (written, rest) = rest.split_once('`')?;
    let line = rest.lines().next().unwrap_or_default();
    let accepted = line
        .split_once("expected")
        .map(|(_, list)| list.split('`').skip(1).step_by(2).map(str::to_string).collect())
        .unwrap_or_default();
    Some(Misspelt { written: written.to_string(), accepted, is_key })
}

/// The accepted key or name nearest `written`, when it is near enough to be a slip of the keyboard: at most a third
/// of its letters (at least one) changed, added, left out or swapped.
pub fn did_you_mean<'a>(written: &str, accepted: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let most = (written.chars().count() / 3).max(1);
    accepted
        .into_iter()
        .map(|name| (strsim::osa_distance(written, name), name))
        .filter(|(distance, _)| *distance <= most)
        .min_by_key(|(distance, _)| *distance)
        .map(|(_, name)| name)
}

/// The dotted key a parser error is about: toml writes it on the error's last line as ``in `a.b` `` when
/// the error carries no text of its own.
fn key_of(error: &toml::de::Error) -> Option<String> {
    let shown = error.to_string();
    let last = shown.trim_end().lines().last()?;
    let key = last.strip_prefix("in `")?.strip_suffix('`')?;
    Some(key.to_string())
}

/// The line (from 1) of `text` on which the dotted key is written, or the deepest table of it that is.
fn line_of(text: &str, key: &str) -> Option<usize> {
    let document = toml::de::DeTable::parse(text).ok()?;
    let mut table = document.get_ref();
    let mut start = None;
    for part in key.split('.') {
        let Some((name, value)) = table.iter().find(|(name, _)| name.get_ref() == part) else {
            break;
        };
        start = Some(name.span().start);
        match value.get_ref() {
            toml::de::DeValue::Table(inner) => table = inner,
            _ => break,
        }
    }
    start.map(|start| text[..start].matches('\n').count() + 1)
}

fn with_key(message: String, key: Option<&str>) -> String {
    match key {
        Some(key) => format!("{}\nin `{key}`", message.trim_end()),
        None => message,
    }
}

fn read_text(path: &Path, file: &str, extended_by: Option<&str>) -> Result<String, ConfigError> {
    read_bounded(path).map_err(|reason| match extended_by {
        Some(child) => ConfigError::Base { file: child.to_string(), base: file.to_string(), reason },
        None => ConfigError::Read { file: file.to_string(), reason },
    })
}

/// A regular file's text, up to [`crate::MAX_CONFIG_FILE_BYTES`]; anything else refused at once, saying why.
/// The file is opened without blocking (a FIFO with no writer would block the open) and checked on the
/// descriptor itself (no window between a check by name and the open).
pub fn read_bounded(path: &Path) -> Result<String, String> {
    use std::io::Read;
    use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| e.to_string())?;
    let metadata = file.metadata().map_err(|e| e.to_string())?;
    let kind = metadata.file_type();
    if !kind.is_file() {
        let what = if kind.is_dir() {
            "a directory"
        } else if kind.is_fifo() {
            "a FIFO"
        } else if kind.is_char_device() {
            "a character device"
        } else if kind.is_block_device() {
            "a block device"
        } else if kind.is_socket() {
            "a socket"
        } else {
            "not a file"
        };
        return Err(format!("not a regular file ({what}): a configuration must be a regular file"));
    }
    let limit = crate::MAX_CONFIG_FILE_BYTES;
    let too_long = || {
        format!(
            "longer than {} MiB, the most vservo reads of a configuration, URDF or calibration file",
            limit / (1024 * 1024)
        )
    };
    if metadata.len() > limit {
        return Err(too_long());
    }
    let mut bytes = Vec::with_capacity(metadata.len() as usize);
    // the file may grow while it is read: never past the bound
    file.take(limit + 1).read_to_end(&mut bytes).map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(too_long());
    }
    String::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))
}

/// Refuses a chain of files longer together than one file may be ([`crate::MAX_CONFIG_FILE_BYTES`]), naming
/// the file that went over and the chain.
fn refuse_a_long_chain(read_bytes: u64, file: &str, layers: &[Layer]) -> Result<(), ConfigError> {
    let limit = crate::MAX_CONFIG_FILE_BYTES;
    if read_bytes <= limit {
        return Ok(());
    }
    let chain: Vec<&str> = layers.iter().map(|layer| layer.file.as_str()).chain([file]).collect();
    Err(ConfigError::Read {
        file: file.to_string(),
        reason: format!(
            "the files {} hold {read_bytes} bytes together, more than the {} MiB a configuration is read up to",
            chain.join(" → "),
            limit / (1024 * 1024)
        ),
    })
}

/// Refuses a file met before in the chain, naming the chain.
fn refuse_a_cycle(
    path: &Path,
    file: &str,
    seen: &mut Vec<PathBuf>,
    layers: &[Layer],
) -> Result<(), ConfigError> {
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if seen.contains(&canonical) {
        let chain: Vec<&str> = layers.iter().map(|layer| layer.file.as_str()).chain([file]).collect();
        return Err(ConfigError::Cycle { file: chain[0].to_string(), chain: chain.join(" → ") });
    }
    seen.push(canonical);
    Ok(())
}

fn parse_table(text: &str, file: &str) -> Result<toml::Table, ConfigError> {
    toml::from_str(text).map_err(|e| ConfigError::Parse {
        file: file.to_string(),
        key: None,
        message: e.to_string().trim_end().to_string(),
    })
}

/// Makes a relative `camera.calibration_file` relative to the directory of the file at `path`.
fn anchor_calibration_file(table: &mut toml::Table, path: &Path) {
    let Some(toml::Value::Table(camera)) = table.get_mut("camera") else { return };
    let Some(toml::Value::String(file)) = camera.get_mut("calibration_file") else { return };
    anchor(file, path);
}

/// Makes a relative `robot.arm.urdf` relative to the directory of the file at `path`.
fn anchor_urdf(table: &mut toml::Table, path: &Path) {
    let Some(toml::Value::Table(robot)) = table.get_mut("robot") else { return };
    let Some(toml::Value::Table(arm)) = robot.get_mut("arm") else { return };
    let Some(toml::Value::String(file)) = arm.get_mut("urdf") else { return };
    anchor(file, path);
}

/// Makes `file`, if relative, relative to the directory of the file at `path`, and absolute: the resolved text
/// (the configuration in force, which vservod writes into the instance's directory for its helpers and
/// clients) names the same file from any working directory.
fn anchor(file: &mut String, path: &Path) {
    if !file.trim().is_empty() && Path::new(file.as_str()).is_relative() {
        let directory = path.parent().unwrap_or(Path::new(""));
        let joined = directory.join(file.as_str());
        *file = std::path::absolute(&joined).unwrap_or(joined).display().to_string();
    }
}

/// Takes `extends` out of a file's keys: the base's path, relative to the file.
fn take_extends(table: &mut toml::Table, path: &Path, file: &str) -> Result<Option<PathBuf>, ConfigError> {
    match table.remove(EXTENDS) {
        None => Ok(None),
        Some(toml::Value::String(base)) if !base.trim().is_empty() => {
            let directory = path.parent().unwrap_or(Path::new(""));
            Ok(Some(directory.join(base)))
        }
        Some(other) => Err(ConfigError::Invalid {
            file: file.to_string(),
            key: EXTENDS.into(),
            value: other.to_string(),
            reason: "must be the path of the base file, relative to this one".into(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        toml::from_str(text).expect("test TOML")
    }

    fn layers(texts: &[(&str, &str)]) -> Layers {
        Layers {
            layers: texts
                .iter()
                .map(|(file, text)| Layer {
                    file: file.to_string(),
                    text: text.to_string(),
                    table: table(text),
                })
                .collect(),
        }
    }

    #[test]
    fn tables_merge_key_by_key_and_other_values_replace() {
        let chain = layers(&[
            ("top.toml", "[a]\nx = 2\nlist = [9]\n[c]\nz = 1\n"),
            ("base.toml", "[a]\nx = 1\ny = 1\nlist = [1, 2]\n[b]\nw = 1\n"),
        ]);
        let merged = chain.merged();
        assert_eq!(merged, table("[a]\nx = 2\ny = 1\nlist = [9]\n[b]\nw = 1\n[c]\nz = 1\n"));
    }

    #[test]
    fn a_key_is_traced_to_the_file_that_wrote_it() {
        let chain = layers(&[("top.toml", "[a]\nx = 2\n"), ("base.toml", "[a]\nx = 1\ny = 1\n[b]\nw = 1\n")]);
        assert_eq!(chain.file_of("a.x"), "top.toml");
        assert_eq!(chain.file_of("a.y"), "base.toml");
        assert_eq!(chain.file_of("b.w[0].v"), "base.toml");
        // not written anywhere: the nearest table that is, then the first file
        assert_eq!(chain.file_of("a.missing"), "top.toml");
        assert_eq!(chain.file_of("nowhere.at_all"), "top.toml");
    }

    #[test]
    fn a_key_is_found_on_its_line() {
        let text = "# a comment\n[a]\nx = 1\n\n[a.b]\ny = 2\n";
        assert_eq!(line_of(text, "a.x"), Some(3));
        assert_eq!(line_of(text, "a.b.y"), Some(6));
        // not written: the deepest table that is
        assert_eq!(line_of(text, "a.b.z"), Some(5));
        assert_eq!(line_of(text, "c"), None);
    }

    #[test]
    fn the_parsers_key_is_read_from_its_error() {
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct Outer {
            inner: Inner,
        }
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct Inner {
            law: Law,
        }
        #[derive(Debug, serde::Deserialize)]
        #[serde(rename_all = "kebab-case")]
        enum Law {
            Paper,
        }
        let error =
            toml::Value::Table(table("[inner]\nlaw = \"fast\"\n")).try_into::<Outer>().expect_err("refused");
        assert_eq!(key_of(&error).as_deref(), Some("inner.law"), "{error}");
    }
}
