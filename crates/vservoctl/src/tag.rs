//! `vservoctl tag`: one tag36h11 AprilTag as an SVG to print at scale, for a target of `[target] kind = "tag"`:
//! its black square the size given, a white margin around it (a tag is found only with white around its black
//! border), a scale bar to measure after printing, and a caption saying the id, the family, the size and which
//! edge is up. Its layout (the corners in the tag's frame) as JSON.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use vservo_scene::TagGrid;

use crate::UsageError;
use crate::output::print_stdout;

/// Arguments of `vservoctl tag`.
#[derive(Args)]
pub struct TagArgs {
    /// The tag's id (tag36h11: 0 to 586); `[target] tag_id` in the configuration.
    #[arg(long)]
    id: u32,
    /// The edge of its black square (mm), as printed: `[target] tag_size_m` × 1000.
    #[arg(long)]
    size_mm: f64,
    /// Where to write the SVG (a new name: a link or another user's file there is refused, one's own file too
    /// unless --force).
    #[arg(long, value_name = "FILE.svg")]
    out: PathBuf,
    /// Replace one's own file at --out.
    #[arg(long)]
    force: bool,
    /// Print the layout (the tag's corners in its frame) as one JSON object.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: &TagArgs) -> Result<()> {
    // one tag with a white margin of a quarter of its side all round
    let grid = TagGrid::new(1, 1, args.size_mm / 1e3, args.size_mm / 4e3, args.id)
        .map_err(|e| UsageError(format!("the tag: {e}")))?;
    if args.out.extension().and_then(|e| e.to_str()) != Some("svg") {
        return Err(UsageError(format!("--out {}: the file must end in .svg", args.out.display())).into());
    }
    let caption = [
        format!("tag36h11 id {}, black square {} mm", args.id, args.size_mm),
        "the top of the page is the tag's top (its frame's −y); x to the right".to_string(),
        "print at 100 %, then measure the bar".to_string(),
    ];
    crate::new_file::write(&args.out, crate::board::svg(&grid, &caption).as_bytes(), args.force, 0o644)?;
    if args.json {
        print_stdout(&format!("{}\n", crate::board::layout(&grid)))?;
    }
    Ok(())
}
