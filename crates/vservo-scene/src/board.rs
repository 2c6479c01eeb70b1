//! The object: a flat board with four dark disc marks, or with one AprilTag whose four corners are the marks.

use nalgebra::{Point2, Point3};

use crate::bundle::TagBundle;
use crate::tag_grid::TagGrid;
use crate::tag36h11;

/// Number of marks on the board.
pub const MARKS: usize = 4;

/// The board and its marks. The board frame has its z axis along the board's normal, pointing away from
/// the side the camera looks at; the marks lie in its z = 0 plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Mark centres in the board frame (m), in the fixed feature order. With an AprilTag target, the tag's
    /// four corners in the tag's own order ([`AprilTag::corners_in_board`]).
    pub marks_in_board: [Point3<f64>; MARKS],
    /// Diameter of each disc mark (m); unused with an AprilTag target.
    pub mark_diameter_m: f64,
    /// The white board's rectangle in the board frame's z = 0 plane: its lowest and highest (x, y) (m).
    pub extent_in_board: [Point2<f64>; 2],
    /// What is printed on the board: the disc marks, or one AprilTag.
    pub target: Target,
    /// A calibration board printed on it as well, centred on the board frame's origin (`vservoctl calibrate`
    /// detects its tags). Where the target's tag lies inside the grid it is one of the grid's tags, and inside
    /// its black square the target is drawn (a scenario's cover on a corner shows white there).
    pub calibration_grid: Option<TagGrid>,
}

/// What is printed on the board, and so what the four features are.
#[derive(Debug, Clone, Copy, PartialEq)]
#[expect(
    clippy::large_enum_variant,
    reason = "a bundle's 8 tags inline (about 330 bytes) keep the board `Copy` and free of allocation; a board is \
              copied per stage and per occluded frame, never per pixel"
)]
pub enum Target {
    /// Four dark discs at `marks_in_board` (the paper's).
    Marks,
    /// One tag36h11 AprilTag; the features are its four corners.
    AprilTag(AprilTag),
    /// Several tags on the board; the features are the corners of the box that holds them
    /// ([`TagBundle::outer_corners_in_board`]).
    Bundle(TagBundle),
}

/// One tag of the tag36h11 family lying on the board, its rows along the board's +y axis and its columns
/// along +x (so, seen fronto-parallel with an upright camera, it appears as printed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AprilTag {
    id: u16,
    /// Edge of the black square (m).
    size_m: f64,
    /// The black square's centre in the board frame (m).
    centre_in_board: Point2<f64>,
    /// The 8 × 8 cells of the black square, bit `8·row + column` set where the cell is black.
    black_cells: u64,
}

/// The id is not one of the family's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("tag36h11 has ids 0 to {} only; {id} is not one", tag36h11::CODES.len() - 1)]
pub struct UnknownTagId {
    /// The id asked for.
    pub id: u32,
}

impl AprilTag {
    /// Tag `id` of tag36h11 with a black square `size_m` on a side centred at `centre_in_board`.
    pub fn tag36h11(id: u32, size_m: f64, centre_in_board: Point2<f64>) -> Result<Self, UnknownTagId> {
        match u16::try_from(id) {
            Ok(small) if (small as usize) < tag36h11::CODES.len() => {
                Ok(Self { id: small, size_m, centre_in_board, black_cells: BLACK_CELLS[small as usize] })
            }
            _ => Err(UnknownTagId { id }),
        }
    }

    /// Its id in the family.
    pub fn id(&self) -> u32 {
        u32::from(self.id)
    }

    /// Its 36-bit code (`tag36h11::CODES[id]`).
    pub fn code(&self) -> u64 {
        tag36h11::CODES[self.id as usize]
    }

    /// Edge of the black square (m).
    pub fn size_m(&self) -> f64 {
        self.size_m
    }

    /// The black square's centre in the board frame (m).
    pub fn centre_in_board(&self) -> Point2<f64> {
        self.centre_in_board
    }

    /// The four outer corners of the black square in the board frame, in the C library's order: in tag
    /// coordinates (x along the columns, y along the rows, ±1 at the black square's edges) (−1, +1),
    /// (+1, +1), (+1, −1), (−1, −1): bottom left, bottom right, top right, top left of the tag as printed
    /// (counter-clockwise in an image with y down, as `apriltag_detection_t::p` wraps).
    pub fn corners_in_board(&self) -> [Point3<f64>; MARKS] {
        let h = 0.5 * self.size_m;
        let c = self.centre_in_board;
        [(-1.0, 1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)]
            .map(|(x, y)| Point3::new(c.x + x * h, c.y + y * h, 0.0))
    }

