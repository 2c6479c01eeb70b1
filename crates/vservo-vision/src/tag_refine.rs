//! Sub-pixel corners of a tag's black square from the area coverage of the pixels along its four edges.
//!
//! A pixel's gray is the mean of what its footprint sees (the renderer's model, and a camera's to the
//! extent its fill factor is high). So in a strip of whole pixels one pixel wide that crosses a straight
//! edge, the dark length is the sum of the pixels' dark fractions (b − g)/(b − d), b and d the bright and
//! dark levels; it equals the dark length at the strip's centre line exactly, whatever the edge's slope
//! (the edge is linear across the strip). Blur moves gray along the strip but keeps its sum, so the strip
//! still measures the edge as long as it reaches the flat levels on both sides. For an edge that runs
//! more along x than y each strip is a pixel column (else a row); b and d are fitted as straight lines
//! along the edge (a lighting gradient) to the strips' end pixels; a straight line is fitted to the
//! edge positions, once again without the points more than 3 RMS (at least 0.5 px) off; adjacent lines
//! intersect at the corners. A corner is refined when both its edges were measured and it moved at most
//! [`MAX_CORNER_SHIFT_PX`] from the detector's; otherwise it is the detector's own corner (the C library's
//! edge-refined quad), and [`Refined::refined`] says so. An edge with too few strips, a poor fit or too little
//! contrast costs its corners' accuracy, never the tag: the decoder accepted it (docs/VISION.md, "A tag that
//! cannot be refined").
//!
//! Through a distorting lens the square's edges are curves in the image (a line fitted to a bowed edge
//! puts the corners half a pixel out with OpenCV's k1 = −0.25 at 640 × 480): each edge point measured in
//! the image is then taken to its pinhole pixel, the lines are fitted and intersected there, where the
//! edges are straight, and the corners are taken back through the lens ([`Straight`]).

use image::GrayImage;
use nalgebra::{Point2, Vector2};
use vservo_scene::{CameraIntrinsics, MARKS};

/// Where the tag's edges are straight lines: in the image itself (a pinhole camera), or, through a lens
/// that distorts, on the pinhole image of the camera.
#[derive(Debug, Clone, Copy)]
pub enum Straight<'a> {
    /// The image: no distortion.
    InImage,
    /// The pinhole image of this camera (its lens's undistortion).
    OnPinhole(&'a CameraIntrinsics),
}

impl<'a> Straight<'a> {
    /// Where the edges are straight in a picture of `width_px` × `height_px` from `camera`: on its pinhole image
    /// when the picture is the camera's size and its lens distorts, else in the picture itself (a picture of
    /// another size is not the camera's, and its lens does not apply).
    pub fn for_picture(camera: &'a CameraIntrinsics, width_px: u32, height_px: u32) -> Self {
        let fits = (camera.width_px(), camera.height_px()) == (width_px, height_px);
        if fits && !camera.distortion().is_none() { Straight::OnPinhole(camera) } else { Straight::InImage }
    }
}

impl Straight<'_> {
    /// An image point where edges are straight; `None` where the lens has no undistorted point.
    fn of_image(&self, point: Point2<f64>) -> Option<Point2<f64>> {
        match self {
            Straight::InImage => Some(point),
            Straight::OnPinhole(camera) => camera.pinhole_of_observed(&point),
        }
    }

    /// Back to the image.
    fn image_of(&self, point: Point2<f64>) -> Point2<f64> {
        match self {
            Straight::InImage => point,
            Straight::OnPinhole(camera) => camera.observed_of_pinhole(&point),
        }
    }

    /// How far (px) the lens bows the edge from image point `p` to `q` off their chord: the distance
    /// between the chord's midpoint and the image of the straight edge's midpoint (0 without a lens).
    fn bend_px(&self, p: &Point2<f64>, q: &Point2<f64>) -> f64 {
        match (self.of_image(*p), self.of_image(*q)) {
            (Some(a), Some(b)) => (self.image_of(nalgebra::center(&a, &b)) - nalgebra::center(p, q)).norm(),
            _ => f64::INFINITY,
        }
    }
}

/// How far (px) a refined corner may lie from the detector's (through a lens, more by twice the bend of its
/// edges, [`Straight`]).
pub const MAX_CORNER_SHIFT_PX: f64 = 2.0;
/// The largest RMS (px) of an edge's points about its fitted line.
pub const MAX_EDGE_RMS_PX: f64 = 0.35;
/// The fewest strips an edge needs.
pub const MIN_STRIPS: usize = 8;

