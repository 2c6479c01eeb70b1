//! The simulated hand camera: renders the board with its marks as an 8-bit grayscale image.
//!
//! Geometry is exact: a pixel's gray is the area-weighted mean of what its footprint sees, found by
//! supersampling (S × S samples mapped through the board's homography) wherever a board or mark edge may
//! cross the pixel; pixels wholly on the background, the board or a mark take that gray directly. The
//! image is then lit by a linear gradient and gets Gaussian noise, both seeded and repeatable.

use image::GrayImage;
use nalgebra::{Matrix3, Point2, Point3, Vector3};
use vservo_scene::{AprilTag, Board, CameraIntrinsics, IsometryMatrix3, MARKS, TagGrid};

use crate::noise::{GaussianTable, Xorshift64};
pub use vservo_settings::vision::RenderSettings;

/// The renderer and its image buffer, sized once for the camera.
#[derive(Debug, Clone)]
pub struct Renderer {
    camera: CameraIntrinsics,
    settings: RenderSettings,
    noise: GaussianTable,
    image: GrayImage,
    albedo: Vec<f32>,
    /// With a distorting lens: the pinhole pixel of every pixel corner ((width + 1) × (height + 1), row by
    /// row; NaN outside the lens's valid region), computed once. Empty for a pinhole camera.
    pinhole_corners: Vec<Point2<f64>>,
}

/// What one frame's geometry needs, computed once per frame.
struct Scene<'a> {
    board: &'a Board,
    /// The camera, whose lens maps an image point to its pinhole pixel.
    camera: CameraIntrinsics,
    /// Whether the lens distorts (else the image is the pinhole's and no point is mapped).
    distorted: bool,
    /// image_from_board homography on the board plane, and its inverse.
    image_from_board: Matrix3<f64>,
    board_from_image: Matrix3<f64>,
    /// The board's outline in the image (convex, after clipping at the camera plane).
    outline: [Point2<f64>; 8],
    outline_len: usize,
    mark_radius_m: f64,
}

/// Where a sample falls.
#[derive(Clone, Copy, PartialEq)]
enum Surface {
    Background,
    Board,
    Mark,
}

