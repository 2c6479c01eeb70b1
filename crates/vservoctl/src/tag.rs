//! `vservoctl tag`: one tag36h11 AprilTag as an SVG to print at scale, for a target of `[target] kind = "apriltag"`:
//! its black square the size given, a white margin around it (a tag is found only with white around its black
//! border), a scale bar to measure after printing, and a caption saying the id, the family, the size and which
//! edge is up. Its layout (the corners in the tag's frame) as JSON.

use anyhow::Result;
use clap::Args;
use vservo_scene::TagGrid;

use crate::UsageError;

/// Arguments of `vservoctl tag`.
#[derive(Args)]
pub struct TagArgs {
    /// The tag's id (tag36h11: 0 to 586): `[target] id` in the configuration.
    #[arg(long)]
    id: u32,
    /// The edge of its black square (mm), as printed: `[target] tag_size_m` × 1000.
    #[arg(long)]
    size_mm: f64,
    #[command(flatten)]
    print: crate::board::PrintOut,
}

/// Runs the command.
pub fn run(args: &TagArgs) -> Result<()> {
    // one tag with a white margin of a quarter of its side all round
    let grid = TagGrid::new(1, 1, args.size_mm / 1e3, args.size_mm / 4e3, args.id)
        .map_err(|e| UsageError(format!("the tag: {e}")))?;
    let caption = [
        format!("tag36h11 id {}, black square {} mm", args.id, args.size_mm),
        "the top of the page is the tag's top (its frame's −y); x to the right".to_string(),
        "print at 100 %, then measure the bar".to_string(),
    ];
    args.print.write(&grid, &caption)
}
