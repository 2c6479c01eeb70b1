//! The object: a flat board with four dark disc marks.

use nalgebra::{Point2, Point3};

/// Number of marks on the board.
pub const MARKS: usize = 4;

/// The board and its marks. The board frame has its z axis along the board's normal, pointing away from
/// the side the camera looks at; the marks lie in its z = 0 plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    /// Mark centres in the board frame (m), in the fixed feature order.
    pub marks_in_board: [Point3<f64>; MARKS],
    /// Diameter of each disc mark (m).
    pub mark_diameter_m: f64,
    /// The white board's rectangle in the board frame's z = 0 plane: its lowest and highest (x, y) (m).
    pub extent_in_board: [Point2<f64>; 2],
}

impl Board {
    /// The paper's board (docs/REPRODUCTION.md): marks placed so that, 0.5 m fronto-parallel in front of the paper's
    /// camera, they image exactly at ξ_d = [151, 168, 318, 178, 339, 75, 172, 70] px; 15 mm discs.
    pub fn paper() -> Board {
        let mark = |u: f64, v: f64| Point3::new((u - 256.0) * 0.5 / 500.0, (v - 256.0) * 0.5 / 500.0, 0.0);
        Board {
            marks_in_board: [mark(151.0, 168.0), mark(318.0, 178.0), mark(339.0, 75.0), mark(172.0, 70.0)],
            mark_diameter_m: 0.015,
            extent_in_board: [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)],
        }
    }
}
