//! Image sources: the simulated camera, and a directory of recorded images.

use std::path::{Path, PathBuf};

use image::GrayImage;
use nalgebra::Point2;
use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3};

use crate::render::{RenderSettings, Renderer};

/// Why an image could not be had.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The directory could not be listed.
    #[error("{path}: cannot list images: {reason}")]
    Directory {
        /// The directory.
        path: String,
        /// The operating system's reason.
        reason: String,
    },
    /// The directory holds no PGM or PNG file.
    #[error("{0}: holds no .pgm or .png image")]
    Empty(String),
    /// A file could not be read as an 8-bit grayscale image.
    #[error("{path}: {reason}")]
    Image {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
}

/// Reads an image file (PNG or binary PGM) as 8-bit grayscale. Colour or 16-bit images are refused rather
/// than converted, so that a wrong camera setting shows up.
pub fn read_gray_image(path: &Path) -> Result<GrayImage, SourceError> {
    let error = |reason: String| SourceError::Image { path: path.display().to_string(), reason };
    let decoded = image::ImageReader::open(path)
        .map_err(|e| error(e.to_string()))?
        .with_guessed_format()
        .map_err(|e| error(e.to_string()))?
        .decode()
        .map_err(|e| error(e.to_string()))?;
    match decoded {
        image::DynamicImage::ImageLuma8(gray) => Ok(gray),
        other => Err(error(format!("is {:?}, not 8-bit grayscale", other.color()))),
    }
}

/// Reads any 8-bit or 16-bit gray or colour PNG, JPEG or PGM as 8-bit grayscale, for looking at a picture
/// (`vservoctl tags`, `vservoctl vision extract`): a JPEG gives its luma channel Y as coded (what OpenCV's and
/// the AprilTag library's grayscale readers give, and a YUY2 camera's Y), other colour its luma Y = 0.299 R +
/// 0.587 G + 0.114 B (ITU-R BT.601), rounded; 16 bits become 8. Also the image's colour type as stored, for
/// reports.
pub fn read_image_as_gray(path: &Path) -> Result<(GrayImage, image::ColorType), SourceError> {
    use image::ImageDecoder;
    let error = |reason: String| SourceError::Image { path: path.display().to_string(), reason };
    let bytes = std::fs::read(path).map_err(|e| error(e.to_string()))?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| error(e.to_string()))?;
    if reader.format() == Some(image::ImageFormat::Jpeg) {
        let colour = reader.into_decoder().map_err(|e| error(e.to_string()))?.color_type();
        return Ok((jpeg_luma(&bytes).map_err(error)?, colour));
    }
    let decoded = reader.decode().map_err(|e| error(e.to_string()))?;
    let colour = decoded.color();
    let gray = match decoded {
        image::DynamicImage::ImageLuma8(gray) => gray,
        other if !colour.has_color() => other.into_luma8(),
        other => bt601_luma(&other.into_rgb8()),
    };
    Ok((gray, colour))
}

/// One detection of the AprilTag C library's test data: the id and the corners (px, the tag's order).
pub type TestDetection = (u32, [Point2<f64>; 4]);

/// The detections the AprilTag C library's own test data lists beside a picture (its `test/data/*.txt`: one tag a
/// line, `id, (x y), (x y), (x y), (x y)`, the corners in the tag's order as `apriltag_detection_t::p` gives them,
/// in vservo's pixels already: the library's quad fit adds the half pixel itself), as id and corners: the
/// reference of the real-photograph tests.
pub fn read_apriltag_test_detections(path: &Path) -> Result<Vec<TestDetection>, SourceError> {
    let error = |reason: String| SourceError::Image { path: path.display().to_string(), reason };
    let text = std::fs::read_to_string(path).map_err(|e| error(e.to_string()))?;
    let mut detections = Vec::new();
    for (number, line) in text.lines().enumerate().filter(|(_, line)| !line.trim().is_empty()) {
        let values: Vec<f64> = line
            .split(|c: char| c == ',' || c == '(' || c == ')' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|e| error(format!("line {}: {e}", number + 1)))?;
        if values.len() != 9 || values[0] < 0.0 || values[0].fract() != 0.0 {
            return Err(error(format!("line {}: not `id, (x y), (x y), (x y), (x y)`", number + 1)));
        }
        let corners = std::array::from_fn(|k| Point2::new(values[1 + 2 * k], values[2 + 2 * k]));
        detections.push((values[0] as u32, corners));
    }
    Ok(detections)
}

/// A JPEG's luma channel, decoded alone.
fn jpeg_luma(bytes: &[u8]) -> Result<GrayImage, String> {
    let options = zune_core::options::DecoderOptions::default()
        .jpeg_set_out_colorspace(zune_core::colorspace::ColorSpace::Luma);
    let mut decoder =
        zune_jpeg::JpegDecoder::new_with_options(zune_core::bytestream::ZCursor::new(bytes), options);
    let pixels = decoder.decode().map_err(|e| format!("{e:?}"))?;
    let info = decoder.info().ok_or("no JPEG header")?;
    GrayImage::from_raw(u32::from(info.width), u32::from(info.height), pixels)
        .ok_or_else(|| "the JPEG's luma is not width × height bytes".to_string())
}

