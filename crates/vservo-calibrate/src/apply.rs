//! `vservoctl calibrate --apply`: the configuration made to read the calibration file just written, and the
//! running instance asked to take it.
//!
//! The configuration file named by `--config` gets `[camera] calibration_file` (relative to the file where the
//! calibration lies beside or below it) in place of its own lens keys: a file that gives a lens gives all of
//! it (config/vservo.toml's `[camera]`), and the calibration file carries the image size, the lens and
//! `tool_from_camera`. The edit keeps every other key, comment and layout (`toml_edit`); the configuration as it
//! will be is loaded and validated before anything is written (a refusal names what and leaves the file as it
//! was); the file as it was is kept beside it (`<name>.before-calibration`); the new text is written as a new
//! file moved over the name (`vservo_config::new_file`). Then the running instance takes it: vservod applies the lens and
//! the mount while the cell is held, by restarting the nodes that read them, so a cell that servoed is held (a safe
//! stop), reloaded, and resumed once those nodes run again.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use vservo_config::edit::{ConfigEdit, EditError};
use vservo_config::{Config, LENS_KEYS};
use vservo_protocol::DaemonState;

use crate::{CalibrateError, Result};

/// The suffix of the configuration as it was before `--apply`.
const BEFORE_SUFFIX: &str = "before-calibration";

/// The configuration file as it was, checked to be editable (before anything moves, so that a configuration
/// `--apply` cannot edit is refused first).
pub struct Edit(ConfigEdit);

/// What `--apply` did.
pub struct Applied {
    /// The configuration file that now reads the calibration.
    pub config_path: PathBuf,
    /// Where the configuration as it was is kept.
    pub kept: PathBuf,
    /// The lens keys taken out of the file (the calibration file gives them now).
    pub replaced_keys: Vec<String>,
    /// The running instance's answer to the reload, if one was asked.
    pub reload: Option<Reload>,
}

/// The running instance's answer.
pub enum Reload {
    /// It reloaded: the calibrated camera is in force.
    Taken(String),
    /// It refused (the reply says why), or could not be asked: why.
    NotTaken(String),
}

impl From<EditError> for CalibrateError {
    fn from(error: EditError) -> Self {
        match error {
            EditError::Refused(why) if why.contains("is read-only") => CalibrateError::Refused(format!(
                "{why}, or leave --apply out and point [camera] calibration_file at the calibration yourself"
            )),
            EditError::Refused(why) => CalibrateError::Refused(why),
            EditError::File { what, path, source } => CalibrateError::File { what, path, source },
            EditError::Invalid(e) => CalibrateError::Refused(e.to_string()),
            EditError::NewFile(e) => CalibrateError::NewFile(e),
        }
    }
}

impl Edit {
    /// Checks that the configuration file can be edited: a TOML file of the user's own, readable and
    /// writable in its folder.
    pub fn check(config_path: &Path) -> Result<Self> {
        Ok(Self(ConfigEdit::check(config_path, "--apply", BEFORE_SUFFIX)?))
    }

    /// Points `[camera] calibration_file` at `calibration`, checks the configuration loads so and that it
    /// reads the calibration, then writes it (the old text kept beside it). A failure names what it left: the
    /// calibration file, and the copy of the configuration when one was made.
    pub fn apply(self, calibration: &Path) -> Result<Applied> {
        let left_calibration = |e: CalibrateError| {
            e.left(format!(
                "the calibration is written at {} (`[camera] calibration_file` takes it)",
                calibration.display()
            ))
        };
        let (text, replaced_keys) =
            edited(self.0.document()?, &self.relative(calibration)).map_err(left_calibration)?;
        self.validate(&text, calibration).map_err(left_calibration)?;
        let kept = self.0.keep_copy().map_err(|e| left_calibration(e.into()))?.to_path_buf();
        self.0.replace(&text).map_err(|e| {
            left_calibration(CalibrateError::from(e).left(format!(
                "{} is as it was; a copy of it is at {}",
                self.0.path().display(),
                kept.display()
            )))
        })?;
        Ok(Applied { config_path: self.0.path().to_path_buf(), kept, replaced_keys, reload: None })
    }

    /// `calibration` as the configuration writes it: relative to the configuration's folder where it lies
    /// beside or below it, else absolute.
    fn relative(&self, calibration: &Path) -> String {
        let folder = self.0.path().parent().map(absolute).unwrap_or_default();
        let calibration = absolute(calibration);
        calibration.strip_prefix(&folder).unwrap_or(&calibration).display().to_string()
    }

