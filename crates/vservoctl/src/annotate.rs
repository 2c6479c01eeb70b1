//! The marks drawn on a camera image, as `vservoctl snapshot` and `vservoctl plot --frames` show them: each
//! mark the vision node found (a green cross), where the servo wants it (a red ring: ξ_d) and the error between
//! them (a yellow line). Features are drawn where they lie in the image: through the lens when the vision node
//! undistorts them (`vision.undistort`).

use image::{Rgb, RgbImage};
use nalgebra::Point2;
use vservo_protocol::MARKS;

/// A found mark.
pub const FOUND: Rgb<u8> = Rgb([0, 220, 0]);
/// Where the servo wants a mark.
pub const DESIRED: Rgb<u8> = Rgb([230, 0, 0]);
/// From a mark to where it is wanted.
pub const ERROR: Rgb<u8> = Rgb([240, 220, 0]);
/// The collision guard's obstacles, as wireframes.
pub const OBSTACLE: Rgb<u8> = Rgb([0, 200, 255]);
/// Half the cross's arm (px).
const CROSS_PX: i64 = 7;
/// The desired ring's radius (px): outside a mark's image at the paper's distance.
const RING_PX: f64 = 11.0;

/// One mark as drawn: where it was found (if it was), where it is wanted, in the image's pixels.
pub struct MarkDrawn {
    pub found: Option<Point2<f64>>,
    pub wanted: Point2<f64>,
}

impl MarkDrawn {
    /// From where it was found to where it is wanted (px).
    pub fn error_px(&self) -> Option<f64> {
        self.found.map(|found| (found - self.wanted).norm())
    }
}

/// A gray image (`width` × `height`, rows of `stride` bytes) as RGB, to draw on.
pub fn gray_to_rgb(width: u32, height: u32, stride: u32, pixels: &[u8]) -> RgbImage {
    RgbImage::from_fn(width, height, |u, v| {
        let gray = pixels.get((v * stride + u) as usize).copied().unwrap_or(0);
        Rgb([gray, gray, gray])
    })
}

/// Draws the four marks of one frame on `picture`: `features_px` (those of `valid_mask`) and `desired_px`
/// in the law's pixels, `shown` mapping them into the image.
pub fn draw_marks(
    picture: &mut RgbImage,
    features_px: &[f64; 2 * MARKS],
    valid_mask: u32,
    desired_px: &[f64; 2 * MARKS],
    shown: impl Fn(f64, f64) -> Point2<f64>,
) -> Vec<MarkDrawn> {
    (0..MARKS)
        .map(|mark| {
            let wanted = shown(desired_px[2 * mark], desired_px[2 * mark + 1]);
            ring(picture, wanted, DESIRED);
            let seen = valid_mask & (1 << mark) != 0;
            let found = seen.then(|| shown(features_px[2 * mark], features_px[2 * mark + 1]));
            if let Some(found) = found {
                line(picture, found, wanted, ERROR);
                cross(picture, found, FOUND);
            }
            MarkDrawn { found, wanted }
        })
        .collect()
}

/// Sets the pixel holding `(x, y)` in vservo's pixels (a pixel's centre at + ½), if it is in the picture.
fn put(picture: &mut RgbImage, x: f64, y: f64, colour: Rgb<u8>) {
    let (u, v) = (x.floor(), y.floor());
    if u >= 0.0 && v >= 0.0 && (u as u32) < picture.width() && (v as u32) < picture.height() {
        picture.put_pixel(u as u32, v as u32, colour);
    }
}

fn cross(picture: &mut RgbImage, at: Point2<f64>, colour: Rgb<u8>) {
    for d in -CROSS_PX..=CROSS_PX {
        put(picture, at.x + d as f64, at.y, colour);
        put(picture, at.x, at.y + d as f64, colour);
    }
}

fn ring(picture: &mut RgbImage, at: Point2<f64>, colour: Rgb<u8>) {
    let steps = 128;
    for k in 0..steps {
        let angle = std::f64::consts::TAU * f64::from(k) / f64::from(steps);
        put(picture, at.x + RING_PX * angle.cos(), at.y + RING_PX * angle.sin(), colour);
    }
}

fn line(picture: &mut RgbImage, from: Point2<f64>, to: Point2<f64>, colour: Rgb<u8>) {
    let steps = (to - from).norm().ceil().clamp(1.0, 4096.0) as u32;
    for k in 0..=steps {
        let p = from + (to - from) * (f64::from(k) / f64::from(steps));
        put(picture, p.x, p.y, colour);
    }
}

