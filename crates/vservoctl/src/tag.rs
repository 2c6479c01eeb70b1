//! `vservoctl tag`: one tag36h11 AprilTag as an SVG to print at scale, for a target of `[target] kind = "apriltag"`:
//! its black square the size given, a white margin around it (a tag is found only with white around its black
//! border), a scale bar to measure after printing, and a caption saying the id, the family, the size and which
//! edge is up. Its layout (the corners in the tag's frame) as JSON. With `--config`, the configured target
//! instead: its tag, or its bundle of tags on one sheet, each where the configuration puts it.

use anyhow::Result;
use clap::Args;
use serde_json::json;
use vservo_scene::{Board, TagGrid, Target};

use crate::UsageError;
use crate::config_arg::ConfigArg;

/// Arguments of `vservoctl tag`.
#[derive(Args)]
pub struct TagArgs {
    /// The tag's id (tag36h11: 0 to 586): `[target] id` in the configuration.
    #[arg(long, required_unless_present = "config", conflicts_with = "config")]
    id: Option<u32>,
    /// The edge of its black square (mm), as printed: `[target] tag_size_m` × 1000.
    #[arg(long, required_unless_present = "config", conflicts_with = "config")]
    size_mm: Option<f64>,
    /// Print the target of this configuration (`[target]`: one tag, or a bundle's tags on one sheet).
    #[arg(long, value_name = "FILE")]
    config: Option<std::path::PathBuf>,
    #[command(flatten)]
    print: crate::board::PrintOut,
}

/// Runs the command.
pub fn run(args: &TagArgs) -> Result<()> {
    match (&args.config, args.id, args.size_mm) {
        (Some(path), _, _) => configured(&ConfigArg { config: path.clone() }.load()?.cell.board, args),
        (None, Some(id), Some(size_mm)) => one_tag(id, size_mm, args),
        _ => Err(UsageError("give --id and --size-mm, or --config".into()).into()),
    }
}

/// One tag with a white margin of a quarter of its side all round.
fn one_tag(id: u32, size_mm: f64, args: &TagArgs) -> Result<()> {
    let grid = TagGrid::new(1, 1, size_mm / 1e3, size_mm / 4e3, id)
        .map_err(|e| UsageError(format!("the tag: {e}")))?;
    let caption = [
        format!("tag36h11 id {id}, black square {size_mm} mm"),
        "the top of the page is the tag's top (its frame's −y); x to the right".to_string(),
        "print at 100 %, then measure the bar".to_string(),
    ];
    args.print.write(&grid, &caption)
}

/// The configured target's tags on their sheet, each where the board frame puts it; the caption says where the
/// board frame's origin is on the sheet, so that the print can be placed as the configuration says.
fn configured(board: &Board, args: &TagArgs) -> Result<()> {
    let (tags, extent) = match &board.target {
        Target::AprilTag(tag) => (vec![*tag], tag.sheet_extent_in_board()),
        Target::Bundle(bundle) => (bundle.tags().to_vec(), bundle.sheet_extent_in_board()),
        Target::Marks => {
            return Err(UsageError(
                "the configuration's target is disc marks ([target] kind = \"marks\"): no tag to print"
                    .into(),
            )
            .into());
        }
    };
    let [low, high] = extent;
    let sizes: Vec<String> = tags.iter().map(|t| format!("{} mm", t.size_m() * 1e3)).collect();
    let ids: Vec<String> = tags.iter().map(|t| t.id().to_string()).collect();
    let caption = [
        format!(
            "tag36h11, {} tag(s): ids {}; black squares {}",
            tags.len(),
            ids.join(", "),
            sizes.join(", ")
        ),
        format!(
            "the board frame's origin is {:.1} mm right of the sheet's left edge and {:.1} mm below its top",
            -low.x * 1e3,
            -low.y * 1e3
        ),
        "the top of the page is the board's −y; x to the right; print at 100 %, then measure the bar"
            .to_string(),
    ];
    let layout_tags: Vec<_> = tags
        .iter()
        .map(|tag| {
            let corners: Vec<[f64; 3]> = tag.corners_in_board().iter().map(|p| [p.x, p.y, p.z]).collect();
            let c = tag.centre_in_board();
            json!({"id": tag.id(), "tag_size_m": tag.size_m(), "centre_in_board_m": [c.x, c.y], "corners_in_board_m": corners})
        })
        .collect();
    let features: Vec<[f64; 3]> = board.marks_in_board.iter().map(|p| [p.x, p.y, p.z]).collect();
    let layout = json!({
        "family": "tag36h11",
        "kind": if board.bundle().is_some() { "bundle" } else { "apriltag" },
        "extent_in_board_m": [[low.x, low.y], [high.x, high.y]],
        "tags": layout_tags,
        "features_in_board_m": features,
    });
    args.print.write_tags(&tags, extent, &caption, &layout)
}
