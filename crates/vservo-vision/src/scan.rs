//! The scan tiles of an image too large for one full-resolution quad search in a frame
//! ([`crate::tag::FULL_RESOLUTION_MAX_PIXELS`]): a grid of overlapping tiles, each within the budget, that the
//! tag extractor searches one a frame while it has nothing to track, so that a small tag anywhere in a large
//! image is acquired within as many frames as there are tiles (6 at 1280 × 1024: half a second at the paper's
//! 85 ms).

use crate::tag::{FULL_RESOLUTION_MAX_PIXELS, TILE_GRID_PX};

/// How much neighbouring scan tiles overlap (px): every tag up to this wide lies whole in one of them, and the
/// decimated search finds the larger ones (from 30 px on at 1280 × 1024, docs/VISION.md).
pub const SCAN_OVERLAP_PX: u32 = 64;

/// An image too large for one full-resolution search cut into a grid of overlapping tiles, each within
/// [`FULL_RESOLUTION_MAX_PIXELS`], as few as will do: 2 × 3 at 1280 × 1024.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanTiles {
    width_px: u32,
    height_px: u32,
    columns: u32,
    rows: u32,
}

/// The scan tiles of a `width_px` × `height_px` image (one, the whole image, when it is within the budget).
pub fn scan_tiles(width_px: u32, height_px: u32) -> ScanTiles {
    let tile_px = |length: u32, parts: u32| {
        if parts == 1 { length } else { length.div_ceil(parts) + SCAN_OVERLAP_PX + TILE_GRID_PX }
    };
    let mut best = ScanTiles { width_px, height_px, columns: 16, rows: 16 };
    for columns in 1..=16u32 {
        for rows in 1..=16u32 {
            let fits = u64::from(tile_px(width_px, columns)) * u64::from(tile_px(height_px, rows))
                <= u64::from(FULL_RESOLUTION_MAX_PIXELS);
            if fits && columns * rows < best.columns * best.rows {
                best = ScanTiles { width_px, height_px, columns, rows };
            }
        }
    }
    best
}

impl ScanTiles {
    /// How many tiles.
    pub fn count(&self) -> u32 {
        self.columns * self.rows
    }

    /// Tile `k` (row-major): its share of the image grown by half the overlap on every inner side, starting on
    /// the threshold tiles' grid; (u0, v0, u1, v1), exclusive ends.
    pub fn tile(&self, k: u32) -> (u32, u32, u32, u32) {
        let (column, row) = (k % self.columns, (k / self.columns) % self.rows);
        let span = |index: u32, parts: u32, length: u32| {
            let (start, end) = (index * length / parts, (index + 1) * length / parts);
            let start = if index == 0 { 0 } else { start.saturating_sub(SCAN_OVERLAP_PX / 2) };
            let end = if index + 1 == parts { length } else { (end + SCAN_OVERLAP_PX / 2).min(length) };
            (start / TILE_GRID_PX * TILE_GRID_PX, end)
        };
        let (u0, u1) = span(column, self.columns, self.width_px);
        let (v0, v1) = span(row, self.rows, self.height_px);
        (u0, v0, u1, v1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every tile within the budget (1920 × 1080 takes 5 × 2: 3 × 3 tiles would be 712 × 432 px with their
    /// overlap, 384 px over it), and every square of the overlap's side, anywhere in the image, whole in one
    /// tile: a tag up to that size is never cut by every tile it meets.
    #[test]
    fn the_tiles_keep_the_budget_and_hold_every_small_square_whole() {
        for (width, height, count) in
            [(640, 480, 1), (799, 533, 2), (1280, 1024, 6), (1920, 1080, 10), (4000, 3000, 0)]
        {
            let tiles = scan_tiles(width, height);
            if count > 0 {
                assert_eq!(tiles.count(), count, "{width} × {height}");
            }
            for k in 0..tiles.count() {
                let (u0, v0, u1, v1) = tiles.tile(k);
                assert!(u0 < u1 && u1 <= width && v0 < v1 && v1 <= height, "{width} × {height}, tile {k}");
                assert!((u1 - u0) * (v1 - v0) <= FULL_RESOLUTION_MAX_PIXELS, "{width} × {height}, tile {k}");
                assert_eq!((u0 % TILE_GRID_PX, v0 % TILE_GRID_PX), (0, 0), "on the threshold tiles' grid");
            }
            let side = SCAN_OVERLAP_PX;
            for v in (0..=height - side).step_by(7) {
                for u in (0..=width - side).step_by(7) {
                    let whole = (0..tiles.count())
                        .map(|k| tiles.tile(k))
                        .any(|(u0, v0, u1, v1)| u0 <= u && u + side <= u1 && v0 <= v && v + side <= v1);
                    assert!(whole, "{width} × {height}: the square at ({u}, {v}) is cut by every tile");
                }
            }
        }
    }
}
