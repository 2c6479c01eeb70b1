//! `vservoctl vision render` and `vservoctl vision extract`: what the simulated camera sees at a joint
//! configuration, and the features in any image — so that users can check a setup on their own images.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use serde_json::json;
use vservo_vision::extract::{Extractor, Prediction};
use vservo_vision::source::read_image_as_gray;
use vservo_vision::{MarkStatus, Renderer};

use crate::UsageError;
use crate::config_arg::ConfigArg;
use crate::joint_args::parse_joint_vector;
use crate::output::print_stdout;

/// Arguments of `vservoctl vision`.
#[derive(Args)]
pub struct VisionArgs {
    #[command(subcommand)]
    command: VisionCommand,
}

#[derive(Subcommand)]
enum VisionCommand {
    /// Render what the hand camera sees with the arm at a joint configuration.
    Render(RenderArgs),
    /// Extract the four marks' features from an 8-bit grayscale PNG or PGM image.
    Extract(ExtractArgs),
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Joint angles q1,…,qn in radians, one per joint of the configured arm, or (the PUMA 560) a named pose
    /// (qz, qr, qs, qn).
    #[arg(long, allow_hyphen_values = true)]
    q: String,
    /// The image file to write (.png or .pgm).
    #[arg(long, value_name = "IMAGE")]
    out: PathBuf,
    /// Frame number, which varies the noise.
    #[arg(long, default_value_t = 0)]
    frame: u64,
}

#[derive(Args)]
struct ExtractArgs {
    /// The image (8-bit grayscale PNG or PGM, of the configured size).
    image: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: &VisionArgs) -> Result<()> {
    match &args.command {
        VisionCommand::Render(a) => render(a),
        VisionCommand::Extract(a) => extract(a),
    }
}

fn render(args: &RenderArgs) -> Result<()> {
    let config = args.config.load()?;
    let arm = &config.cell.arm;
    let is_puma = *arm == vservo_arm::puma560::puma560();
    let q = parse_joint_vector("--q", &args.q, is_puma, arm.joint_count())?;
    arm.check_positions(&q).map_err(|v| UsageError(format!("--q: {v} (the {}'s range)", arm.name)))?;
    let extension = args.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(extension.as_deref(), Some("png" | "pgm")) {
        return Err(
            UsageError(format!("--out {}: the file must end in .png or .pgm", args.out.display())).into()
        );
    }
    let camera_from_board = config.cell.camera_from_board_at(arm, &q);
    let mut renderer = Renderer::new(config.cell.camera, config.cell.vision.render);
    let image = renderer.render(&config.cell.board, &camera_from_board, args.frame);
    image.save(&args.out).with_context(|| format!("writing {}", args.out.display()))?;
    let visible = config.cell.camera.project_marks(&config.cell.board, &camera_from_board);
    let note = match visible {
        Ok(features) => format!("marks at {:.1?} px", features.as_slice()),
        Err(e) => e.to_string(),
    };
    eprintln!("wrote {} ({}×{}); {note}", args.out.display(), image.width(), image.height());
    Ok(())
}

fn extract(args: &ExtractArgs) -> Result<()> {
    let config = args.config.load()?;
    let (image, _) = read_image_as_gray(&args.image).map_err(|e| UsageError(e.to_string()))?;
    let mut extractor = Extractor::new(
        config.cell.vision.extractor,
        config.cell.camera.width_px(),
        config.cell.camera.height_px(),
    );
    // with an AprilTag target (or a bundle), its four corners; a target not found gives each corner its verdict
    let board = &config.cell.board;
    let (found, tag_verdict) = match vservo_vision::TagExtractor::for_board(board, &config.cell.camera) {
        Some(tags) => {
            let found = tags.extract(&image, None);
            let ids: Vec<String> = board.target_tags().iter().map(|tag| tag.id().to_string()).collect();
            let verdict = (found.verdict != vservo_vision::TagVerdict::Found)
                .then(|| format!("tag {}: {}", ids.join(", "), found.verdict.reason()));
            (found.to_extraction(), verdict)
        }
        None => (extractor.extract(&image, &Prediction::Layout(config.cell.desired.features)), None),
    };
    let features: Vec<Option<f64>> =
        found.features.iter().map(|&v| if v.is_finite() { Some(v) } else { None }).collect();
    let reasons: Vec<String> = match &tag_verdict {
        Some(verdict) => vec![verdict.clone(); found.status.len()],
        None => found.status.iter().map(MarkStatus::reason).collect(),
    };
    if args.json {
        let out = json!({
            "image": args.image.display().to_string(),
            "features": features,
            "valid": found.valid(),
            "reasons": reasons,
            "extra_blobs": found.extra_blobs,
            "threshold": found.threshold,
        });
        print_stdout(&format!("{out}\n"))?;
        return Ok(());
    }
    let mut out = format!(
        "{}: threshold {}, {} extra dark blob(s)\n",
        args.image.display(),
        found.threshold,
        found.extra_blobs
    );
    for (mark, status) in found.status.iter().enumerate() {
        let line = if status.is_valid() {
            format!(
                "  mark {}: ({:.3}, {:.3}) px\n",
                mark + 1,
                found.features[2 * mark],
                found.features[2 * mark + 1]
            )
        } else {
            format!("  mark {}: {}\n", mark + 1, reasons[mark])
        };
        out += &line;
    }
    print_stdout(&out)?;
    Ok(())
}