/// A detected tag (`vservoctl tags --draw`): its outline through its four corners (the first corner marked
/// with a cross, the tag's order), and its id written in digits at its centre.
pub fn draw_tag(picture: &mut RgbImage, corners: &[Point2<f64>; MARKS], id: u32, colour: Rgb<u8>) {
    for k in 0..MARKS {
        line(picture, corners[k], corners[(k + 1) % MARKS], colour);
    }
    cross(picture, corners[0], DESIRED);
    let centre = corners.iter().fold(Point2::origin(), |sum, c| sum + c.coords / MARKS as f64);
    let edge = (corners[1] - corners[0]).norm();
    let scale = (edge / 24.0).clamp(1.0, 6.0).floor();
    number(picture, centre, id, scale, colour);
}

/// Digits 0–9 in 3 × 5 cells, a row of three bits each (the top row first).
const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111],
    [0b010, 0b110, 0b010, 0b010, 0b111],
    [0b111, 0b001, 0b111, 0b100, 0b111],
    [0b111, 0b001, 0b111, 0b001, 0b111],
    [0b101, 0b101, 0b111, 0b001, 0b001],
    [0b111, 0b100, 0b111, 0b001, 0b111],
    [0b111, 0b100, 0b111, 0b101, 0b111],
    [0b111, 0b001, 0b010, 0b010, 0b010],
    [0b111, 0b101, 0b111, 0b101, 0b111],
    [0b111, 0b101, 0b111, 0b001, 0b111],
];

/// Writes `value` centred at `at`, each cell of a digit `scale` px square, on a black backing.
fn number(picture: &mut RgbImage, at: Point2<f64>, value: u32, scale: f64, colour: Rgb<u8>) {
    let text = value.to_string();
    let (cell, count) = (scale, text.len() as f64);
    let (width, height) = ((4.0 * count - 1.0) * cell, 5.0 * cell);
    let origin = Point2::new(at.x - width / 2.0, at.y - height / 2.0);
    for dv in -1..=(height as i64) {
        for du in -1..=(width as i64) {
            put(picture, origin.x + du as f64, origin.y + dv as f64, Rgb([0, 0, 0]));
        }
    }
    for (place, digit) in text.bytes().enumerate() {
        let rows = DIGITS[usize::from(digit - b'0')];
        for (row, bits) in rows.iter().enumerate() {
            for column in 0..3 {
                if bits & (0b100 >> column) == 0 {
                    continue;
                }
                let left = origin.x + (4.0 * place as f64 + f64::from(column)) * cell;
                let top = origin.y + row as f64 * cell;
                for dv in 0..(cell as i64) {
                    for du in 0..(cell as i64) {
                        put(picture, left + du as f64, top + dv as f64, colour);
                    }
                }
            }
        }
    }
}

/// Pieces a segment of a wireframe is cut into before it goes through the lens (its image bends with distortion).
const WIREFRAME_PIECES: u32 = 32;
/// Nearer to the camera than this (m), a wireframe is not drawn.
const WIREFRAME_NEAR_M: f64 = 0.02;

/// A wireframe seen by `camera`: each segment (in the camera frame) cut short where it comes nearer than a few
/// centimetres, through the lens piece by piece, each piece drawn where both its ends image within the lens's
/// valid region. Whether any piece fell in the picture.
pub fn draw_wireframe(
    picture: &mut RgbImage,
    segments_in_camera: &[[nalgebra::Point3<f64>; 2]],
    camera: &vservo_scene::CameraIntrinsics,
    colour: Rgb<u8>,
) -> bool {
    let valid_radius = camera.distortion().valid_radius();
    let image = |p: &nalgebra::Point3<f64>| {
        let within = p.z >= WIREFRAME_NEAR_M && (p.x / p.z).hypot(p.y / p.z) <= valid_radius;
        within.then(|| camera.project_observed(p)).flatten()
    };
    let mut seen = false;
    for [from, to] in segments_in_camera {
        for k in 0..WIREFRAME_PIECES {
            let at = |t: u32| from + (to - from) * (f64::from(t) / f64::from(WIREFRAME_PIECES));
            if let (Some(a), Some(b)) = (image(&at(k)), image(&at(k + 1))) {
                seen |= [a, b].iter().any(|p| camera.contains(p));
                line(picture, a, b, colour);
            }
        }
    }
    seen
}