    /// Loads the edited configuration from a file beside the real one (so that `extends` and relative
    /// paths resolve as they will) and checks it reads the calibration.
    fn validate(&self, text: &str, calibration: &Path) -> Result<()> {
        let config = self.0.load_edited(text).map_err(|e| match e {
            EditError::Invalid(e) => CalibrateError::Refused(format!(
                "--apply: {} with calibration_file = {} does not load, so it was left as it was: {e}",
                self.0.path().display(),
                calibration.display()
            )),
            other => other.into(),
        })?;
        if !reads(&config, calibration)? {
            return Err(CalibrateError::Refused(format!(
                "--apply: {} would not read {}: a file it extends or its [camera] sets the lens otherwise; \
                 set calibration_file by hand",
                self.0.path().display(),
                calibration.display()
            )));
        }
        Ok(())
    }
}

/// Whether `config` runs the camera of the calibration file at `calibration`: its focal lengths, principal
/// point, lens and mount.
fn reads(config: &Config, calibration: &Path) -> Result<bool> {
    let text = std::fs::read_to_string(calibration)
        .map_err(CalibrateError::file("--apply: reading back", calibration))?;
    let file = vservo_config::calibration::parse(&text).map_err(|e| {
        CalibrateError::Refused(format!("--apply: {} does not read back: {e}", calibration.display()))
    })?;
    let camera = &config.cell.camera;
    let point = camera.principal_point_px();
    let same_lens = [camera.fx_px(), camera.fy_px(), point.x, point.y]
        == [file.focal_px[0], file.focal_px[1], file.principal_point_px[0], file.principal_point_px[1]]
        && camera.distortion().coefficients() == file.distortion;
    let (_, believed) = config.cell.camera_in_mount();
    let same_mount = file.tool_from_camera.or(file.base_from_camera).is_none_or(|mount| mount == believed);
    Ok(same_lens && same_mount)
}