    /// The tag with a white patch over each corner k set in `corners` (bit k, the corners' order): the 3 × 3
    /// cells of the black square at that corner turn white, its border and code bits with them (a sticker
    /// or a finger over a corner; what a scenario's occlusion of "mark" k does to a tag).
    pub fn with_corners_covered(&self, corners: u8) -> AprilTag {
        let mut tag = *self;
        let cells = tag36h11::WIDTH_AT_BORDER;
        for (k, (x, y)) in [(-1, 1), (1, 1), (1, -1), (-1, -1)].into_iter().enumerate() {
            if corners & (1 << k) == 0 {
                continue;
            }
            let (columns, rows) =
                (if x < 0 { 0..3 } else { cells - 3..cells }, if y < 0 { 0..3 } else { cells - 3..cells });
            for row in rows {
                for column in columns.clone() {
                    tag.black_cells &= !(1u64 << (row * cells + column));
                }
            }
        }
        tag
    }

    /// Whether cell (`column`, `row`) of the black square is black (columns along +x, rows along +y, 0 to 7
    /// each, as [`AprilTag::is_black_at`] counts them); `false` for a cell off the square (the white margin is
    /// the board itself).
    pub fn is_black_cell(&self, column: f64, row: f64) -> bool {
        let cells = f64::from(tag36h11::WIDTH_AT_BORDER);
        if !((0.0..cells).contains(&column) && (0.0..cells).contains(&row)) {
            return false;
        }
        let (column, row) = (column as u32, row as u32);
        self.black_cells >> (row * tag36h11::WIDTH_AT_BORDER + column) & 1 == 1
    }

    /// Whether a point of the board plane is on a black cell of the tag (its border or a 0 bit); `None` off
    /// the black square (the white margin is the board itself).
    pub fn is_black_at(&self, x_m: f64, y_m: f64) -> Option<bool> {
        let cells = f64::from(tag36h11::WIDTH_AT_BORDER);
        // cell coordinates: 0..8 across the black square, the columns along +x and the rows along +y
        let u = ((x_m - self.centre_in_board.x) / self.size_m + 0.5) * cells;
        let v = ((y_m - self.centre_in_board.y) / self.size_m + 0.5) * cells;
        ((0.0..cells).contains(&u) && (0.0..cells).contains(&v))
            .then(|| self.is_black_cell(u.floor(), v.floor()))
    }

    /// The white sheet the tag is printed on alone (`vservoctl tag`): the black square and
    /// [`SHEET_MARGIN_CELLS`] cells of white all round (a quarter of its side): lowest and highest (x, y) in the
    /// board frame (m).
    pub fn sheet_extent_in_board(&self) -> [Point2<f64>; 2] {
        let cells = f64::from(tag36h11::WIDTH_AT_BORDER);
        let half = self.size_m * (0.5 + SHEET_MARGIN_CELLS / cells);
        let c = self.centre_in_board;
        [Point2::new(c.x - half, c.y - half), Point2::new(c.x + half, c.y + half)]
    }
}

/// The white round a printed tag's (or a calibration grid's) black squares, in tag cells: one cell more than
/// the white ring the detector needs.
pub const SHEET_MARGIN_CELLS: f64 = 2.0;

/// The black cells of tag `id`: all, but those of the code's 1 bits.
const fn black_cells(id: usize) -> u64 {
    let code = tag36h11::CODES[id];
    let mut cells = u64::MAX;
    let mut i = 0;
    while i < tag36h11::BITS {
        if code >> (tag36h11::BITS - 1 - i) & 1 == 1 {
            let cell = tag36h11::BIT_Y[i] as u32 * tag36h11::WIDTH_AT_BORDER + tag36h11::BIT_X[i] as u32;
            cells &= !(1u64 << cell);
        }
        i += 1;
    }
    cells
}

/// Every tag's black cells, made at compile time (a grid's renderer makes its tags pixel by pixel).
static BLACK_CELLS: [u64; tag36h11::CODES.len()] = {
    let mut table = [0; tag36h11::CODES.len()];
    let mut id = 0;
    while id < table.len() {
        table[id] = black_cells(id);
        id += 1;
    }
    table
};

