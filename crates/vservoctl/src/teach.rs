//! `vservoctl teach`: the view the camera has now becomes the goal. With the arm where the camera should be (moved
//! by the pendant, by hand in guiding mode, or with `vservoctl move-joints`) and still, it watches the features and
//! the joints for a while, and from their means:
//! - `desired.joints_rad` is the joints now;
//! - `desired.camera_from_board` is the board's pose as seen (the plane homography of the four marks through the
//!   configured camera, `CameraIntrinsics::board_pose_from_features`), so that ξ_d, the image of the board from
//!   there, is the view now (to within the pose's fit, which it reports) and the board stands in the
//!   configuration where the camera sees it;
//!
//! writes them into the configuration file (every other key and comment kept, the file as it was kept as
//! `<name>.before-teach`, the edited configuration validated first: `vservo_config::edit`) and has the running
//! instance reload it, which takes `[desired]` live (a hand camera; a fixed camera's `[desired]` places the
//! board on the tool and needs a restart, which the reload says). Afterwards `vservoctl check`'s kinematics and
//! desired-pose lines pass by construction. `--target-only` changes only the running goal (`vservoctl target
//! teach`), and leaves the file as it is.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use nalgebra::Vector3;
use serde_json::json;
use vservo_client::Client;
use vservo_config::Config;
use vservo_config::edit::ConfigEdit;
use vservo_protocol::{FeaturesMsg, JointStateMsg, Topic};
use vservo_scene::{FeatureVector, IsometryMatrix3};

use crate::UsageError;
use crate::output::print_stdout;

/// Arguments of `vservoctl teach`.
#[derive(Args)]
pub struct TeachArgs {
    /// The configuration file to write the goal into: the one the running instance was started with (its
    /// instance is the one taught).
    #[arg(long, value_name = "FILE", default_value = "config/vservo.toml")]
    config: PathBuf,
    /// Change only the running goal (as `vservoctl target teach`); the file stays as it is.
    #[arg(long)]
    target_only: bool,
    /// How long to watch the still arm and its features (s): their means are taught.
    #[arg(long, default_value_t = 1.0)]
    watch_s: f64,
    /// Print what was taught as one JSON object.
    #[arg(long)]
    json: bool,
}

/// A joint moving by more than this over the watch (rad) is not still.
const STILL_RAD: f64 = 1e-3;
/// A mark moving by more than this over the watch (px) is not still.
const STILL_PX: f64 = 1.0;
/// The features must be the image of the board from the taught pose to within this (px): more says the
/// configured board or camera is not the one seen (`vservo_cell::target::TARGET_POSE_FIT_PX`).
const FIT_PX: f64 = vservo_cell::target::TARGET_POSE_FIT_PX;

/// What the camera and the arm showed over the watch.
struct Seen {
    features: FeatureVector,
    joints: Vec<f64>,
    frames: usize,
}

/// The goal taught from what was seen.
struct Taught {
    joints: Vec<f64>,
    camera_from_board: IsometryMatrix3<f64>,
    /// ξ_d: the board's image from the taught pose (px).
    features: FeatureVector,
    /// How far ξ_d lies from the features seen, at most (px).
    fit_px: f64,
}

/// Runs the command.
pub fn run(args: &TeachArgs) -> Result<()> {
    if !(args.watch_s.is_finite() && (0.2..=10.0).contains(&args.watch_s)) {
        return Err(UsageError(format!("--watch-s {}: from 0.2 to 10 s", args.watch_s)).into());
    }
    let config = Config::load(&args.config).map_err(|e| UsageError(e.to_string()))?;
    let mut client = Client::connect(&config.instance)?;
    if args.target_only {
        let reply = client.teach()?;
        if !reply.accepted {
            bail!("the running goal was not taught: {}", reply.reason);
        }
        let said = format!("the running goal is the view now ({}); the file is as it was\n", reply.reason);
        return Ok(print_stdout(&said)?);
    }
    // checked before anything is watched: a file teach cannot write is refused first
    let edit = ConfigEdit::check(&args.config, "teach", "before-teach")?;
    let seen = watch(&client, &config, Duration::from_secs_f64(args.watch_s))?;
    let taught = teach(&config, &seen)?;
    let text = edited(&edit, &taught)?;
    let loaded = edit.load_edited(&text)?;
    in_force(&loaded, &taught, &args.config)?;
    let kept = edit.keep_copy()?.to_path_buf();
    edit.replace(&text).with_context(|| {
        format!("{} is as it was; a copy of it is at {}", args.config.display(), kept.display())
    })?;
    let reload = client.reload()?;
    report(args, &seen, &taught, &kept, &reload)
}