/// The BT.601 luma of an RGB image.
fn bt601_luma(rgb: &image::RgbImage) -> GrayImage {
    GrayImage::from_fn(rgb.width(), rgb.height(), |u, v| {
        let [r, g, b] = rgb.get_pixel(u, v).0.map(f64::from);
        image::Luma([(0.299 * r + 0.587 * g + 0.114 * b).round().clamp(0.0, 255.0) as u8])
    })
}

/// The simulated hand camera: renders the board as seen from the camera.
#[derive(Debug, Clone)]
pub struct SimulatedCamera {
    renderer: Renderer,
    board: Board,
}

impl SimulatedCamera {
    /// A camera that sees `board`.
    pub fn new(camera: CameraIntrinsics, board: Board, settings: RenderSettings) -> Self {
        Self { renderer: Renderer::new(camera, settings), board }
    }

    /// The image of frame `frame` with the board at `camera_from_board`.
    pub fn capture(&mut self, camera_from_board: &IsometryMatrix3<f64>, frame: u64) -> &GrayImage {
        self.renderer.render(&self.board, camera_from_board, frame)
    }

    /// [`SimulatedCamera::capture`] with the marks of `hidden` (bit m for mark m) covered, as if by something
    /// the board's colour: a scenario's occlusion. With an AprilTag target, the corners of `hidden` are
    /// covered ([`vservo_scene::AprilTag::with_corners_covered`]); with a bundle, its tags of `hidden` whole
    /// ([`vservo_scene::TagBundle::with_tags_covered`]).
    pub fn capture_hiding(
        &mut self,
        camera_from_board: &IsometryMatrix3<f64>,
        frame: u64,
        hidden: u8,
    ) -> &GrayImage {
        self.capture_exposure(std::slice::from_ref(camera_from_board), frame, hidden)
    }

    /// [`SimulatedCamera::capture_hiding`] over an exposure: the board at each of `camera_from_board`
    /// (instants spread evenly over the time the shutter is open), blurred by its motion as a real camera's
    /// image is ([`crate::render::Renderer::render_exposure`]).
    pub fn capture_exposure(
        &mut self,
        camera_from_board: &[IsometryMatrix3<f64>],
        frame: u64,
        hidden: u8,
    ) -> &GrayImage {
        if hidden == 0 {
            return self.renderer.render_exposure(&self.board, camera_from_board, frame);
        }
        let mut board = self.board;
        if let Some(tag) = board.apriltag() {
            // a tag's corner is covered where it lies, by a patch of white over it
            board.target = vservo_scene::Target::AprilTag(tag.with_corners_covered(hidden));
            return self.renderer.render_exposure(&board, camera_from_board, frame);
        }
        if let Some(bundle) = board.bundle() {
            // a bundle's tag k is covered whole, by a white patch over it (all of them: a bare board, whose
            // zero-sized marks draw nothing)
            board.target = bundle
                .with_tags_covered(hidden)
                .map_or(vservo_scene::Target::Marks, vservo_scene::Target::Bundle);
            return self.renderer.render_exposure(&board, camera_from_board, frame);
        }
        for (index, mark) in board.marks_in_board.iter_mut().enumerate() {
            if hidden & (1 << index) != 0 {
                // off the board, where nothing of it is drawn
                let [lo, _] = board.extent_in_board;
                *mark = nalgebra::Point3::new(lo.x - 10.0, lo.y - 10.0, 0.0);
            }
        }
        self.renderer.render_exposure(&board, camera_from_board, frame)
    }

    /// The last image captured.
    pub fn image(&self) -> &GrayImage {
        self.renderer.image()
    }
}

/// Recorded images, in file-name order, one per frame; after the last it starts again.
#[derive(Debug, Clone)]
pub struct DirectorySource {
    files: Vec<PathBuf>,
    next: usize,
}

impl DirectorySource {
    /// Lists the `.pgm` and `.png` files of a directory.
    pub fn open(directory: &Path) -> Result<Self, SourceError> {
        let listing = std::fs::read_dir(directory).map_err(|e| SourceError::Directory {
            path: directory.display().to_string(),
            reason: e.to_string(),
        })?;
        let mut files: Vec<PathBuf> = listing
            .filter_map(|entry| entry.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| e.eq_ignore_ascii_case("pgm") || e.eq_ignore_ascii_case("png"))
            })
            .collect();
        files.sort();
        if files.is_empty() {
            return Err(SourceError::Empty(directory.display().to_string()));
        }
        Ok(Self { files, next: 0 })
    }

    /// The number of images.
    pub fn len(&self) -> usize {
        self.files.len()
    }

    /// Whether there are none (never true for an opened source).
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// The next image and its file.
    pub fn next_image(&mut self) -> (PathBuf, Result<GrayImage, SourceError>) {
        let path = self.files[self.next % self.files.len()].clone();
        self.next += 1;
        let image = read_gray_image(&path);
        (path, image)
    }
}
