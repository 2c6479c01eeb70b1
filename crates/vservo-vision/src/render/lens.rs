//! The path through a lens that distorts: each pixel's corners taken to the pinhole image once per camera and
//! to the board by each frame's homography, and a pixel judged whole, covered exactly by a tag's cells, or
//! supersampled between its corners.

use nalgebra::Point2;
use vservo_scene::{AprilTag, Board, CameraIntrinsics, TagGrid};

use super::scene::{Scene, Surface};
use super::{coverage, mixed};

/// The pinhole pixel of every pixel corner of a distorting camera (NaN where the lens has none), row by row;
/// empty for a pinhole camera.
pub(super) fn pinhole_corners(camera: &CameraIntrinsics) -> Vec<Point2<f64>> {
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
pub(super) enum Footprint {
    /// All of it sees one surface.
    Whole(Surface),
    /// A mark's edge may cross it.
    NearMark,
    /// Tags' cells of both colours meet it: this share of it is black (exact, from the clipped areas).
    Covered(f64),
    /// The board's outline may cross it (or part of it misses the board plane or the lens).
    NearOutline,
}

/// What a distorting lens's rows need: the pinhole points of every pixel corner (per camera), and the board
/// points of the corners above and below the row (per frame, the row above kept from the last row).
pub(super) struct Lens<'a> {
    pub(super) pinhole_corners: &'a [Point2<f64>],
    pub(super) board_corners: &'a mut [Vec<Option<Point2<f64>>>; 2],
}

