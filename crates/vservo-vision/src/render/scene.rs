//! One frame's geometry: the board's homography and outline in the image, and which surface (background,
//! board, mark, tag) a point of the image sees.

use nalgebra::{Matrix3, Point2, Point3, Vector3};
use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3};

/// What one frame's geometry needs, computed once per frame.
pub(super) struct Scene<'a> {
    pub(super) board: &'a Board,
    /// The camera, whose lens maps an image point to its pinhole pixel.
    pub(super) camera: CameraIntrinsics,
    /// Whether the lens distorts (else the image is the pinhole's and no point is mapped).
    pub(super) distorted: bool,
    /// image_from_board homography on the board plane, and its inverse.
    pub(super) image_from_board: Matrix3<f64>,
    pub(super) board_from_image: Matrix3<f64>,
    /// The board's outline in the image (convex, after clipping at the camera plane).
    pub(super) outline: [Point2<f64>; 8],
    pub(super) outline_len: usize,
    pub(super) mark_radius_m: f64,
}

/// Where a sample falls.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Surface {
    Background,
    Board,
    Mark,
}

impl Scene<'_> {
    pub(super) fn new<'a>(
        camera: &CameraIntrinsics,
        board: &'a Board,
        camera_from_board: &IsometryMatrix3<f64>,
    ) -> Scene<'a> {
        let r = camera_from_board.rotation.matrix();
        let t = camera_from_board.translation.vector;
        let k = Matrix3::new(
            camera.fx_px(),
            0.0,
            camera.principal_point_px().x,
            0.0,
            camera.fy_px(),
            camera.principal_point_px().y,
            0.0,
            0.0,
            1.0,
        );
        let plane = Matrix3::from_columns(&[r.column(0).into_owned(), r.column(1).into_owned(), t]);
        let image_from_board = k * plane;
        // a board plane through the camera centre images as a line: nothing to see, everything background
        let board_from_image = image_from_board.try_inverse().unwrap_or_else(Matrix3::zeros);

        // the board's corners in the camera frame, clipped to z ≥ near, then projected
        let [lo, hi] = board.extent_in_board;
        let corners = [(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)]
            .map(|(x, y)| camera_from_board * Point3::new(x, y, 0.0));
        const NEAR: f64 = 1e-4;
        let mut clipped = [Point3::origin(); 8];
        let mut n = 0;
        for i in 0..4 {
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            if a.z >= NEAR {
                clipped[n] = a;
                n += 1;
            }
            if (a.z >= NEAR) != (b.z >= NEAR) {
                let s = (NEAR - a.z) / (b.z - a.z);
                clipped[n] = a + (b - a) * s;
                n += 1;
            }
        }
        let mut outline = [Point2::origin(); 8];
        for (out, p) in outline.iter_mut().zip(&clipped[..n]) {
            *out = camera.project(p).unwrap_or_else(Point2::origin);
        }
        Scene {
            board,
            camera: *camera,
            distorted: !camera.distortion().is_none(),
            image_from_board,
            board_from_image,
            outline,
            outline_len: n,
            mark_radius_m: 0.5 * board.mark_diameter_m,
        }
    }

    /// Board-plane coordinates of an image point, or `None` where the ray misses the board plane.
    #[inline]
    pub(super) fn on_board(&self, x: f64, y: f64) -> Option<Point2<f64>> {
        let b = self.board_from_image * Vector3::new(x, y, 1.0);
        (b.z > 0.0).then(|| Point2::new(b.x / b.z, b.y / b.z))
    }

    /// Board-plane coordinates of what the image point (`x`, `y`) sees: through the lens to its pinhole
    /// pixel (when the lens distorts), then the board's homography; `None` where the ray misses the board
    /// plane or the point is outside the lens's valid region.
    #[inline]
    pub(super) fn board_point_of(&self, x: f64, y: f64) -> Option<Point2<f64>> {
        if !self.distorted {
            return self.on_board(x, y);
        }
        let pinhole = self.camera.pinhole_of_observed(&Point2::new(x, y))?;
        self.on_board(pinhole.x, pinhole.y)
    }

    #[inline]
    pub(super) fn surface(&self, x: f64, y: f64) -> Surface {
        let Some(p) = self.board_point_of(x, y) else { return Surface::Background };
        self.surface_on_board_plane(p)
    }

    /// What a point of the board plane (board frame, m) is: off the board, the white board, a disc mark or
    /// a black cell of the tag or of the calibration grid (their white cells are the board's white; inside
    /// the target tag's black square the target decides).
    #[inline]
    pub(super) fn surface_on_board_plane(&self, p: Point2<f64>) -> Surface {
        let [lo, hi] = self.board.extent_in_board;
        if p.x < lo.x || p.x > hi.x || p.y < lo.y || p.y > hi.y {
            return Surface::Background;
        }
        if let Some(black) = self.board.target_black_at(p.x, p.y) {
            return if black { Surface::Mark } else { Surface::Board };
        }
        if self.board.calibration_grid.is_some_and(|grid| grid.is_black_at(p.x, p.y)) {
            return Surface::Mark;
        }
        if self.board.target_is_tags() {
            return Surface::Board;
        }
        let r2 = self.mark_radius_m * self.mark_radius_m;
        let on_mark =
            self.board.marks_in_board.iter().any(|m| (p.x - m.x).powi(2) + (p.y - m.y).powi(2) <= r2);
        if on_mark { Surface::Mark } else { Surface::Board }
    }

    /// The x-extent of the board outline on the horizontal line y, if it crosses it.
    pub(super) fn span(&self, y: f64) -> Option<(f64, f64)> {
        let n = self.outline_len;
        if n < 3 {
            return None;
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let (a, b) = (self.outline[i], self.outline[(i + 1) % n]);
            if (a.y <= y && b.y >= y) || (b.y <= y && a.y >= y) {
                let x = if (b.y - a.y).abs() < 1e-12 {
                    a.x.min(b.x)
                } else {
                    a.x + (y - a.y) / (b.y - a.y) * (b.x - a.x)
                };
                let x_other = if (b.y - a.y).abs() < 1e-12 { a.x.max(b.x) } else { x };
                lo = lo.min(x);
                hi = hi.max(x_other);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }

    /// The pixel box (u0, u1, v0, v1), exclusive ends, that holds mark `index`'s image; `None` when part
    /// of the mark is behind the camera (it is then drawn by the edge sampler alone).
    pub(super) fn mark_box(&self, index: usize) -> Option<(i64, i64, i64, i64)> {
        if self.board.target_is_tags() {
            return None;
        }
        let c = self.board.marks_in_board[index];
        let r = self.mark_radius_m;
        self.board_box([Point2::new(c.x - r, c.y - r), Point2::new(c.x + r, c.y + r)])
    }

    /// The pixel box (u0, u1, v0, v1), exclusive ends, that holds the black squares of the tag and of the
    /// calibration grid; `None` without either. When part of them is behind the camera the box is the whole
    /// image: every pixel of the board is then judged against the tags.
    pub(super) fn tags_box(&self) -> Option<(i64, i64, i64, i64)> {
        const WHOLE_IMAGE: (i64, i64, i64, i64) = (i64::MIN / 2, i64::MAX / 2, i64::MIN / 2, i64::MAX / 2);
        let tag = self.board.target_tags().iter().fold(None, |union, tag| {
            let c = tag.centre_in_board();
            let r = 0.5 * tag.size_m();
            let one = self
                .board_box([Point2::new(c.x - r, c.y - r), Point2::new(c.x + r, c.y + r)])
                .unwrap_or(WHOLE_IMAGE);
            Some(union.map_or(one, |u: (i64, i64, i64, i64)| {
                (u.0.min(one.0), u.1.max(one.1), u.2.min(one.2), u.3.max(one.3))
            }))
        });
        let grid = self
            .board
            .calibration_grid
            .map(|grid| self.board_box(grid.tags_extent_in_board()).unwrap_or(WHOLE_IMAGE));
        match (tag, grid) {
            (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1), a.2.min(b.2), a.3.max(b.3))),
            (Some(one), None) | (None, Some(one)) => Some(one),
            (None, None) => None,
        }
    }

    /// The pixel box holding the image of the board rectangle from `low` to `high`.
    pub(super) fn board_box(&self, [low, high]: [Point2<f64>; 2]) -> Option<(i64, i64, i64, i64)> {
        let (mut u0, mut u1, mut v0, mut v1) =
            (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (x, y) in [(low.x, low.y), (high.x, low.y), (high.x, high.y), (low.x, high.y)] {
            let h = self.image_from_board * Vector3::new(x, y, 1.0);
            if h.z <= 0.0 {
                return None;
            }
            let (x, y) = (h.x / h.z, h.y / h.z);
            u0 = u0.min(x);
            u1 = u1.max(x);
            v0 = v0.min(y);
            v1 = v1.max(y);
        }
        Some((u0.floor() as i64 - 1, u1.ceil() as i64 + 1, v0.floor() as i64 - 1, v1.ceil() as i64 + 1))
    }
}