impl Board {
    /// The paper's board (docs/REPRODUCTION.md): marks placed so that, 0.5 m fronto-parallel in front of the paper's
    /// camera, they image exactly at ξ_d = [151, 168, 318, 178, 339, 75, 172, 70] px; 15 mm discs.
    pub fn paper() -> Board {
        let mark = |u: f64, v: f64| Point3::new((u - 256.0) * 0.5 / 500.0, (v - 256.0) * 0.5 / 500.0, 0.0);
        Board {
            marks_in_board: [mark(151.0, 168.0), mark(318.0, 178.0), mark(339.0, 75.0), mark(172.0, 70.0)],
            mark_diameter_m: 0.015,
            extent_in_board: [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)],
            target: Target::Marks,
            calibration_grid: None,
        }
    }

    /// A board of the given extent with `tag` printed on it: its marks are the tag's corners.
    pub fn with_apriltag(tag: AprilTag, extent_in_board: [Point2<f64>; 2]) -> Board {
        Board {
            marks_in_board: tag.corners_in_board(),
            mark_diameter_m: 0.0,
            extent_in_board,
            target: Target::AprilTag(tag),
            calibration_grid: None,
        }
    }

    /// A board of the given extent with `bundle` printed on it: its marks are the bundle's outer corners.
    pub fn with_bundle(bundle: TagBundle, extent_in_board: [Point2<f64>; 2]) -> Board {
        Board {
            marks_in_board: bundle.outer_corners_in_board(),
            mark_diameter_m: 0.0,
            extent_in_board,
            target: Target::Bundle(bundle),
            calibration_grid: None,
        }
    }

    /// The AprilTag on the board, if one tag is the target.
    pub fn apriltag(&self) -> Option<&AprilTag> {
        match &self.target {
            Target::AprilTag(tag) => Some(tag),
            Target::Marks | Target::Bundle(_) => None,
        }
    }

    /// The bundle on the board, if that is the target.
    pub fn bundle(&self) -> Option<&TagBundle> {
        match &self.target {
            Target::Bundle(bundle) => Some(bundle),
            Target::Marks | Target::AprilTag(_) => None,
        }
    }

    /// The tags that make the target: the one tag, the bundle's, or none for disc marks.
    pub fn target_tags(&self) -> &[AprilTag] {
        match &self.target {
            Target::AprilTag(tag) => std::slice::from_ref(tag),
            Target::Bundle(bundle) => bundle.tags(),
            Target::Marks => &[],
        }
    }

    /// Whether a point of the board plane is on a black cell of the target's tags; `None` beside their black
    /// squares (and always for disc marks).
    pub fn target_black_at(&self, x_m: f64, y_m: f64) -> Option<bool> {
        match &self.target {
            Target::AprilTag(tag) => tag.is_black_at(x_m, y_m),
            Target::Bundle(bundle) => bundle.is_black_at(x_m, y_m),
            Target::Marks => None,
        }
    }

    /// Whether the target is printed tags (one or a bundle) rather than disc marks.
    pub fn target_is_tags(&self) -> bool {
        !matches!(self.target, Target::Marks)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Covering corner k whitens the 3 × 3 cells at that corner of the black square and nothing else.
    #[test]
    fn a_covered_corner_is_white_over_three_by_three_cells() {
        let tag = AprilTag::tag36h11(3, 0.16, Point2::new(0.0, 0.0)).expect("an id");
        let cell_centre = |column: u32, row: u32| {
            (-0.08 + 0.02 * (f64::from(column) + 0.5), -0.08 + 0.02 * (f64::from(row) + 0.5))
        };
        // corner k's block of cells: the corners in the C library's order, (−1, +1) first
        let blocks = [(0..3, 5..8), (5..8, 5..8), (5..8, 0..3), (0..3, 0..3)];
        for (k, (columns, rows)) in blocks.iter().enumerate() {
            let covered = tag.with_corners_covered(1 << k);
            for row in 0..8 {
                for column in 0..8 {
                    let (x, y) = cell_centre(column, row);
                    let inside = columns.contains(&column) && rows.contains(&row);
                    let expected = if inside { Some(false) } else { tag.is_black_at(x, y) };
                    assert_eq!(covered.is_black_at(x, y), expected, "corner {k}, cell ({column}, {row})");
                }
            }
            // the corner itself lies in that block
            let corner = tag.corners_in_board()[k];
            let (x, y) = (corner.x * 0.99, corner.y * 0.99);
            assert_eq!(covered.is_black_at(x, y), Some(false), "corner {k}");
            assert_eq!(tag.is_black_at(x, y), Some(true), "the border is black at corner {k}");
        }
    }

    #[test]
    fn a_tag_reads_back_its_code_cell_by_cell_and_has_a_black_border() {
        let tag = AprilTag::tag36h11(7, 0.08, Point2::new(0.01, -0.02)).expect("id 7 exists");
        let cell = 0.08 / 8.0;
        let at = |column: u8, row: u8| {
            tag.is_black_at(
                0.01 - 0.04 + (f64::from(column) + 0.5) * cell,
                -0.02 - 0.04 + (f64::from(row) + 0.5) * cell,
            )
        };
        let mut code = 0u64;
        for i in 0..tag36h11::BITS {
            let black = at(tag36h11::BIT_X[i], tag36h11::BIT_Y[i]).expect("inside the square");
            code = code << 1 | u64::from(!black);
        }
        assert_eq!(code, 0x0000_0001_106c_ba43, "tag36h11.c codedata[7]");
        for k in 0..8 {
            for (column, row) in [(k, 0), (0, k), (k, 7), (7, k)] {
                assert_eq!(at(column, row), Some(true), "border cell ({column}, {row}) is black");
            }
        }
        assert_eq!(tag.is_black_at(0.01 + 0.0401, -0.02), None, "just right of the square: the margin");
    }

    #[test]
    fn ids_beyond_the_family_are_refused() {
        assert!(AprilTag::tag36h11(586, 0.1, Point2::origin()).is_ok());
        assert_eq!(AprilTag::tag36h11(587, 0.1, Point2::origin()), Err(UnknownTagId { id: 587 }));
    }
}