/// An edge line `normal · p = offset`, with `normal` not necessarily unit.
#[derive(Debug, Clone, Copy)]
struct Line {
    normal: Vector2<f64>,
    offset: f64,
}

/// A measured edge: its line where edges are straight, and the RMS (px) of its points about it.
#[derive(Debug, Clone, Copy)]
struct EdgeFit {
    line: Line,
    rms_px: f64,
}

/// One edge of the black square to measure: strips along axis `along` (0: columns over x, 1: rows over y).
#[derive(Debug, Clone, Copy)]
struct Edge {
    /// The detector's line, as `across = a + b · along` (px).
    a: f64,
    b: f64,
    /// The strips' centres run over [start, end) along the edge (px).
    start: f64,
    end: f64,
    /// 0 when the edge runs along x (strips are columns), 1 when along y (strips are rows).
    along: usize,
    /// Whether the dark side (the tag) lies at larger `across`.
    dark_after: bool,
    /// Half the strip's length, in whole pixels, beside the pixel the edge crosses.
    half_px: i64,
}

/// The four corners of one tag after refinement, and how each was measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refined {
    /// The corners (px, the tag's order).
    pub corners: [Point2<f64>; MARKS],
    /// Per corner: refined on the pixels' coverage (true), or the detector's own corner (false).
    pub refined: [bool; MARKS],
    /// Per edge k (corner k to corner k + 1): the RMS (px) of the edge points about the line fitted to them,
    /// NaN where the edge could not be measured (too small a tag, too few strips, too little contrast, or an
    /// RMS over [`MAX_EDGE_RMS_PX`]).
    pub edge_rms_px: [f64; MARKS],
}

impl Refined {
    /// The detector's corners as they are, nothing refined.
    fn unrefined(corners: &[Point2<f64>; MARKS]) -> Self {
        Self { corners: *corners, refined: [false; MARKS], edge_rms_px: [f64::NAN; MARKS] }
    }

    /// Whether all four corners were refined.
    pub fn all_refined(&self) -> bool {
        self.refined.iter().all(|&r| r)
    }
}

/// Refines the four corners (px, the tag's order) the detector gave: each corner whose two edges could be
/// measured, and which moved plausibly, is refined; the others stay the detector's (see the module's
/// documentation).
pub fn refine_corners(image: &GrayImage, corners: &[Point2<f64>; MARKS], straight: Straight) -> Refined {
    let centre = corners.iter().fold(Vector2::zeros(), |s, c| s + c.coords) / MARKS as f64;
    let shortest =
        (0..MARKS).map(|k| (corners[(k + 1) % MARKS] - corners[k]).norm()).fold(f64::INFINITY, f64::min);
    // strips reach at most half a cell (an eighth of the square) past the edge on either side
    let half_px = ((shortest / 16.0).floor() as i64).min(6);
    let mut result = Refined::unrefined(corners);
    if half_px < 2 {
        return result;
    }
    let lines: [Option<EdgeFit>; MARKS] = std::array::from_fn(|k| {
        let edge = edge_between(&corners[k], &corners[(k + 1) % MARKS], &centre, half_px);
        fit_edge(image, &edge, straight)
    });
    for (k, fit) in lines.iter().enumerate() {
        result.edge_rms_px[k] = fit.map_or(f64::NAN, |f| f.rms_px);
    }
    for k in 0..MARKS {
        let (Some(before), Some(after)) = (&lines[(k + MARKS - 1) % MARKS], &lines[k]) else { continue };
        let Some(crossing) = intersect(&before.line, &after.line) else { continue };
        let corner = straight.image_of(crossing);
        // the detector fits straight lines in the image: through a lens its corners are off by up to
        // about the edges' bend
        let (previous, next) = (&corners[(k + MARKS - 1) % MARKS], &corners[(k + 1) % MARKS]);
        let bend = straight.bend_px(previous, &corners[k]).max(straight.bend_px(&corners[k], next));
        if (corner - corners[k]).norm() <= MAX_CORNER_SHIFT_PX + 2.0 * bend {
            result.corners[k] = corner;
            result.refined[k] = true;
        }
    }
    result
}