/// The means of the features (all four marks valid) and of the joints over `watch`, with the arm still.
fn watch(client: &Client, config: &Config, watch: Duration) -> Result<Seen> {
    let joint_count = config.cell.arm.joint_count();
    let features_in = client.subscribe::<FeaturesMsg>(Topic::Features)?;
    let states_in = client.subscribe::<JointStateMsg>(Topic::JointState)?;
    let (mut features, mut joints): (Vec<FeatureVector>, Vec<Vec<f64>>) = (Vec::new(), Vec::new());
    let started = Instant::now();
    while started.elapsed() < watch {
        while let Some(sample) = features_in.receive()? {
            let Ok(message) = vservo_protocol::inbox::accept(*sample) else { continue };
            if message.valid_mask == 0b1111 {
                features.push(FeatureVector::from(message.features_px));
            }
        }
        while let Some(sample) = states_in.receive()? {
            let Ok(state) = vservo_protocol::inbox::accept(*sample) else { continue };
            if let Some(q) = state.arm_q_rad(joint_count) {
                joints.push(q[..joint_count].to_vec());
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    if features.len() < 3 {
        bail!(
            "the camera showed all four marks in {} frame(s) of {:.1} s: nothing was taught; put the board in view \
             (`vservoctl snapshot` shows what the camera sees)",
            features.len(),
            watch.as_secs_f64()
        );
    }
    if joints.is_empty() {
        bail!("no joint state from the robot driver in {:.1} s: nothing was taught", watch.as_secs_f64());
    }
    still(&features, &joints)?;
    let mean_features = features.iter().sum::<FeatureVector>() / features.len() as f64;
    let mean_joints =
        (0..joint_count).map(|j| joints.iter().map(|q| q[j]).sum::<f64>() / joints.len() as f64).collect();
    Ok(Seen { features: mean_features, joints: mean_joints, frames: features.len() })
}

/// Refuses an arm or marks that moved over the watch.
fn still(features: &[FeatureVector], joints: &[Vec<f64>]) -> Result<()> {
    let spread = |values: &mut dyn Iterator<Item = f64>| {
        let (low, high) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
        high - low
    };
    let joint_spread =
        (0..joints[0].len()).map(|j| spread(&mut joints.iter().map(|q| q[j]))).fold(0.0, f64::max);
    let mark_spread = (0..8).map(|i| spread(&mut features.iter().map(|f| f[i]))).fold(0.0, f64::max);
    if joint_spread > STILL_RAD || mark_spread > STILL_PX {
        bail!(
            "the arm or the board moved while watched (a joint by {joint_spread:.4} rad, a mark by {mark_spread:.2} px; \
             at most {STILL_RAD} rad and {STILL_PX} px): nothing was taught; teach with the arm at rest (a held cell)"
        );
    }
    Ok(())
}

/// The goal from what was seen: the joints, and the board's pose that images the marks at the features.
fn teach(config: &Config, seen: &Seen) -> Result<Taught> {
    let cell = &config.cell;
    let camera_from_board = cell.camera.board_pose_from_features(&cell.board, &seen.features).context(
        "the board's pose cannot be found from the features seen (three marks in a line?): nothing was taught",
    )?;
    let features = cell.camera.project_marks(&cell.board, &camera_from_board)?;
    let fit_px = (0..4)
        .map(|m| (features.fixed_rows::<2>(2 * m) - seen.features.fixed_rows::<2>(2 * m)).norm())
        .fold(0.0, f64::max);
    if fit_px > FIT_PX {
        bail!(
            "the marks seen are no image of the configured board through the configured camera: the best pose \
             reprojects them up to {fit_px:.1} px away (at most {FIT_PX} px); check [target] or [object] against \
             the print and calibrate the camera (`vservoctl calibrate`): nothing was taught"
        );
    }
    Ok(Taught { joints: seen.joints.clone(), camera_from_board, features, fit_px })
}

/// The configuration's text with `[desired]` taught: `joints_rad` and `camera_from_board` (the rest of the file as
/// it was).
fn edited(edit: &ConfigEdit, taught: &Taught) -> Result<String> {
    let mut document = edit.document()?;
    let round = |v: f64, places: i32| (v * 10f64.powi(places)).round() / 10f64.powi(places);
    let array = |values: &mut dyn Iterator<Item = f64>| {
        let mut array = toml_edit::Array::new();
        values.for_each(|v| array.push(v));
        toml_edit::value(array)
    };
    let (roll, pitch, yaw) = taught.camera_from_board.rotation.euler_angles();
    let translation = taught.camera_from_board.translation.vector;
    let desired = document
        .entry("desired")
        .or_insert_with(|| toml_edit::Item::Table(toml_edit::Table::new()))
        .as_table_like_mut()
        .context("`desired` in the configuration is not a table")?;
    desired.insert("joints_rad", array(&mut taught.joints.iter().map(|&q| round(q, 9))));
    let pose = desired
        .entry("camera_from_board")
        .or_insert(toml_edit::Item::Table(toml_edit::Table::new()))
        .as_table_like_mut()
        .context("`desired.camera_from_board` in the configuration is not a table")?;
    pose.insert("translation_m", array(&mut translation.iter().map(|&v| round(v, 9))));
    let degrees = Vector3::new(roll, pitch, yaw).map(f64::to_degrees);
    pose.insert("rotation_rpy_deg", array(&mut degrees.iter().map(|&v| round(v, 7))));
    Ok(document.to_string())
}

/// Refuses an edit that the configuration would not take as taught (a file over it, or one it extends, sets
/// `[desired]` otherwise).
fn in_force(loaded: &Config, taught: &Taught, path: &std::path::Path) -> Result<()> {
    let desired = &loaded.cell.desired;
    let joints_apart =
        desired.joints.iter().zip(&taught.joints).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let features_apart = (desired.features - taught.features).amax();
    if joints_apart > 1e-6 || features_apart > 1e-3 {
        bail!(
            "{} edited would not take the taught goal (its desired joints {joints_apart:.2e} rad and ξ_d \
             {features_apart:.2e} px away): nothing was written",
            path.display()
        );
    }
    Ok(())
}

fn report(
    args: &TeachArgs,
    seen: &Seen,
    taught: &Taught,
    kept: &std::path::Path,
    reload: &vservo_client::Reply,
) -> Result<()> {
    let t = taught.camera_from_board.translation.vector;
    let (roll, pitch, yaw) = taught.camera_from_board.rotation.euler_angles();
    let rpy = [roll, pitch, yaw].map(f64::to_degrees);
    if args.json {
        let out = json!({
            "config": args.config.display().to_string(),
            "kept": kept.display().to_string(),
            "frames": seen.frames,
            "joints_rad": taught.joints,
            "camera_from_board": {"translation_m": [t.x, t.y, t.z], "rotation_rpy_deg": rpy},
            "target_features_px": taught.features.as_slice(),
            "fit_px": taught.fit_px,
            "reload": {
                "accepted": reload.accepted,
                "reason": reload.reason,
                "target_features_px": reload.target_features_px,
            },
        });
        return Ok(print_stdout(&format!("{out}\n"))?);
    }
    let joints: Vec<String> = taught.joints.iter().map(|q| format!("{q:.4}")).collect();
    let features: Vec<String> = taught.features.iter().map(|v| format!("{v:.1}")).collect();
    let reloaded = if reload.accepted {
        format!("the running instance took it: {}", reload.reason)
    } else {
        format!("the running instance did not take it: {} (restart vservod to run it)", reload.reason)
    };
    Ok(print_stdout(&format!(
        "taught from {} frames with the arm still:\n  desired.joints_rad = [{}]\n  desired.camera_from_board: \
         translation_m = [{:.4}, {:.4}, {:.4}], rotation_rpy_deg = [{:.2}, {:.2}, {:.2}]\n  ξ_d = [{}] px (within \
         {:.2} px of the features seen)\nwrote {} (as it was: {})\n{reloaded}\n",
        seen.frames,
        joints.join(", "),
        t.x,
        t.y,
        t.z,
        rpy[0],
        rpy[1],
        rpy[2],
        features.join(", "),
        taught.fit_px,
        args.config.display(),
        kept.display()
    ))?)
}