/// The configuration's text with `[camera] calibration_file` set and the other lens keys of its `[camera]`
/// removed (they are the file's now), and the keys removed.
fn edited(mut document: toml_edit::DocumentMut, calibration: &str) -> Result<(String, Vec<String>)> {
    let camera = document
        .entry("camera")
        .or_insert_with(|| toml_edit::Item::Table(toml_edit::Table::new()))
        .as_table_like_mut()
        .ok_or_else(|| {
            CalibrateError::Refused("--apply: `camera` in the configuration is not a table".to_string())
        })?;
    let mut replaced = Vec::new();
    for key in LENS_KEYS {
        if key != "calibration_file" && camera.remove(key).is_some() {
            replaced.push(format!("camera.{key}"));
        }
    }
    camera.insert("calibration_file", toml_edit::value(calibration));
    Ok((document.to_string(), replaced))
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// How long the nodes that read the camera get to restart after the reload before the resume is given up.
const RESTART_WAIT: Duration = Duration::from_secs(20);

/// Has the running instance take the calibration: the camera's nodes restart with it while the cell is held,
/// so a cell that servoed is held (a safe stop), reloaded, and resumed once those nodes run again; a cell that
/// was held stays held. Its answer, or why it did not take it.
pub fn reload(instance: &str) -> Reload {
    match reload_held(instance) {
        Ok(said) => Reload::Taken(said),
        Err(why) => Reload::NotTaken(why.to_string()),
    }
}

fn reload_held(instance: &str) -> Result<String> {
    let mut client = vservo_client::Client::connect(instance)?;
    let held_before = state_of(&client)? == Ok(DaemonState::SafeStop);
    if !held_before {
        let stop = client.safe_stop_command()?;
        if !stop.accepted {
            return Err(CalibrateError::Cell(format!(
                "the safe stop before the reload was refused: {}",
                stop.reason
            )));
        }
    }
    let restarts_before = camera_node_restarts(&client)?;
    let reply = client.reload()?;
    if !reply.accepted {
        if !held_before {
            resume_when_back(&mut client, restarts_before, false)?;
        }
        return Err(CalibrateError::Cell(reply.reason));
    }
    if held_before {
        return Ok(format!("{}; the cell stays held, as it was (`vservoctl resume` servos)", reply.reason));
    }
    // an unchanged camera (the same calibration again) restarts nothing: the cell resumes at once
    let restarting = reply.reason.contains(vservo_client::RELOAD_RESTARTS_NODES);
    resume_when_back(&mut client, restarts_before, restarting)?;
    Ok(format!("{}; the cell servos again with the calibrated camera", reply.reason))
}

fn state_of(client: &vservo_client::Client) -> Result<Result<DaemonState, u32>> {
    let status = client.status(Duration::from_secs(2))?;
    Ok(DaemonState::try_from(status.state).map_err(|_| status.state))
}

/// The restarts of the nodes that read the camera (vision, servo, rmrc), as the status says.
fn camera_node_restarts(client: &vservo_client::Client) -> Result<[u64; 3]> {
    let status = client.status(Duration::from_secs(2))?;
    Ok([1, 2, 3].map(|node| status.nodes[node].restarts))
}

/// Resumes once the camera's nodes run healthy again (restarted, when `restarted`), within [`RESTART_WAIT`].
fn resume_when_back(client: &mut vservo_client::Client, before: [u64; 3], restarted: bool) -> Result<()> {
    let until = Instant::now() + RESTART_WAIT;
    loop {
        let status = client.status(Duration::from_secs(2))?;
        let back = [1, 2, 3].iter().zip(before).all(|(&node, restarts)| {
            let node = &status.nodes[node];
            node.healthy == 1 && (!restarted || node.restarts > restarts)
        });
        if back {
            let reply = client.resume()?;
            if reply.accepted {
                return Ok(());
            }
            if Instant::now() >= until {
                return Err(CalibrateError::Cell(format!(
                    "the resume after the reload was refused: {}",
                    reply.reason
                )));
            }
        } else if Instant::now() >= until {
            return Err(CalibrateError::Cell(format!(
                "the camera's nodes did not run again within {} s of the reload: the cell stays held",
                RESTART_WAIT.as_secs()
            )));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

impl Applied {
    /// The lines of the report.
    pub fn text(&self) -> String {
        let replaced = if self.replaced_keys.is_empty() {
            String::new()
        } else {
            format!(" in place of {}", self.replaced_keys.join(", "))
        };
        let mut text = format!(
            "applied: {} now reads the calibration (camera.calibration_file{replaced}); as it was: {}\n",
            self.config_path.display(),
            self.kept.display()
        );
        match &self.reload {
            None => text.push_str("  every run from this configuration takes the calibrated camera\n"),
            Some(Reload::Taken(reply)) => {
                text.push_str(&format!("  the running instance reloaded: {reply}\n"))
            }
            Some(Reload::NotTaken(why)) => text.push_str(&format!(
                "  the running instance did not take it: {why}\n  \
                 `vservoctl reload` (the cell held) or a restart of vservod runs the calibrated camera\n"
            )),
        }
        text
    }

    /// The report's `applied` object.
    pub fn json(&self) -> Value {
        let (reloaded, reply) = match &self.reload {
            None => (Value::Null, Value::Null),
            Some(Reload::Taken(reply)) => (json!(true), json!(reply)),
            Some(Reload::NotTaken(why)) => (json!(false), json!(why)),
        };
        json!({
            "config": self.config_path.display().to_string(),
            "kept": self.kept.display().to_string(),
            "replaced_keys": self.replaced_keys,
            "reloaded": reloaded,
            "reply": reply,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lens_keys_give_way_to_the_calibration_file_and_the_rest_stays() {
        let before = "# my cell\nextends = \"base.toml\"\n\n[camera]\n# the lens\nfx_px = 600.0 # measured\nfy_px = 600.0\n\
                      principal_point_px = [320.0, 240.0]\nwidth_px = 640\nheight_px = 480\n\n[timing]\nvision_period_s = 0.085\n";
        let (after, replaced) = edited(before.parse().expect("TOML"), "calibration.yaml").expect("edits");
        assert_eq!(
            replaced,
            [
                "camera.fx_px",
                "camera.fy_px",
                "camera.principal_point_px",
                "camera.width_px",
                "camera.height_px"
            ]
        );
        let table: toml::Table = after.parse().expect("TOML");
        assert_eq!(table["camera"]["calibration_file"].as_str(), Some("calibration.yaml"));
        assert!(table["camera"].get("fx_px").is_none());
        assert_eq!(table["timing"]["vision_period_s"].as_float(), Some(0.085));
        assert!(after.starts_with("# my cell\nextends = \"base.toml\"\n"), "{after}");
    }

    #[test]
    fn a_configuration_without_a_camera_table_gets_one() {
        let (after, replaced) =
            edited("extends = \"vservo.toml\"\n".parse().expect("TOML"), "/abs/calibration.yaml")
                .expect("edits");
        assert!(replaced.is_empty());
        let table: toml::Table = after.parse().expect("TOML");
        assert_eq!(table["camera"]["calibration_file"].as_str(), Some("/abs/calibration.yaml"));
    }

    #[test]
    fn a_camera_that_is_not_a_table_is_refused() {
        assert!(edited("camera = 3\n".parse().expect("TOML"), "c.yaml").is_err());
    }
}
