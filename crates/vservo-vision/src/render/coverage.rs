//! The exact share of a pixel's footprint that a tag's black cells cover: the footprint (a quadrilateral on
//! the board plane, in the tag's cell units) clipped against each black unit cell it reaches, the areas
//! summed. This replaces S × S samples at the edges between a tag's cells, where a calibration grid has
//! tens of thousands of pixels, by at most four clippings; no allocation.

/// The most vertices a quadrilateral clipped by four half-planes can have.
const MAX_VERTICES: usize = 8;

/// A convex clip window's side: points with `axis` coordinate on the `keep` side of `at` are kept.
#[derive(Clone, Copy)]
struct HalfPlane {
    /// 0: x, 1: y.
    axis: usize,
    at: f64,
    /// Keep the points above `at` (`true`) or below it.
    above: bool,
}

impl HalfPlane {
    fn keeps(&self, p: [f64; 2]) -> bool {
        if self.above { p[self.axis] >= self.at } else { p[self.axis] <= self.at }
    }

    /// Where the segment from `a` to `b` crosses the line (`a` and `b` on different sides).
    fn crossing(&self, a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
        let t = (self.at - a[self.axis]) / (b[self.axis] - a[self.axis]);
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
    }
}

/// A polygon of at most [`MAX_VERTICES`] vertices, on the stack.
#[derive(Clone, Copy)]
struct Polygon {
    vertices: [[f64; 2]; MAX_VERTICES],
    count: usize,
}

impl Polygon {
    fn of(quad: &[[f64; 2]; 4]) -> Self {
        let mut vertices = [[0.0; 2]; MAX_VERTICES];
        vertices[..4].copy_from_slice(quad);
        Self { vertices, count: 4 }
    }

    fn push(&mut self, p: [f64; 2]) {
        // a convex window cuts a convex quadrilateral into at most eight vertices; past that (a footprint
        // the lens made non-convex) the extra vertex is dropped, a loss far below a gray level
        if self.count < MAX_VERTICES {
            self.vertices[self.count] = p;
            self.count += 1;
        }
    }

    /// Sutherland–Hodgman: the part of the polygon on the kept side of `plane`.
    fn clipped(&self, plane: HalfPlane) -> Self {
        let mut out = Self { vertices: [[0.0; 2]; MAX_VERTICES], count: 0 };
        for i in 0..self.count {
            let current = self.vertices[i];
            let previous = self.vertices[(i + self.count - 1) % self.count];
            match (plane.keeps(previous), plane.keeps(current)) {
                (true, true) => out.push(current),
                (true, false) => out.push(plane.crossing(previous, current)),
                (false, true) => {
                    out.push(plane.crossing(previous, current));
                    out.push(current);
                }
                (false, false) => {}
            }
        }
        out
    }

    /// The signed area (shoelace): positive when the vertices turn counter-clockwise.
    fn signed_area(&self) -> f64 {
        let mut twice = 0.0;
        for i in 0..self.count {
            let [x0, y0] = self.vertices[i];
            let [x1, y1] = self.vertices[(i + 1) % self.count];
            twice += x0 * y1 - x1 * y0;
        }
        0.5 * twice
    }
}

/// The signed area of the part of `quad` inside the unit cell whose low corner is `(column, row)`.
fn area_in_cell(quad: &[[f64; 2]; 4], column: f64, row: f64) -> f64 {
    [
        HalfPlane { axis: 0, at: column, above: true },
        HalfPlane { axis: 0, at: column + 1.0, above: false },
        HalfPlane { axis: 1, at: row, above: true },
        HalfPlane { axis: 1, at: row + 1.0, above: false },
    ]
    .iter()
    .fold(Polygon::of(quad), |polygon, &plane| polygon.clipped(plane))
    .signed_area()
}