impl Scene<'_> {
    fn new<'a>(
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
    fn on_board(&self, x: f64, y: f64) -> Option<Point2<f64>> {
        let b = self.board_from_image * Vector3::new(x, y, 1.0);
        (b.z > 0.0).then(|| Point2::new(b.x / b.z, b.y / b.z))
    }

    /// Board-plane coordinates of what the image point (`x`, `y`) sees: through the lens to its pinhole
    /// pixel (when the lens distorts), then the board's homography; `None` where the ray misses the board
    /// plane or the point is outside the lens's valid region.
    #[inline]
    fn board_point_of(&self, x: f64, y: f64) -> Option<Point2<f64>> {
        if !self.distorted {
            return self.on_board(x, y);
        }
        let pinhole = self.camera.pinhole_of_observed(&Point2::new(x, y))?;
        self.on_board(pinhole.x, pinhole.y)
    }

    #[inline]
    fn surface(&self, x: f64, y: f64) -> Surface {
        let Some(p) = self.board_point_of(x, y) else { return Surface::Background };
        self.surface_on_board_plane(p)
    }

    /// What a point of the board plane (board frame, m) is: off the board, the white board, a disc mark or
    /// a black cell of the tag or of the calibration grid (their white cells are the board's white; inside
    /// the target tag's black square the target decides).
    #[inline]
    fn surface_on_board_plane(&self, p: Point2<f64>) -> Surface {
        let [lo, hi] = self.board.extent_in_board;
        if p.x < lo.x || p.x > hi.x || p.y < lo.y || p.y > hi.y {
            return Surface::Background;
        }
        if let Some(black) = self.board.apriltag().and_then(|tag| tag.is_black_at(p.x, p.y)) {
            return if black { Surface::Mark } else { Surface::Board };
        }
        if self.board.calibration_grid.is_some_and(|grid| grid.is_black_at(p.x, p.y)) {
            return Surface::Mark;
        }
        if self.board.apriltag().is_some() {
            return Surface::Board;
        }
        let r2 = self.mark_radius_m * self.mark_radius_m;
        let on_mark =
            self.board.marks_in_board.iter().any(|m| (p.x - m.x).powi(2) + (p.y - m.y).powi(2) <= r2);
        if on_mark { Surface::Mark } else { Surface::Board }
    }

    /// The x-extent of the board outline on the horizontal line y, if it crosses it.
    fn span(&self, y: f64) -> Option<(f64, f64)> {
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
    fn mark_box(&self, index: usize) -> Option<(i64, i64, i64, i64)> {
        if self.board.apriltag().is_some() {
            return None;
        }
        let c = self.board.marks_in_board[index];
        let r = self.mark_radius_m;
        self.board_box([Point2::new(c.x - r, c.y - r), Point2::new(c.x + r, c.y + r)])
    }

    /// The pixel box (u0, u1, v0, v1), exclusive ends, that holds the black squares of the tag and of the
    /// calibration grid; `None` without either. When part of them is behind the camera the box is the whole
    /// image: every pixel of the board is then judged against the tags.
    fn tags_box(&self) -> Option<(i64, i64, i64, i64)> {
        const WHOLE_IMAGE: (i64, i64, i64, i64) = (i64::MIN / 2, i64::MAX / 2, i64::MIN / 2, i64::MAX / 2);
        let tag = self.board.apriltag().map(|tag| {
            let c = tag.centre_in_board();
            let r = 0.5 * tag.size_m();
            self.board_box([Point2::new(c.x - r, c.y - r), Point2::new(c.x + r, c.y + r)])
                .unwrap_or(WHOLE_IMAGE)
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
    fn board_box(&self, [low, high]: [Point2<f64>; 2]) -> Option<(i64, i64, i64, i64)> {
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

impl Renderer {
    /// A renderer for `camera`'s image size.
    pub fn new(camera: CameraIntrinsics, settings: RenderSettings) -> Self {
        let (w, h) = (camera.width_px(), camera.height_px());
        Self {
            camera,
            settings,
            noise: GaussianTable::new(settings.noise_sigma_gray),
            image: GrayImage::new(w, h),
            albedo: vec![0.0; w as usize],
            pinhole_corners: pinhole_corners(&camera),
        }
    }

    /// The settings.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The last rendered image.
    pub fn image(&self) -> &GrayImage {
        &self.image
    }

    /// Renders what the camera sees with the board at `camera_from_board`; `frame` varies the noise.
    pub fn render(
        &mut self,
        board: &Board,
        camera_from_board: &IsometryMatrix3<f64>,
        frame: u64,
    ) -> &GrayImage {
        let scene = Scene::new(&self.camera, board, camera_from_board);
        let (width, height) = (self.camera.width_px() as i64, self.camera.height_px() as i64);
        let s = self.settings;
        let samples = s.supersampling.max(1);
        let gray = |surface: Surface| match surface {
            Surface::Background => s.background_gray,
            Surface::Board => s.board_gray,
            Surface::Mark => s.mark_gray,
        };
        let boxes = EdgeBoxes { marks: std::array::from_fn(|i| scene.mark_box(i)), tags: scene.tags_box() };
        let mut rng = Xorshift64::new(s.noise_seed ^ frame.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        for v in 0..height {
            if scene.distorted {
                distorted_row(&scene, &self.pinhole_corners, v, &mut self.albedo, &gray, samples);
            } else {
                pinhole_row(&scene, &s, &boxes, v, &mut self.albedo, &gray);
            }
            let out = &mut self.image.as_mut()[(v * width) as usize..((v + 1) * width) as usize];
            light_and_noise(&s, &self.noise, &mut rng, (v, height), &self.albedo, out);
        }
        &self.image
    }
}

/// The pixel boxes of the marks and of the tags' black squares (u0, u1, v0, v1, exclusive ends), where the
/// pinhole path looks at each pixel.
struct EdgeBoxes {
    marks: [Option<(i64, i64, i64, i64)>; MARKS],
    tags: Option<(i64, i64, i64, i64)>,
}

/// Row `v` of the albedo through a pinhole: the board's outline where it crosses the row (supersampled at
/// its edges), then the marks and the tag inside the wholly-on-board stretch, each pixel judged whole or
/// supersampled.
fn pinhole_row(
    scene: &Scene,
    s: &RenderSettings,
    boxes: &EdgeBoxes,
    v: i64,
    row: &mut [f32],
    gray: &impl Fn(Surface) -> f64,
) {
    let width = row.len() as i64;
    let samples = s.supersampling.max(1);
    let supersample_with = |u: i64, v: i64, samples: u32| -> f32 {
        let mut sum = 0.0;
        for j in 0..samples {
            let y = v as f64 + (f64::from(j) + 0.5) / f64::from(samples);
            for i in 0..samples {
                let x = u as f64 + (f64::from(i) + 0.5) / f64::from(samples);
                sum += gray(scene.surface(x, y));
            }
        }
        (sum / f64::from(samples * samples)) as f32
    };
    // mark edges get the full count (they carry the features); the board's outline, which carries none,
    // half as many per axis
    let supersample = |u: i64, v: i64| supersample_with(u, v, samples);
    let outline_samples = (samples / 2).max(2);
    let supersample_outline = |u: i64, v: i64| supersample_with(u, v, outline_samples);
    row.fill(s.background_gray as f32);
    // where the board outline crosses this pixel row, at each sub-row
    let (mut a_min, mut a_max, mut b_min, mut b_max) =
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    let mut any = false;
    let mut all = true;
    for j in 0..samples {
        let y = v as f64 + (f64::from(j) + 0.5) / f64::from(samples);
        match scene.span(y) {
            Some((a, b)) => {
                any = true;
                a_min = a_min.min(a);
                a_max = a_max.max(a);
                b_min = b_min.min(b);
                b_max = b_max.max(b);
            }
            None => all = false,
        }
    }
    let clamp = |x: f64| (x.max(0.0).min(width as f64)) as i64;
    let (mut full_start, mut full_end) = (0, 0);
    if any {
        let edge_start = clamp(a_min.floor());
        let edge_end = clamp(b_max.ceil());
        if all && a_max.ceil() < b_min.floor() {
            full_start = clamp(a_max.ceil());
            full_end = clamp(b_min.floor());
        }
        if full_start < full_end {
            row[full_start as usize..full_end as usize].fill(s.board_gray as f32);
            for u in (edge_start..full_start).chain(full_end..edge_end) {
                row[u as usize] = supersample_outline(u, v);
            }
        } else {
            for u in edge_start..edge_end {
                row[u as usize] = supersample_outline(u, v);
            }
        }
    }
    // marks: only inside the wholly-on-board stretch (the edge pixels above were sampled whole)
    for bbox in boxes.marks.iter().flatten() {
        let &(u0, u1, v0, v1) = bbox;
        if v < v0 || v >= v1 {
            continue;
        }
        for u in u0.max(full_start)..u1.min(full_end) {
            row[u as usize] =
                mark_pixel(scene, u, v, s.board_gray, s.mark_gray).unwrap_or_else(|| supersample(u, v));
        }
    }
    // the tags: likewise only inside the wholly-on-board stretch
    if let Some((u0, u1, v0, v1)) = boxes.tags
        && v >= v0
        && v < v1
    {
        for u in u0.max(full_start)..u1.min(full_end) {
            row[u as usize] =
                tag_pixel(scene, u, v, s.board_gray, s.mark_gray).unwrap_or_else(|| supersample(u, v));
        }
    }
}

/// Row `v` (of `height`) of the image from its albedo: the lighting gradient and the noise, in f32 with
/// saturating casts. This loop touches every pixel, so it stays free of calls and branches (rounding is
/// half-up).
fn light_and_noise(
    s: &RenderSettings,
    noise: &GaussianTable,
    rng: &mut Xorshift64,
    (v, height): (i64, i64),
    row: &[f32],
    out: &mut [u8],
) {
    let width = row.len() as i64;
    let [gx, gy] = s.lighting_gradient;
    let y_light =
        (1.0 + gy * ((v as f64 + 0.5) / height as f64 - 0.5) + gx * (0.5 / width as f64 - 0.5)) as f32;
    let step = (gx / width as f64) as f32;
    if s.noise_sigma_gray > 0.0 {
        for (chunk_out, chunk_in) in
            out.chunks_mut(5).zip(row.chunks(5)).enumerate().map(|(i, (o, a))| ((i, o), a))
        {
            let ((chunk, pixels), albedo) = (chunk_out, chunk_in);
            let mut bits = rng.next_u64();
            for (k, (pixel, &a)) in pixels.iter_mut().zip(albedo).enumerate() {
                let u = (chunk * 5 + k) as f32;
                let value = a * (y_light + step * u) + noise.sample(bits) + 0.5;
                *pixel = value.clamp(0.0, 255.0) as u8;
                bits >>= 12;
            }
        }
    } else {
        for (u, (pixel, &a)) in out.iter_mut().zip(row.iter()).enumerate() {
            *pixel = (a * (y_light + step * u as f32) + 0.5).clamp(0.0, 255.0) as u8;
        }
    }
}

/// The pinhole pixel of every pixel corner of a distorting camera (NaN where the lens has none), row by row;
/// empty for a pinhole camera.
fn pinhole_corners(camera: &CameraIntrinsics) -> Vec<Point2<f64>> {
    if camera.distortion().is_none() {
        return Vec::new();
    }
    let (w, h) = (camera.width_px(), camera.height_px());
    (0..=h)
        .flat_map(|v| (0..=w).map(move |u| Point2::new(f64::from(u), f64::from(v))))
        .map(|corner| camera.pinhole_of_observed(&corner).unwrap_or(Point2::new(f64::NAN, f64::NAN)))
        .collect()
}

/// What a pixel's footprint on the board holds, judged from its corners.
enum Footprint {
    /// All of it sees one surface.
    Whole(Surface),
    /// A mark's edge may cross it.
    NearMark,
    /// The board's outline may cross it (or part of it misses the board plane or the lens).
    NearOutline,
}

/// Row `v` of the albedo through a distorting lens: each pixel is judged by where its corners' rays meet the
/// board (the lens's map of the corners, computed once per camera, then this frame's homography) and
/// supersampled where an edge may cross it. Within one pixel the lens's map is taken as bilinear between the
/// corners' pinhole points (its bend over a pixel is below 1e-3 px for the lenses here), so a sample costs a
/// homography, not an undistortion.
fn distorted_row(
    scene: &Scene,
    pinhole_corners: &[Point2<f64>],
    v: i64,
    row: &mut [f32],
    gray: &impl Fn(Surface) -> f64,
    samples: u32,
) {
    let stride = row.len() + 1;
    let top = v as usize * stride;
    // mark and tag edges get the full count (they carry the features); the outline half as many per axis
    let outline_samples = (samples / 2).max(2);
    for (u, albedo) in row.iter_mut().enumerate() {
        let pinhole =
            [top + u, top + u + 1, top + stride + u + 1, top + stride + u].map(|i| pinhole_corners[i]);
        let corners = pinhole.map(|p| scene.on_board(p.x, p.y));
        *albedo = match footprint(scene, corners) {
            Footprint::Whole(surface) => gray(surface) as f32,
            Footprint::NearMark => supersample_between(scene, (u as f64, v as f64), &pinhole, samples, gray),
            Footprint::NearOutline => {
                supersample_between(scene, (u as f64, v as f64), &pinhole, outline_samples, gray)
            }
        };
    }
}

/// The mean gray of `samples` × `samples` points of the pixel whose top left corner is `top_left` and whose
/// corners' pinhole points are `pinhole` (top left, top right, bottom right, bottom left), each point's
/// pinhole point bilinear between them. A pixel with a corner the lens has no pinhole point for is sampled
/// through the lens's inverse.
fn supersample_between(
    scene: &Scene,
    top_left: (f64, f64),
    pinhole: &[Point2<f64>; 4],
    samples: u32,
    gray: &impl Fn(Surface) -> f64,
) -> f32 {
    let exact = pinhole.iter().any(|p| !(p.x.is_finite() && p.y.is_finite()));
    let mut sum = 0.0;
    for j in 0..samples {
        let b = (f64::from(j) + 0.5) / f64::from(samples);
        for i in 0..samples {
            let a = (f64::from(i) + 0.5) / f64::from(samples);
            let surface = if exact {
                scene.surface(top_left.0 + a, top_left.1 + b)
            } else {
                let top = pinhole[0] + (pinhole[1] - pinhole[0]) * a;
                let bottom = pinhole[3] + (pinhole[2] - pinhole[3]) * a;
                let p = top + (bottom - top) * b;
                match scene.on_board(p.x, p.y) {
                    Some(on_board) => scene.surface_on_board_plane(on_board),
                    None => Surface::Background,
                }
            };
            sum += gray(surface);
        }
    }
    (sum / f64::from(samples * samples)) as f32
}

/// Judges a pixel's footprint on the board from its four corners' board points. Any point of a convex
/// quadrilateral lies within its longer diagonal of every corner; the lens bends a pixel's edges, so every
/// test keeps a further half diagonal (the bend over one pixel is orders of magnitude smaller) and a pixel
/// it cannot judge is supersampled.
fn footprint(scene: &Scene, corners: [Option<Point2<f64>>; 4]) -> Footprint {
    let mut points = [Point2::origin(); 4];
    for (point, corner) in points.iter_mut().zip(corners) {
        match corner {
            Some(c) => *point = c,
            None => return Footprint::NearOutline,
        }
    }
    let diameter = (points[0] - points[2]).norm().max((points[1] - points[3]).norm());
    let margin = 0.5 * diameter;
    let [lo, hi] = scene.board.extent_in_board;
    let outside = points.iter().all(|p| p.x < lo.x - margin)
        || points.iter().all(|p| p.x > hi.x + margin)
        || points.iter().all(|p| p.y < lo.y - margin)
        || points.iter().all(|p| p.y > hi.y + margin);
    if outside {
        return Footprint::Whole(Surface::Background);
    }
    let inside = points.iter().all(|p| {
        p.x >= lo.x + margin && p.x <= hi.x - margin && p.y >= lo.y + margin && p.y <= hi.y - margin
    });
    if !inside {
        return Footprint::NearOutline;
    }
    match printed_footprint(scene.board, &points, margin) {
        Printed::Tags(footprint) => return footprint,
        Printed::GridOverMarks(near @ (Footprint::Whole(Surface::Mark) | Footprint::NearMark)) => {
            return near;
        }
        Printed::GridOverMarks(_) | Printed::Marks => {}
    }
    let r = scene.mark_radius_m;
    for m in &scene.board.marks_in_board {
        let distances = points.map(|p| ((p.x - m.x).powi(2) + (p.y - m.y).powi(2)).sqrt());
        if distances.iter().all(|&d| d <= r - margin) {
            return Footprint::Whole(Surface::Mark);
        }
        if distances.iter().any(|&d| d <= r + diameter + margin) {
            return Footprint::NearMark;
        }
    }
    Footprint::Whole(Surface::Board)
}

/// What the tags printed on a board make of a pixel's footprint.
enum Printed {
    /// The board's target is a tag (a calibration grid or not): the footprint as they judge it.
    Tags(Footprint),
    /// Disc marks with a calibration grid: the grid's judgement, the marks still to judge.
    GridOverMarks(Footprint),
    /// Disc marks alone.
    Marks,
}

/// Judges a pixel's footprint, from its corners' board points and the margin for the lens's bend, against
/// the tags printed on the board: the target's tag decides wherever the footprint is not wholly beside its
/// black square, the calibration grid elsewhere.
fn printed_footprint(board: &Board, points: &[Point2<f64>; 4], margin: f64) -> Printed {
    let on_grid = || board.calibration_grid.as_ref().map(|grid| grid_footprint(grid, points, margin));
    match board.apriltag() {
        Some(tag) => Printed::Tags(match tag_footprint(tag, points, margin) {
            Some(on_tag) => on_tag,
            None => on_grid().unwrap_or(Footprint::Whole(Surface::Board)),
        }),
        None => on_grid().map_or(Printed::Marks, Printed::GridOverMarks),
    }
}

/// Judges a pixel's footprint on the calibration grid: every tag that can reach it judged alone. A footprint
/// wholly in one tag's cell is beside every other tag (the gaps are a tag's border wide).
fn grid_footprint(grid: &TagGrid, points: &[Point2<f64>; 4], margin: f64) -> Footprint {
    let low = Point2::new(
        points.iter().map(|p| p.x).fold(f64::INFINITY, f64::min) - margin,
        points.iter().map(|p| p.y).fold(f64::INFINITY, f64::min) - margin,
    );
    let high = Point2::new(
        points.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max) + margin,
        points.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max) + margin,
    );
    let mut judged = Footprint::Whole(Surface::Board);
    for tag in grid.tags_meeting(low, high) {
        match tag_footprint(&tag, points, margin) {
            None | Some(Footprint::Whole(Surface::Board)) => {}
            Some(Footprint::Whole(_)) => judged = Footprint::Whole(Surface::Mark),
            Some(Footprint::NearMark | Footprint::NearOutline) => return Footprint::NearMark,
        }
    }
    judged
}

/// Judges a pixel's footprint on a tag, from its corners' board points and the margin for the lens's bend:
/// wholly in cells of one colour, or near an edge between colours; `None` wholly beside the tag's black
/// square.
fn tag_footprint(tag: &AprilTag, points: &[Point2<f64>; 4], margin: f64) -> Option<Footprint> {
    let cells = f64::from(vservo_scene::tag36h11::WIDTH_AT_BORDER);
    let per_cell = tag.size_m() / cells;
    let c = tag.centre_in_board();
    // in cell units, the square's corner at (0, 0)
    let local = points.map(|p| ((p.x - c.x) / per_cell + 0.5 * cells, (p.y - c.y) / per_cell + 0.5 * cells));
    let m = margin / per_cell;
    let beside = local.iter().all(|l| l.0 < -m)
        || local.iter().all(|l| l.0 > cells + m)
        || local.iter().all(|l| l.1 < -m)
        || local.iter().all(|l| l.1 > cells + m);
    if beside {
        return None;
    }
    // the cells the footprint (and the margin) can reach: all inside the square and of one colour, or near an
    // edge between colours
    let reach = |axis: fn(&(f64, f64)) -> f64| {
        let low = local.iter().map(|l| (axis(l) - m).floor()).fold(f64::INFINITY, f64::min);
        let high = local.iter().map(|l| (axis(l) + m).floor()).fold(f64::NEG_INFINITY, f64::max);
        (low, high)
    };
    let ((first_column, last_column), (first_row, last_row)) = (reach(|l| l.0), reach(|l| l.1));
    let inside = first_column >= 0.0 && first_row >= 0.0 && last_column < cells && last_row < cells;
    // at most 2 × 2 cells are looked at; a footprint over more is sampled
    if !inside || last_column - first_column > 1.0 || last_row - first_row > 1.0 {
        return Some(Footprint::NearMark);
    }
    let black_in = |column: f64, row: f64| {
        let x = c.x + (column + 0.5 - 0.5 * cells) * per_cell;
        let y = c.y + (row + 0.5 - 0.5 * cells) * per_cell;
        tag.is_black_at(x, y) == Some(true)
    };
    let black = black_in(first_column, first_row);
    let one_colour = [(first_column, last_row), (last_column, first_row), (last_column, last_row)]
        .iter()
        .all(|&(column, row)| black_in(column, row) == black);
    if !one_colour {
        return Some(Footprint::NearMark);
    }
    Some(Footprint::Whole(if black { Surface::Mark } else { Surface::Board }))
}

/// The gray of a pixel wholly on the board near a mark when it is wholly on or off the mark; `None` when a
/// mark edge may cross it (then it is supersampled).
#[inline]
fn mark_pixel(scene: &Scene, u: i64, v: i64, board_gray: f64, mark_gray: f64) -> Option<f32> {
    let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        .map(|(du, dv)| scene.on_board(u as f64 + du, v as f64 + dv));
    let mut points = [Point2::origin(); 4];
    for (p, c) in points.iter_mut().zip(corners) {
        *p = c?;
    }
    // the footprint's size on the board: any point of it is within this of every corner
    let diameter = (points[0] - points[2]).norm().max((points[1] - points[3]).norm());
    let r = scene.mark_radius_m;
    let mut outside_all = true;
    for m in &scene.board.marks_in_board {
        let distances = points.map(|p| ((p.x - m.x).powi(2) + (p.y - m.y).powi(2)).sqrt());
        if distances.iter().all(|&d| d <= r) {
            // a disc is convex: all four corners inside means the footprint is inside
            return Some(mark_gray as f32);
        }
        if distances.iter().any(|&d| d <= r + diameter) {
            outside_all = false;
        }
    }
    outside_all.then_some(board_gray as f32)
}

/// The gray of a pixel wholly on the board near the tags when it lies wholly in one cell of a black square
/// or wholly beside them; `None` when a cell edge may cross it (then it is supersampled). A pixel's
/// footprint on the board plane is a convex quadrilateral, so its four corners in one (convex) cell, or all
/// beyond one side of a square, put all of it there.
#[inline]
fn tag_pixel(scene: &Scene, u: i64, v: i64, board_gray: f64, mark_gray: f64) -> Option<f32> {
    let mut points = [Point2::origin(); 4];
    for (point, (du, dv)) in points.iter_mut().zip([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]) {
        *point = scene.on_board(u as f64 + du, v as f64 + dv)?;
    }
    // a pinhole maps the pixel's edges to straight lines: no margin
    match printed_footprint(scene.board, &points, 0.0) {
        Printed::Tags(Footprint::Whole(Surface::Mark)) => Some(mark_gray as f32),
        Printed::Tags(Footprint::Whole(_)) => Some(board_gray as f32),
        // disc marks under a grid are judged sample by sample
        Printed::Tags(Footprint::NearMark | Footprint::NearOutline)
        | Printed::GridOverMarks(_)
        | Printed::Marks => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3};
    use vservo_scene::Distortion;

    /// config/vservo-distorted.toml's camera.
    fn lens_camera() -> CameraIntrinsics {
        let lens = Distortion::new([-0.25, 0.08, 0.0, 0.0, 0.0]).expect("finite");
        CameraIntrinsics::with_lens([600.0, 606.0], Point2::new(322.0, 237.0), 640, 480, lens).expect("valid")
    }

    /// Through the lens, a pixel the renderer takes as wholly one surface (without sampling it) must see
    /// only that surface: checked on a 9 × 9 grid over each such pixel, its borders included, on every
    /// other row, for the board in view, tilted, and half out of the image.
    #[test]
    fn through_a_lens_every_pixel_not_sampled_sees_one_surface() {
        let camera = lens_camera();
        let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
        let tag_board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
        let poses = [
            (Translation3::new(0.01, 0.13, 0.35), Vector3::new(0.0, 0.0, 0.0)),
            (Translation3::new(0.03, 0.10, 0.40), Vector3::new(0.25, -0.3, 0.4)),
            (Translation3::new(0.2, 0.05, 0.3), Vector3::new(-0.1, 0.2, -0.2)),
        ];
        for board in [Board::paper(), tag_board] {
            every_pixel_not_sampled_sees_one_surface(&camera, &board, &poses, 10);
        }
        // a grid of 35 tags has many more edges between colours
        for board in grid_boards() {
            every_pixel_not_sampled_sees_one_surface(&camera, &board, &grid_views(), 5);
        }
    }

    /// Views of the calibration grid of [`grid_boards`]: square on, tilted, rolled and from aside.
    fn grid_views() -> [(Translation3<f64>, Vector3<f64>); 3] {
        [
            (Translation3::new(0.0, 0.0, 0.45), Vector3::new(0.0, 0.0, 0.0)),
            (Translation3::new(0.02, -0.03, 0.5), Vector3::new(0.35, -0.3, 0.8)),
            (Translation3::new(-0.05, 0.04, 0.42), Vector3::new(-0.2, 0.45, -0.3)),
        ]
    }

    /// The default calibration grid (5 × 7 tags of 28 mm, 8 mm apart) printed on a board whose target is its
    /// centre tag (id 17), and the same with two of the target's corners covered.
    fn grid_boards() -> [Board; 2] {
        let grid = vservo_scene::TagGrid::new(5, 7, 0.028, 0.008, 0).expect("a grid");
        let target = grid.tag_with_id(17).expect("the centre tag");
        let mut board = Board::with_apriltag(target, grid.extent_in_board());
        board.calibration_grid = Some(grid);
        let mut covered = Board::with_apriltag(target.with_corners_covered(0b0101), grid.extent_in_board());
        covered.calibration_grid = Some(grid);
        [board, covered]
    }

    /// Through a pinhole, a pixel the tags' judgement gives one gray sees that surface at every point.
    #[test]
    fn through_a_pinhole_every_pixel_of_the_grid_not_sampled_sees_one_surface() {
        let camera = CameraIntrinsics::with_lens(
            [600.0, 606.0],
            Point2::new(322.0, 237.0),
            640,
            480,
            Distortion::NONE,
        )
        .expect("valid");
        let s = RenderSettings::default();
        for board in grid_boards() {
            for (translation, rotation) in grid_views() {
                let pose = IsometryMatrix3::from_parts(translation, Rotation3::from_scaled_axis(rotation));
                let scene = Scene::new(&camera, &board, &pose);
                let (mut whole, mut sampled) = (0usize, 0usize);
                for v in (0..480i64).step_by(3) {
                    for u in 0..640i64 {
                        let Some(gray) = tag_pixel(&scene, u, v, s.board_gray, s.mark_gray) else {
                            sampled += 1;
                            continue;
                        };
                        whole += 1;
                        let surface = if gray == s.mark_gray as f32 { Surface::Mark } else { Surface::Board };
                        for j in 0..=8 {
                            for i in 0..=8 {
                                let (x, y) = (u as f64 + f64::from(i) / 8.0, v as f64 + f64::from(j) / 8.0);
                                let seen = scene.surface(x, y);
                                // the board's outline is judged before the tags, on the whole row
                                assert!(
                                    seen == surface || seen == Surface::Background,
                                    "pixel ({u}, {v}) taken as one surface, but ({x}, {y}) sees another"
                                );
                            }
                        }
                    }
                }
                assert!(whole > 10 * sampled, "{whole} pixels judged whole, {sampled} sampled");
            }
        }
    }

    fn every_pixel_not_sampled_sees_one_surface(
        camera: &CameraIntrinsics,
        board: &Board,
        poses: &[(Translation3<f64>, Vector3<f64>)],
        whole_per_sampled: usize,
    ) {
        let corners = pinhole_corners(camera);
        for &(translation, rotation) in poses {
            let pose = IsometryMatrix3::from_parts(translation, Rotation3::from_scaled_axis(rotation));
            let scene = Scene::new(camera, board, &pose);
            let (mut whole, mut sampled) = (0usize, 0usize);
            for v in (0..480usize).step_by(2) {
                for u in 0..640usize {
                    let top = v * 641;
                    let corner_at = |i: usize| scene.on_board(corners[i].x, corners[i].y);
                    let judged = footprint(
                        &scene,
                        [top + u, top + u + 1, top + 641 + u + 1, top + 641 + u].map(corner_at),
                    );
                    let Footprint::Whole(surface) = judged else {
                        sampled += 1;
                        continue;
                    };
                    whole += 1;
                    for j in 0..=8 {
                        for i in 0..=8 {
                            let (x, y) = (u as f64 + f64::from(i) / 8.0, v as f64 + f64::from(j) / 8.0);
                            assert!(
                                scene.surface(x, y) == surface,
                                "pixel ({u}, {v}) taken as one surface, but ({x}, {y}) sees another (pose {translation:?})"
                            );
                        }
                    }
                }
            }
            // the judgement spares most pixels the sampling
            assert!(whole > whole_per_sampled * sampled, "{whole} pixels judged whole, {sampled} sampled");
        }
    }

    /// A pixel near an edge is sampled at points whose pinhole points are bilinear between its corners'; the
    /// lens's own inverse at every sample gives the same gray but where a sample lies within the bend (under
    /// 1e-3 px) of an edge: checked on every sampled pixel of a frame with the tag and of one with the marks.
    #[test]
    fn through_a_lens_sampling_between_the_corners_agrees_with_the_lens_inverse() {
        let camera = lens_camera();
        let tag = AprilTag::tag36h11(3, 0.16, Point2::new(-0.01, -0.135)).expect("a tag36h11 id");
        let tag_board = Board::with_apriltag(tag, [Point2::new(-0.16, -0.24), Point2::new(0.14, -0.03)]);
        let corners = pinhole_corners(&camera);
        let pose = IsometryMatrix3::from_parts(
            Translation3::new(0.03, 0.10, 0.40),
            Rotation3::from_scaled_axis(Vector3::new(0.25, -0.3, 0.4)),
        );
        let gray = |surface: Surface| match surface {
            Surface::Background => 40.0,
            Surface::Board => 230.0,
            Surface::Mark => 20.0,
        };
        for board in [Board::paper(), tag_board] {
            let scene = Scene::new(&camera, &board, &pose);
            let (mut sampled, mut differing) = (0usize, 0usize);
            for v in 0..480usize {
                for u in 0..640usize {
                    let top = v * 641;
                    let pinhole =
                        [top + u, top + u + 1, top + 641 + u + 1, top + 641 + u].map(|i| corners[i]);
                    if let Footprint::Whole(_) = footprint(&scene, pinhole.map(|p| scene.on_board(p.x, p.y)))
                    {
                        continue;
                    }
                    sampled += 1;
                    let between = supersample_between(&scene, (u as f64, v as f64), &pinhole, 4, &gray);
                    let mut exact = 0.0;
                    for j in 0..4 {
                        for i in 0..4 {
                            let (x, y) = (
                                u as f64 + (f64::from(i) + 0.5) / 4.0,
                                v as f64 + (f64::from(j) + 0.5) / 4.0,
                            );
                            exact += gray(scene.surface(x, y)) / 16.0;
                        }
                    }
                    let difference = (f64::from(between) - exact).abs();
                    // one sample of 16 changing surface at most
                    assert!(difference <= 210.0 / 16.0 + 1e-3, "pixel ({u}, {v}): {between} vs {exact}");
                    if difference > 1e-3 {
                        differing += 1;
                    }
                }
            }
            assert!(sampled > 1000, "{sampled} pixels sampled");
            assert!(differing * 1000 < sampled, "{differing} of {sampled} sampled pixels differ");
        }
    }

    /// Each mark's dark area is centred where the lens images its centre (within 0.3 px: a disc's image
    /// centroid is not exactly its centre's image), 2 px and more from where a pinhole would.
    #[test]
    fn through_a_lens_the_marks_are_drawn_where_the_lens_images_them() {
        let camera = lens_camera();
        let board = Board::paper();
        let pose = IsometryMatrix3::from_parts(Translation3::new(0.01, 0.13, 0.35), Rotation3::identity());
        let mut renderer = Renderer::new(camera, RenderSettings::default());
        let image = renderer.render(&board, &pose, 0).clone();
        for mark in &board.marks_in_board {
            let in_camera = pose * Point3::new(mark.x, mark.y, 0.0);
            let observed = camera.project_observed(&in_camera).expect("in front");
            let pinhole = camera.project(&in_camera).expect("in front");
            // the darkness-weighted centroid of a 40 × 40 px window around it (board 230, mark 20)
            let (mut weight, mut sum_x, mut sum_y) = (0.0, 0.0, 0.0);
            for v in (observed.y as i64 - 20)..(observed.y as i64 + 20) {
                for u in (observed.x as i64 - 20)..(observed.x as i64 + 20) {
                    let darkness = (230.0 - f64::from(image.get_pixel(u as u32, v as u32)[0])).max(0.0);
                    weight += darkness;
                    sum_x += darkness * (u as f64 + 0.5);
                    sum_y += darkness * (v as f64 + 0.5);
                }
            }
            let drawn = Point2::new(sum_x / weight, sum_y / weight);
            assert!(
                (drawn - observed).norm() < 0.3,
                "mark drawn at {drawn}, the lens images it at {observed}"
            );
            assert!((observed - pinhole).norm() > 2.0, "the lens moves the mark ({observed} vs {pinhole})");
        }
    }
}
