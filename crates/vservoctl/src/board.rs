//! `vservoctl board`: the calibration board (a grid of tag36h11 AprilTags, `vservo_scene::TagGrid`) as an SVG to
//! print at scale (its size in millimetres: print at 100 %, then measure the scale bar), and its layout as JSON:
//! every tag's id and its four corners in the board frame, in the AprilTag C library's corner order.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use nalgebra::Point2;
use vservo_scene::{AprilTag, TagGrid};

use crate::UsageError;
use crate::output::print_stdout;

/// Arguments of `vservoctl board`.
#[derive(Args)]
pub struct BoardArgs {
    /// Rows of tags.
    #[arg(long, default_value_t = 5)]
    rows: u32,
    /// Columns of tags.
    #[arg(long, default_value_t = 7)]
    columns: u32,
    /// Edge of each tag's black square (mm). The defaults fit A4 landscape.
    #[arg(long, default_value_t = 28.0)]
    tag_size_mm: f64,
    /// White between two tags (mm); at least a quarter of the tag.
    #[arg(long, default_value_t = 8.0)]
    gap_mm: f64,
    /// The first tag's id (tag36h11); the others follow row by row.
    #[arg(long, default_value_t = 0)]
    first_id: u32,
    #[command(flatten)]
    print: PrintOut,
}

/// Where a print of tags goes (`vservoctl board`, `vservoctl tag`), and whether its layout is printed.
#[derive(Args)]
pub struct PrintOut {
    /// Where to write the SVG (a new name: a link or another user's file there is refused, one's own file too
    /// unless --force).
    #[arg(long, value_name = "FILE.svg")]
    out: PathBuf,
    /// Replace one's own file at --out.
    #[arg(long)]
    force: bool,
    /// Print the layout (each tag's id and corners) as one JSON object.
    #[arg(long)]
    json: bool,
}

impl PrintOut {
    /// Writes `grid` as an SVG with `caption` below it, and its layout as JSON if asked.
    pub fn write(&self, grid: &TagGrid, caption: &[String]) -> Result<()> {
        let tags: Vec<AprilTag> = grid.tags().collect();
        self.write_tags(
            &tags,
            grid.extent_in_board(),
            caption,
            &vservo_calibrate::dataset::board_layout(grid),
        )
    }

    /// Writes `tags` on a sheet of `extent` (board frame, m) as an SVG with `caption` below it, and `layout`
    /// (which must hold `extent_in_board_m` and each tag's id and corners) if asked.
    pub fn write_tags(
        &self,
        tags: &[AprilTag],
        extent: [Point2<f64>; 2],
        caption: &[String],
        layout: &serde_json::Value,
    ) -> Result<()> {
        if self.out.extension().and_then(|e| e.to_str()) != Some("svg") {
            return Err(UsageError(format!("--out {}: the file must end in .svg", self.out.display())).into());
        }
        vservo_config::new_file::write(&self.out, svg(tags, extent, caption).as_bytes(), self.force, 0o644)?;
        if self.json {
            print_stdout(&format!("{layout}\n"))?;
        }
        Ok(())
    }
}

/// Runs the command.
pub fn run(args: &BoardArgs) -> Result<()> {
    let grid =
        TagGrid::new(args.rows, args.columns, args.tag_size_mm / 1e3, args.gap_mm / 1e3, args.first_id)
            .map_err(|e| UsageError(format!("the board: {e}")))?;
    let caption = format!(
        "tag36h11, {} × {} tags of {} mm, {} mm apart, ids {}–{}; print at 100 %",
        grid.rows(),
        grid.columns(),
        args.tag_size_mm,
        args.gap_mm,
        grid.tag(0).map_or(0, |t| t.id()),
        grid.tag(grid.len() - 1).map_or(0, |t| t.id()),
    );
    args.print.write(&grid, &[caption])
}

/// The tags on a sheet of `extent` as an SVG in millimetres: the board's x to the right and its y down, as an
/// upright camera facing it sees it; each row of black cells one rectangle per run; below, a scale bar (50 mm,
/// or 20 or 10 on a narrow print) and the caption's lines.
pub fn svg(tags: &[AprilTag], [low, high]: [Point2<f64>; 2], caption: &[String]) -> String {
    let mm = |m: f64| m * 1e3;
    let (width, height) = (mm(high.x - low.x), mm(high.y - low.y));
    let line_mm = 5.0;
    let footer = 8.0 + line_mm * caption.len() as f64;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.3}mm" height="{:.3}mm" viewBox="0 0 {width:.3} {:.3}">"#,
        height + footer,
        height + footer
    );
    let _ = writeln!(
        out,
        r#"<rect x="0" y="0" width="{width:.3}" height="{:.3}" fill="white"/>"#,
        height + footer
    );
    for tag in tags {
        let size_m = tag.size_m();
        let cell = size_m / f64::from(vservo_scene::tag36h11::WIDTH_AT_BORDER);
        let c = tag.centre_in_board();
        let side = vservo_scene::tag36h11::WIDTH_AT_BORDER as usize;
        for row in 0..side {
            let y = c.y - 0.5 * size_m + (row as f64 + 0.5) * cell;
            let mut column = 0;
            while column < side {
                let x = |k: usize| c.x - 0.5 * size_m + (k as f64 + 0.5) * cell;
                if tag.is_black_at(x(column), y) != Some(true) {
                    column += 1;
                    continue;
                }
                let start = column;
                while column < side && tag.is_black_at(x(column), y) == Some(true) {
                    column += 1;
                }
                let left = c.x - 0.5 * size_m + start as f64 * cell;
                let top = y - 0.5 * cell;
                let _ = writeln!(
                    out,
                    r#"<rect x="{:.4}" y="{:.4}" width="{:.4}" height="{:.4}" fill="black"/>"#,
                    mm(left - low.x),
                    mm(top - low.y),
                    mm((column - start) as f64 * cell),
                    mm(cell)
                );
            }
        }
    }
    let bar_y = height + 3.0;
    let bar_mm = [50.0, 20.0, 10.0].into_iter().find(|bar| *bar + 10.0 <= width).unwrap_or(5.0);
    let _ = writeln!(out, r#"<rect x="2" y="{bar_y:.3}" width="{bar_mm}" height="2" fill="black"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{:.3}" y="{:.3}" font-family="sans-serif" font-size="3.5">{bar_mm} mm</text>"#,
        bar_mm + 4.0,
        bar_y + 2.0
    );
    for (i, line) in caption.iter().enumerate() {
        let _ = writeln!(
            out,
            r#"<text x="2" y="{:.3}" font-family="sans-serif" font-size="3.5">{}</text>"#,
            bar_y + 2.0 + line_mm * (i as f64 + 1.0),
            line.replace('&', "&amp;").replace('<', "&lt;")
        );
    }
    out.push_str("</svg>\n");
    out
}