/// The share of `quad` (cell units, corners in order around it) that lies in the black cells among columns
/// `columns` and rows `rows` (the cells it reaches; inclusive ranges), `black(column, row)` telling which
/// are black. `None` for a footprint of no area or not of finite numbers (to be sampled instead).
pub fn black_share(
    quad: &[[f64; 2]; 4],
    (first_column, last_column): (f64, f64),
    (first_row, last_row): (f64, f64),
    black: impl Fn(f64, f64) -> bool,
) -> Option<f64> {
    let whole = Polygon::of(quad).signed_area();
    if !whole.is_finite() || whole.abs() < 1e-12 {
        return None;
    }
    let mut covered = 0.0;
    let mut row = first_row;
    while row <= last_row {
        let mut column = first_column;
        while column <= last_column {
            if black(column, row) {
                covered += area_in_cell(quad, column, row);
            }
            column += 1.0;
        }
        row += 1.0;
    }
    // the clipped parts turn as the whole does, so the ratio is the share whichever way the footprint turns
    Some((covered / whole).clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The share by brute force: `n` × `n` points bilinear over the quadrilateral's parameter square,
    /// weighted by the map's Jacobian, so that it is the share of area (not of parameter square).
    fn sampled_share(quad: &[[f64; 2]; 4], black: impl Fn(f64, f64) -> bool, n: usize) -> f64 {
        let point = |a: f64, b: f64| {
            let top =
                [quad[0][0] + (quad[1][0] - quad[0][0]) * a, quad[0][1] + (quad[1][1] - quad[0][1]) * a];
            let bottom =
                [quad[3][0] + (quad[2][0] - quad[3][0]) * a, quad[3][1] + (quad[2][1] - quad[3][1]) * a];
            [top[0] + (bottom[0] - top[0]) * b, top[1] + (bottom[1] - top[1]) * b]
        };
        let (mut covered, mut whole) = (0.0, 0.0);
        let h = 1e-6;
        for j in 0..n {
            let b = (j as f64 + 0.5) / n as f64;
            for i in 0..n {
                let a = (i as f64 + 0.5) / n as f64;
                let p = point(a, b);
                let (pa, pb) = (point(a + h, b), point(a, b + h));
                let jacobian =
                    (((pa[0] - p[0]) * (pb[1] - p[1]) - (pa[1] - p[1]) * (pb[0] - p[0])) / (h * h)).abs();
                whole += jacobian;
                if black(p[0].floor(), p[1].floor()) {
                    covered += jacobian;
                }
            }
        }
        covered / whole
    }

    /// A checkerboard with a hole: cells black where (column + row) is even, but (1, 1).
    fn pattern(column: f64, row: f64) -> bool {
        (column, row) != (1.0, 1.0) && (column + row).rem_euclid(2.0) == 0.0
    }

    fn reach(quad: &[[f64; 2]; 4], axis: usize) -> (f64, f64) {
        let low = quad.iter().map(|p| p[axis].floor()).fold(f64::INFINITY, f64::min);
        let high = quad.iter().map(|p| p[axis].floor()).fold(f64::NEG_INFINITY, f64::max);
        (low, high)
    }

    /// Quadrilaterals of a pixel's footprint (convex, both turns, tilted, over up to 3 × 3 cells): the exact
    /// share equals a 1000 × 1000 sampling within its error.
    #[test]
    fn the_share_equals_dense_sampling() {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..60 {
            // a parallelogram-like footprint, its corners jittered, about one cell across, somewhere in 3 × 3
            let centre = [0.5 + 2.0 * uniform(), 0.5 + 2.0 * uniform()];
            let (angle, size) = (std::f64::consts::TAU * uniform(), 0.3 + 1.2 * uniform());
            let (c, s) = (angle.cos() * size * 0.5, angle.sin() * size * 0.5);
            let mut quad =
                [[-c + s, -s - c], [c + s, s - c], [c - s, s + c], [-c - s, -s + c]].map(|[x, y]| {
                    [centre[0] + x + 0.1 * (uniform() - 0.5), centre[1] + y + 0.1 * (uniform() - 0.5)]
                });
            if case % 2 == 1 {
                quad.reverse();
            }
            let exact = black_share(&quad, reach(&quad, 0), reach(&quad, 1), pattern).expect("an area");
            let sampled = sampled_share(&quad, pattern, 1000);
            assert!(
                (exact - sampled).abs() < 2e-3,
                "case {case}: {exact} exact, {sampled} sampled, {quad:?}"
            );
        }
    }

    #[test]
    fn a_footprint_inside_one_cell_is_all_or_nothing() {
        let quad = [[0.2, 0.2], [0.8, 0.25], [0.75, 0.8], [0.25, 0.7]];
        assert_eq!(black_share(&quad, (0.0, 0.0), (0.0, 0.0), |_, _| true), Some(1.0));
        assert_eq!(black_share(&quad, (0.0, 0.0), (0.0, 0.0), |_, _| false), Some(0.0));
    }

    #[test]
    fn a_square_split_by_a_cell_edge_is_half_covered() {
        let quad = [[0.5, 0.2], [1.5, 0.2], [1.5, 0.8], [0.5, 0.8]];
        let share = black_share(&quad, (0.0, 1.0), (0.0, 0.0), |column, _| column == 1.0).expect("an area");
        assert!((share - 0.5).abs() < 1e-12, "{share}");
    }

    #[test]
    fn a_footprint_of_no_area_or_not_finite_is_refused() {
        let line = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.5, 0.5]];
        assert_eq!(black_share(&line, (0.0, 2.0), (0.0, 2.0), |_, _| true), None);
        let nan = [[f64::NAN, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert_eq!(black_share(&nan, (0.0, 1.0), (0.0, 1.0), |_, _| true), None);
    }
}