/// The edge from corner `p` to corner `q` of a square centred at `centre`.
fn edge_between(p: &Point2<f64>, q: &Point2<f64>, centre: &Vector2<f64>, half_px: i64) -> Edge {
    let d = q - p;
    let along = if d.x.abs() >= d.y.abs() { 0 } else { 1 };
    let across = 1 - along;
    let b = d[across] / d[along];
    let a = p[across] - b * p[along];
    // keep clear of the corners, where the adjacent edge enters the strips
    let clear = 2.0 * (half_px as f64 + 2.0);
    let (lo, hi) = (p[along].min(q[along]), p[along].max(q[along]));
    let dark_after = centre[across] > a + b * centre[along];
    Edge { a, b, start: lo + clear, end: hi - clear, along, dark_after, half_px }
}

/// The strip at pixel index `index` along the edge: the first pixel index across and the grays, or `None`
/// when it leaves the image. Its centre along the edge is `index + ½`.
fn strip(image: &GrayImage, edge: &Edge, index: i64, grays: &mut [f64; 13]) -> Option<i64> {
    let centre = index as f64 + 0.5;
    let first = (edge.a + edge.b * centre).floor() as i64 - edge.half_px;
    let count = 2 * edge.half_px + 1;
    let (w, h) = (i64::from(image.width()), i64::from(image.height()));
    for (i, gray) in grays.iter_mut().take(count as usize).enumerate() {
        let across = first + i as i64;
        let (u, v) = if edge.along == 0 { (index, across) } else { (across, index) };
        if u < 0 || v < 0 || u >= w || v >= h {
            return None;
        }
        *gray = f64::from(image.as_raw()[(v * w + u) as usize]);
    }
    Some(first)
}

/// The strips' pixel indices along the edge.
fn strip_indices(edge: &Edge) -> std::ops::Range<i64> {
    (edge.start - 0.5).ceil() as i64..(edge.end - 0.5).floor() as i64 + 1
}

/// Least squares of y = α + β t over accumulated sums.
#[derive(Debug, Default, Clone, Copy)]
struct LineFit {
    n: f64,
    t: f64,
    y: f64,
    tt: f64,
    ty: f64,
}

impl LineFit {
    fn add(&mut self, t: f64, y: f64) {
        self.n += 1.0;
        self.t += t;
        self.y += y;
        self.tt += t * t;
        self.ty += t * y;
    }

    /// (α, β), or `None` with fewer than two distinct t.
    fn solve(&self) -> Option<(f64, f64)> {
        let det = self.n * self.tt - self.t * self.t;
        if self.n < 2.0 || det.abs() < 1e-9 {
            return None;
        }
        let beta = (self.n * self.ty - self.t * self.y) / det;
        Some(((self.y - beta * self.t) / self.n, beta))
    }
}

/// The dark and bright levels along the edge, each a straight line `level = a + b·t` in the strip's centre
/// `t`: (dark, bright).
type Levels = ((f64, f64), (f64, f64));

/// The dark and bright levels along the edge, from the two end pixels of each strip on each side. A strip
/// whose ends do not reach the levels (something over the edge: a shadow, a covering, a neighbour) is left
/// out of a second fit, and of the edge ([`edge_point`]).
fn fit_levels(image: &GrayImage, edge: &Edge) -> Option<Levels> {
    let first = fit_levels_over(image, edge, |_, _| true)?;
    let mut grays = [0.0; 13];
    let all_reach = strip_indices(edge).all(|index| {
        strip(image, edge, index, &mut grays)
            .is_none_or(|_| reaches_levels(&first, index, strip_ends(edge, &grays)))
    });
    if all_reach {
        Some(first)
    } else {
        fit_levels_over(image, edge, |index, ends| reaches_levels(&first, index, ends))
    }
}

/// The levels fitted to the ends of the strips `keep` takes (by index and ends).
fn fit_levels_over(image: &GrayImage, edge: &Edge, keep: impl Fn(i64, (f64, f64)) -> bool) -> Option<Levels> {
    let (mut dark, mut bright) = (LineFit::default(), LineFit::default());
    let mut grays = [0.0; 13];
    for index in strip_indices(edge) {
        if strip(image, edge, index, &mut grays).is_none() {
            continue;
        }
        let ends = strip_ends(edge, &grays);
        if !keep(index, ends) {
            continue;
        }
        let t = index as f64 + 0.5;
        dark.add(t, ends.0);
        bright.add(t, ends.1);
    }
    Some((dark.solve()?, bright.solve()?))
}

