//! A calibration board: a grid of tag36h11 AprilTags with white gaps between them (the layout of OpenCV's
//! `aruco::GridBoard` with the AprilTag 36h11 dictionary; Kalibr's "AprilGrid" draws squares into the gaps,
//! which the AprilTag 3 detector cannot read). Every tag is a [`AprilTag`]: its four corners are known board
//! points, each found with its id, so that any view that sees part of the board gives correspondences.
//!
//! The board frame is the one of [`crate::Board`]: the tags lie in its z = 0 plane, centred on its origin, rows
//! along +y and columns along +x; tag (row, column) has id `first_id + row · columns + column`.

use nalgebra::Point2;

use crate::board::{AprilTag, SHEET_MARGIN_CELLS, UnknownTagId};
use crate::tag36h11;

/// The grid's layout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagGrid {
    rows: u32,
    columns: u32,
    /// Edge of each tag's black square (m).
    tag_size_m: f64,
    /// White between two tags' black squares (m).
    gap_m: f64,
    first_id: u32,
}

/// Why a grid cannot be made.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TagGridError {
    /// Fewer than 1 or more than 64 rows or columns.
    #[error("a grid has 1 to 64 rows and columns; {rows} × {columns} is not one")]
    Shape {
        /// Rows asked for.
        rows: u32,
        /// Columns asked for.
        columns: u32,
    },
    /// The tag size is not a positive length up to 1 m, or the gap is narrower than the white border the
    /// detector needs around each tag (one cell: a quarter of the tag's size between two tags) or wider than
    /// the tag.
    #[error(
        "tags of {tag_size_m} m with gaps of {gap_m} m: the tag must be 1 mm to 1 m, the gap from a quarter of the tag (its white border) to the tag's size"
    )]
    Size {
        /// Tag size asked for (m).
        tag_size_m: f64,
        /// Gap asked for (m).
        gap_m: f64,
    },
    /// The ids run past the family's.
    #[error(transparent)]
    Id(#[from] UnknownTagId),
}

impl TagGrid {
    /// A grid of `rows` × `columns` tags of `tag_size_m`, `gap_m` apart, ids from `first_id`.
    pub fn new(
        rows: u32,
        columns: u32,
        tag_size_m: f64,
        gap_m: f64,
        first_id: u32,
    ) -> Result<Self, TagGridError> {
        if !(1..=64).contains(&rows) || !(1..=64).contains(&columns) {
            return Err(TagGridError::Shape { rows, columns });
        }
        let border = tag_size_m * 2.0 / f64::from(tag36h11::WIDTH_AT_BORDER);
        let fits = (0.001..=1.0).contains(&tag_size_m) && (border..=tag_size_m).contains(&gap_m);
        if !fits {
            return Err(TagGridError::Size { tag_size_m, gap_m });
        }
        let last = u64::from(first_id) + u64::from(rows) * u64::from(columns) - 1;
        if last >= tag36h11::CODES.len() as u64 {
            return Err(UnknownTagId { id: u32::try_from(last).unwrap_or(u32::MAX) }.into());
        }
        Ok(Self { rows, columns, tag_size_m, gap_m, first_id })
    }

    /// Rows of tags.
    pub fn rows(&self) -> u32 {
        self.rows
    }

    /// Columns of tags.
    pub fn columns(&self) -> u32 {
        self.columns
    }

    /// Edge of each tag's black square (m).
    pub fn tag_size_m(&self) -> f64 {
        self.tag_size_m
    }

    /// White between two tags (m).
    pub fn gap_m(&self) -> f64 {
        self.gap_m
    }

    /// How many tags.
    pub fn len(&self) -> usize {
        (self.rows * self.columns) as usize
    }

    /// Whether it has no tags (never: a grid has at least one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Centre-to-centre distance of neighbouring tags (m).
    fn pitch_m(&self) -> f64 {
        self.tag_size_m + self.gap_m
    }