/// Row `v` of the albedo through a distorting lens: each pixel is judged by where its corners' rays meet the
/// board (the lens's map of the corners, computed once per camera, then this frame's homography, once per
/// corner) and supersampled where an edge may cross it. Within one pixel the lens's map is taken as bilinear
/// between the corners' pinhole points (its bend over a pixel is below 1e-3 px for the lenses here), so a
/// sample costs a homography, not an undistortion.
pub(super) fn distorted_row(
    scene: &Scene,
    lens: Lens,
    v: i64,
    row: &mut [f32],
    gray: &impl Fn(Surface) -> f64,
    samples: u32,
) {
    let stride = row.len() + 1;
    let top = v as usize * stride;
    let pinhole_corners = lens.pinhole_corners;
    let on_board = |i: usize| {
        let p = pinhole_corners[i];
        scene.on_board(p.x, p.y)
    };
    // the corners above this row are those below the last one, but on the first row
    let [above, below] = lens.board_corners;
    if v == 0 {
        above.iter_mut().enumerate().for_each(|(u, corner)| *corner = on_board(u));
    } else {
        std::mem::swap(above, below);
    }
    below.iter_mut().enumerate().for_each(|(u, corner)| *corner = on_board(top + stride + u));
    // mark and tag edges get the full count (they carry the features); the outline half as many per axis
    let outline_samples = (samples / 2).max(2);
    for (u, albedo) in row.iter_mut().enumerate() {
        let pinhole =
            [top + u, top + u + 1, top + stride + u + 1, top + stride + u].map(|i| pinhole_corners[i]);
        let corners = [above[u], above[u + 1], below[u + 1], below[u]];
        *albedo = match footprint(scene, corners) {
            Footprint::Whole(surface) => gray(surface) as f32,
            Footprint::Covered(black) => mixed(gray(Surface::Board), gray(Surface::Mark), black),
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
pub(super) fn supersample_between(
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
pub(super) fn footprint(scene: &Scene, corners: [Option<Point2<f64>>; 4]) -> Footprint {
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
        // a disc mark may be near too: sampled, as both are
        Printed::GridOverMarks(Footprint::Covered(_)) => return Footprint::NearMark,
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
pub(super) enum Printed {
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
pub(super) fn printed_footprint(board: &Board, points: &[Point2<f64>; 4], margin: f64) -> Printed {
    let on_grid = || board.calibration_grid.as_ref().map(|grid| grid_footprint(grid, points, margin));
    let on_target = match board.target_tags() {
        [] => return on_grid().map_or(Printed::Marks, Printed::GridOverMarks),
        [tag] => tag_footprint(tag, points, margin),
        bundle => tags_footprint(bundle.iter().copied(), points, margin),
    };
    Printed::Tags(on_target.or_else(on_grid).unwrap_or(Footprint::Whole(Surface::Board)))
}

/// Judges a pixel's footprint on the calibration grid: every tag that can reach it judged alone
/// ([`tags_footprint`]).
#[inline]
pub(super) fn grid_footprint(grid: &TagGrid, points: &[Point2<f64>; 4], margin: f64) -> Footprint {
    let low = Point2::new(
        points.iter().map(|p| p.x).fold(f64::INFINITY, f64::min) - margin,
        points.iter().map(|p| p.y).fold(f64::INFINITY, f64::min) - margin,
    );
    let high = Point2::new(
        points.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max) + margin,
        points.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max) + margin,
    );
    tags_footprint(grid.tags_meeting(low, high), points, margin).unwrap_or(Footprint::Whole(Surface::Board))
}

/// Judges a pixel's footprint on several tags, each judged alone; `None` wholly beside all of them. A
/// footprint wholly in one tag's cell is beside every other tag (a grid's gaps and a bundle's are a tag's
/// border wide at least); the tags' black cells are apart, so the shares of those it meets add up.
#[inline]
fn tags_footprint(
    tags: impl IntoIterator<Item = AprilTag>,
    points: &[Point2<f64>; 4],
    margin: f64,
) -> Option<Footprint> {
    let mut judged: Option<Footprint> = None;
    for tag in tags {
        let Some(next) = tag_footprint(&tag, points, margin) else { continue };
        judged = Some(match (judged, next) {
            (None | Some(Footprint::Whole(Surface::Board)), next) => next,
            (Some(judged), Footprint::Whole(Surface::Board)) => judged,
            (Some(Footprint::Covered(black)), Footprint::Covered(more)) => Footprint::Covered(black + more),
            // wholly black in one tag and met by another, or near an edge to sample
            _ => return Some(Footprint::NearMark),
        });
    }
    judged.map(|judged| match judged {
        Footprint::Covered(black) => Footprint::Covered(black.min(1.0)),
        judged => judged,
    })
}

/// Judges a pixel's footprint on a tag, from its corners' board points and the margin for the lens's bend:
/// wholly in cells of one colour, the share of it that is black where cells of both colours meet it (exact
/// for the quadrilateral between its corners, which the lens bends by far less than a gray level's worth),
/// or near an edge to sample; `None` wholly beside the tag's black square.
#[inline]
pub(super) fn tag_footprint(tag: &AprilTag, points: &[Point2<f64>; 4], margin: f64) -> Option<Footprint> {
    let cells = f64::from(vservo_scene::tag36h11::WIDTH_AT_BORDER);
    let per_cell = tag.size_m() / cells;
    let c = tag.centre_in_board();
    // in cell units, the square's corner at (0, 0)
    let local = points.map(|p| ((p.x - c.x) / per_cell + 0.5 * cells, (p.y - c.y) / per_cell + 0.5 * cells));
    let m = margin / per_cell;
    // the footprint's extent in cell units, lowest and highest along each axis
    let extent = |axis: fn(&(f64, f64)) -> f64| {
        local
            .iter()
            .map(axis)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), v| (low.min(v), high.max(v)))
    };
    let (x, y) = (extent(|l| l.0), extent(|l| l.1));
    let beside = x.1 < -m || x.0 > cells + m || y.1 < -m || y.0 > cells + m;
    if beside {
        return None;
    }
    // the cells the footprint (and the margin) can reach: all inside the square and of one colour, or near an
    // edge between colours
    let reach = |(low, high): (f64, f64)| ((low - m).floor(), (high + m).floor());
    let (columns, rows) = (reach(x), reach(y));
    // a footprint over more than 3 × 3 cells, or reaching further than the cell beside the square, is
    // sampled: the cells next to the square are the white around it (a grid's gaps are two cells or more,
    // the board's outline was judged first), further ones may be another tag's
    let within = |(first, last): (f64, f64)| first >= -1.0 && last <= cells && last - first <= 2.0;
    if !(within(columns) && within(rows)) {
        return Some(Footprint::NearMark);
    }
    // a cell beside the square is the board's white
    let black_in = |column: f64, row: f64| tag.is_black_cell(column, row);
    let black = black_in(columns.0, rows.0);
    let one_colour = (columns.1 - columns.0 <= 1.0 && rows.1 - rows.0 <= 1.0)
        && [(columns.0, rows.1), (columns.1, rows.0), (columns.1, rows.1)]
            .iter()
            .all(|&(column, row)| black_in(column, row) == black);
    if one_colour {
        return Some(Footprint::Whole(if black { Surface::Mark } else { Surface::Board }));
    }
    let quad = local.map(|(x, y)| [x, y]);
    Some(
        coverage::black_share(&quad, columns, rows, black_in).map_or(Footprint::NearMark, Footprint::Covered),
    )
}