/// A strip's (dark end, bright end): the mean of its two end pixels on each side.
fn strip_ends(edge: &Edge, grays: &[f64; 13]) -> (f64, f64) {
    let last = (2 * edge.half_px) as usize;
    let (low_end, high_end) = (0.5 * (grays[0] + grays[1]), 0.5 * (grays[last] + grays[last - 1]));
    if edge.dark_after { (high_end, low_end) } else { (low_end, high_end) }
}

/// Whether a strip's ends lie within a quarter of the contrast of the levels at its centre.
fn reaches_levels(levels: &Levels, index: i64, (dark_end, bright_end): (f64, f64)) -> bool {
    let t = index as f64 + 0.5;
    let ((d0, d1), (b0, b1)) = *levels;
    let (dark, bright) = (d0 + d1 * t, b0 + b1 * t);
    let tolerance = 0.25 * (bright - dark).abs();
    (dark_end - dark).abs() <= tolerance && (bright_end - bright).abs() <= tolerance
}

/// The edge's position across at strip `index`, from the dark length; `None` where the strip leaves the image,
/// the contrast is too low, or the strip's ends do not reach the levels.
fn edge_point(image: &GrayImage, edge: &Edge, index: i64, levels: &Levels) -> Option<(f64, f64)> {
    let mut grays = [0.0; 13];
    let first = strip(image, edge, index, &mut grays)?;
    let t = index as f64 + 0.5;
    let ((d0, d1), (b0, b1)) = *levels;
    let (dark, bright) = (d0 + d1 * t, b0 + b1 * t);
    // a contrast under 20 gray levels says nothing reliable about an edge
    if bright - dark < 20.0 || !reaches_levels(levels, index, strip_ends(edge, &grays)) {
        return None;
    }
    let count = (2 * edge.half_px + 1) as usize;
    let dark_length: f64 = grays[..count].iter().map(|g| (bright - g) / (bright - dark)).sum();
    let across = if edge.dark_after {
        (first + count as i64) as f64 - dark_length
    } else {
        first as f64 + dark_length
    };
    Some((t, across))
}

/// The edge's line from its strips: fit, drop points off by more than 3 RMS (≥ 0.5 px), fit again; the
/// points and the line where the edges are straight (`straight`), as (along, across) there.
fn fit_edge(image: &GrayImage, edge: &Edge, straight: Straight) -> Option<EdgeFit> {
    let levels = fit_levels(image, edge)?;
    let across = 1 - edge.along;
    let to_straight = |(t, y): (f64, f64)| {
        let in_image = if edge.along == 0 { Point2::new(t, y) } else { Point2::new(y, t) };
        straight.of_image(in_image).map(|p| (p[edge.along], p[across]))
    };
    let points =
        || strip_indices(edge).filter_map(|i| edge_point(image, edge, i, &levels)).filter_map(to_straight);
    let mut first = LineFit::default();
    points().for_each(|(t, y)| first.add(t, y));
    let (a, b) = first.solve()?;
    let rms = (points().map(|(t, y)| (y - a - b * t).powi(2)).sum::<f64>() / first.n).sqrt();
    let gate = (3.0 * rms).max(0.5);
    let mut kept = LineFit::default();
    points().filter(|(t, y)| (y - a - b * t).abs() <= gate).for_each(|(t, y)| kept.add(t, y));
    let (a, b) = kept.solve()?;
    let rms = (points()
        .filter(|(t, y)| (y - a - b * t).abs() <= gate)
        .map(|(t, y)| (y - a - b * t).powi(2))
        .sum::<f64>()
        / kept.n)
        .sqrt();
    if (kept.n as usize) < MIN_STRIPS || rms > MAX_EDGE_RMS_PX {
        return None;
    }
    // across = a + b·along, i.e. −b·along + across = a
    let normal = if edge.along == 0 { Vector2::new(-b, 1.0) } else { Vector2::new(1.0, -b) };
    Some(EdgeFit { line: Line { normal, offset: a }, rms_px: rms })
}

/// Where two lines cross; `None` for (nearly) parallel ones.
fn intersect(l: &Line, m: &Line) -> Option<Point2<f64>> {
    let det = l.normal.x * m.normal.y - l.normal.y * m.normal.x;
    if det.abs() < 1e-9 {
        return None;
    }
    Some(Point2::new(
        (l.offset * m.normal.y - l.normal.y * m.offset) / det,
        (l.normal.x * m.offset - l.offset * m.normal.x) / det,
    ))
}