    /// Tag `index` (row-major: `row · columns + column`), `None` past the last.
    #[inline]
    pub fn tag(&self, index: usize) -> Option<AprilTag> {
        if index >= self.len() {
            return None;
        }
        let (row, column) = (index as u32 / self.columns, index as u32 % self.columns);
        let centre = |k: u32, n: u32| (f64::from(k) - 0.5 * f64::from(n - 1)) * self.pitch_m();
        let centre_in_board = Point2::new(centre(column, self.columns), centre(row, self.rows));
        AprilTag::tag36h11(self.first_id + index as u32, self.tag_size_m, centre_in_board).ok()
    }

    /// Every tag, row-major.
    pub fn tags(&self) -> impl Iterator<Item = AprilTag> + '_ {
        (0..self.len()).filter_map(|i| self.tag(i))
    }

    /// The tag with id `id`, if the grid has it.
    pub fn tag_with_id(&self, id: u32) -> Option<AprilTag> {
        id.checked_sub(self.first_id).and_then(|i| self.tag(i as usize))
    }

    /// The tags whose pitch cell (the tag and half the gap around it) meets the box from `low` to `high`
    /// (board frame, m): every tag that can have a black cell in it.
    #[inline]
    pub fn tags_meeting(&self, low: Point2<f64>, high: Point2<f64>) -> impl Iterator<Item = AprilTag> + '_ {
        let range = |low: f64, high: f64, n: u32| {
            // a NaN bound meets nothing
            if low.is_nan() || high.is_nan() || low > high {
                return 0..0;
            }
            let index = |v: f64| (v / self.pitch_m() + 0.5 * f64::from(n)).floor();
            let (first, last) = (index(low).max(0.0), index(high).min(f64::from(n) - 1.0));
            // NaN or an empty range gives no indices
            if first <= last { first as u32..last as u32 + 1 } else { 0..0 }
        };
        let rows = range(low.y, high.y, self.rows);
        let columns = range(low.x, high.x, self.columns);
        rows.flat_map(move |row| columns.clone().map(move |column| (row, column)))
            .filter_map(|(row, column)| self.tag((row * self.columns + column) as usize))
    }

    /// The square (lowest and highest x, y; board frame, m) that holds every tag's black square.
    pub fn tags_extent_in_board(&self) -> [Point2<f64>; 2] {
        let half = |n: u32| 0.5 * (f64::from(n) * self.tag_size_m + f64::from(n - 1) * self.gap_m);
        let (hx, hy) = (half(self.columns), half(self.rows));
        [Point2::new(-hx, -hy), Point2::new(hx, hy)]
    }

    /// The white board around the tags, one white border (a tag cell) wider than the outer tags' white
    /// rings: lowest and highest (x, y) in the board frame (m).
    pub fn extent_in_board(&self) -> [Point2<f64>; 2] {
        let cell = self.tag_size_m / f64::from(tag36h11::WIDTH_AT_BORDER);
        let half = |n: u32| {
            0.5 * (f64::from(n) * self.tag_size_m + f64::from(n - 1) * self.gap_m) + SHEET_MARGIN_CELLS * cell
        };
        let (hx, hy) = (half(self.columns), half(self.rows));
        [Point2::new(-hx, -hy), Point2::new(hx, hy)]
    }

    /// Whether a point of the board plane is black: on one of the tags' black cells.
    pub fn is_black_at(&self, x_m: f64, y_m: f64) -> bool {
        // the tag whose pitch cell holds the point, and only it, can be black there
        let index = |v: f64, n: u32| {
            let k = (v / self.pitch_m() + 0.5 * f64::from(n)).floor();
            (k >= 0.0 && k < f64::from(n)).then_some(k as u32)
        };
        match (index(x_m, self.columns), index(y_m, self.rows)) {
            (Some(column), Some(row)) => self
                .tag((row * self.columns + column) as usize)
                .and_then(|tag| tag.is_black_at(x_m, y_m))
                .unwrap_or(false),
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_are_centred_on_the_origin_row_major_with_their_ids() {
        let grid = TagGrid::new(2, 3, 0.04, 0.01, 10).expect("a grid");
        assert_eq!(grid.len(), 6);
        let first = grid.tag(0).expect("tag 0");
        assert_eq!(first.id(), 10);
        assert!((first.centre_in_board() - Point2::new(-0.05, -0.025)).norm() < 1e-12);
        let last = grid.tag(5).expect("tag 5");
        assert_eq!(last.id(), 15);
        assert!((last.centre_in_board() - Point2::new(0.05, 0.025)).norm() < 1e-12);
        assert_eq!(grid.tag_with_id(13).map(|t| t.id()), Some(13));
        assert_eq!(grid.tag_with_id(9), None);
        assert_eq!(grid.tag_with_id(16), None);
        assert_eq!(grid.tag(6), None);
    }

    #[test]
    fn black_where_a_tag_is_black_and_white_in_the_gaps_and_around() {
        let grid = TagGrid::new(2, 2, 0.08, 0.02, 0).expect("a grid");
        for tag in grid.tags() {
            let c = tag.centre_in_board();
            // the tag's border cells are black
            assert!(grid.is_black_at(c.x - 0.039, c.y));
            assert_eq!(
                grid.is_black_at(c.x + 0.001, c.y + 0.001),
                tag.is_black_at(c.x + 0.001, c.y + 0.001) == Some(true)
            );
        }
        // the cross between the four tags and the margin are white
        assert!(!grid.is_black_at(0.0, 0.0));
        assert!(!grid.is_black_at(0.0, 0.05));
        let [low, high] = grid.extent_in_board();
        assert!(!grid.is_black_at(low.x + 1e-4, 0.05) && !grid.is_black_at(high.x - 1e-4, 0.05));
        assert!((high.x - (0.09 + 0.02)).abs() < 1e-12, "{high}");
    }

    #[test]
    fn the_tags_meeting_a_box_are_those_whose_pitch_cell_it_touches() {
        let grid = TagGrid::new(3, 4, 0.04, 0.01, 0).expect("a grid");
        let ids = |low: (f64, f64), high: (f64, f64)| -> Vec<u32> {
            grid.tags_meeting(Point2::new(low.0, low.1), Point2::new(high.0, high.1))
                .map(|t| t.id())
                .collect()
        };
        // pitch 0.05: columns span [-0.1, -0.05, 0, 0.05, 0.1], rows [-0.075, -0.025, 0.025, 0.075]
        assert_eq!(ids((0.001, -0.02), (0.002, -0.01)), vec![6]);
        assert_eq!(ids((-0.001, -0.03), (0.001, -0.02)), vec![1, 2, 5, 6]);
        assert_eq!(ids((-1.0, -1.0), (1.0, 1.0)).len(), 12);
        assert!(ids((0.2, 0.0), (0.3, 0.1)).is_empty(), "right of the grid");
        assert!(ids((f64::NAN, 0.0), (0.0, 0.0)).is_empty());
        let [low, high] = grid.tags_extent_in_board();
        assert!((high.x - 0.095).abs() < 1e-12 && (low.y + 0.07).abs() < 1e-12, "{low} {high}");
    }

    #[test]
    fn shapes_sizes_and_ids_it_cannot_make_are_refused() {
        assert!(matches!(TagGrid::new(0, 3, 0.04, 0.01, 0), Err(TagGridError::Shape { .. })));
        assert!(matches!(TagGrid::new(2, 65, 0.04, 0.01, 0), Err(TagGridError::Shape { .. })));
        assert!(
            matches!(TagGrid::new(2, 2, 0.04, 0.005, 0), Err(TagGridError::Size { .. })),
            "gap under a border"
        );
        assert!(matches!(TagGrid::new(2, 2, f64::NAN, 0.01, 0), Err(TagGridError::Size { .. })));
        assert!(matches!(TagGrid::new(2, 2, 0.04, f64::INFINITY, 0), Err(TagGridError::Size { .. })));
        assert!(matches!(TagGrid::new(24, 24, 0.04, 0.01, 20), Err(TagGridError::Id(_))), "past id 586");
        assert!(TagGrid::new(24, 24, 0.04, 0.01, 0).is_ok());
    }
}
