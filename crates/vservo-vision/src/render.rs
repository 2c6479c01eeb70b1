//! The simulated hand camera: renders the board with its marks as an 8-bit grayscale image.
//!
//! Geometry is exact: a pixel's gray is the area-weighted mean of what its footprint sees. Where the edges
//! between a tag's cells cross it, that is the exact share of its footprint the black cells cover
//! (`render/coverage.rs`); where a disc mark's edge or the board's outline may cross it, it is found by
//! supersampling (S × S samples mapped through the board's homography); pixels wholly on the background, the
//! board or a mark take that gray directly. The image is then lit by a linear gradient and gets Gaussian
//! noise, both seeded and repeatable.

use image::GrayImage;
use nalgebra::Point2;
use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3, MARKS};

use crate::noise::{GaussianTable, Xorshift64};
use scene::{Scene, Surface};
pub use vservo_settings::vision::RenderSettings;

mod coverage;
mod lens;
mod scene;

use lens::{Footprint, Lens, Printed, distorted_row, pinhole_corners, printed_footprint};

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
    /// With a distorting lens: the board points of a row's pixel corners, above and below the row being
    /// drawn (each corner is shared by four pixels, so each is mapped once).
    board_corners: [Vec<Option<Point2<f64>>>; 2],
    /// The albedo of the whole image summed over an exposure's instants (width × height, row by row); sized
    /// when the renderer is made if `exposure_s` > 0, else empty.
    exposure_sum: Vec<f32>,
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
            board_corners: [vec![None; w as usize + 1], vec![None; w as usize + 1]],
            exposure_sum: if settings.exposure_s > 0.0 { vec![0.0; (w * h) as usize] } else { Vec::new() },
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
        let height = self.camera.height_px() as i64;
        let boxes = EdgeBoxes::of(&scene);
        let mut rng = self.frame_noise(frame);
        for v in 0..height {
            self.albedo_row(&scene, &boxes, v);
            self.light_row(v, &mut rng);
        }
        &self.image
    }

    /// Renders an exposure: the mean of what the camera sees with the board at each of `camera_from_board`
    /// (instants evenly spread over the time the shutter is open), then lit and with noise as one image, as a
    /// sensor integrates a moving scene. One pose is [`Renderer::render`]'s image.
    pub fn render_exposure(
        &mut self,
        board: &Board,
        camera_from_board: &[IsometryMatrix3<f64>],
        frame: u64,
    ) -> &GrayImage {
        let (width, height) = (self.camera.width_px() as usize, self.camera.height_px() as i64);
        match camera_from_board {
            [] => return &self.image,
            [only] => return self.render(board, only, frame),
            _ => {}
        }
        if self.exposure_sum.len() != width * height as usize {
            // a renderer made without an exposure, asked for one (offline use): sized once
            self.exposure_sum = vec![0.0; width * height as usize];
        }
        self.exposure_sum.fill(0.0);
        for pose in camera_from_board {
            let scene = Scene::new(&self.camera, board, pose);
            let boxes = EdgeBoxes::of(&scene);
            for v in 0..height {
                self.albedo_row(&scene, &boxes, v);
                let sum = &mut self.exposure_sum[v as usize * width..(v as usize + 1) * width];
                sum.iter_mut().zip(&self.albedo).for_each(|(total, albedo)| *total += albedo);
            }
        }
        let instants = camera_from_board.len() as f32;
        let mut rng = self.frame_noise(frame);
        for v in 0..height {
            let sum = &self.exposure_sum[v as usize * width..(v as usize + 1) * width];
            self.albedo.iter_mut().zip(sum).for_each(|(albedo, total)| *albedo = total / instants);
            self.light_row(v, &mut rng);
        }
        &self.image
    }

    /// The noise generator of frame `frame`.
    fn frame_noise(&self, frame: u64) -> Xorshift64 {
        Xorshift64::new(self.settings.noise_seed ^ frame.wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }

    /// Row `v` of the image from the albedo row: lit, with noise.
    fn light_row(&mut self, v: i64, rng: &mut Xorshift64) {
        let (width, height) = (self.camera.width_px() as i64, self.camera.height_px() as i64);
        let out = &mut self.image.as_mut()[(v * width) as usize..((v + 1) * width) as usize];
        light_and_noise(&self.settings, &self.noise, rng, (v, height), &self.albedo, out);
    }

    /// Row `v` of `scene`'s albedo into `self.albedo` (rows must come in order from 0: a lens's corners
    /// are carried from one row to the next).
    fn albedo_row(&mut self, scene: &Scene, boxes: &EdgeBoxes, v: i64) {
        let s = self.settings;
        let gray = |surface: Surface| match surface {
            Surface::Background => s.background_gray,
            Surface::Board => s.board_gray,
            Surface::Mark => s.mark_gray,
        };
        if scene.distorted {
            let lens =
                Lens { pinhole_corners: &self.pinhole_corners, board_corners: &mut self.board_corners };
            distorted_row(scene, lens, v, &mut self.albedo, &gray, s.supersampling.max(1));
        } else {
            pinhole_row(scene, &s, boxes, v, &mut self.albedo, &gray);
        }
    }
}

/// The pixel boxes of the marks and of the tags' black squares (u0, u1, v0, v1, exclusive ends), where the
/// pinhole path looks at each pixel.
struct EdgeBoxes {
    marks: [Option<(i64, i64, i64, i64)>; MARKS],
    tags: Option<(i64, i64, i64, i64)>,
}

impl EdgeBoxes {
    fn of(scene: &Scene) -> Self {
        Self { marks: std::array::from_fn(|i| scene.mark_box(i)), tags: scene.tags_box() }
    }
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

/// The gray of a footprint `black` of whose area is `mark_gray`, the rest `board_gray`.
fn mixed(board_gray: f64, mark_gray: f64, black: f64) -> f32 {
    (board_gray + (mark_gray - board_gray) * black) as f32
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
        Printed::Tags(Footprint::Covered(black)) => Some(mixed(board_gray, mark_gray, black)),
        // disc marks under a grid are judged sample by sample
        Printed::Tags(Footprint::NearMark | Footprint::NearOutline)
        | Printed::GridOverMarks(_)
        | Printed::Marks => None,
    }
}

#[cfg(test)]
mod tests;
