//! A ROS camera as vservo's camera driver, the pure part: a `sensor_msgs/Image` as the 8-bit gray image
//! `camera_image` carries (docs/DRIVERS.md, "The camera driver"), or why not.
//!
//! Taken: `mono8`, `mono16` (its high byte), `8UC1`, the colour encodings `rgb8`, `bgr8`, `rgba8`, `bgra8`
//! (their luma, ITU-R BT.601 in integers, as OpenCV's `cvtColor`), and `yuv422_yuy2`/`yuyv` (their Y bytes). The image must be the
//! configured camera's size: vservo's lens model is of that image.

use crate::msg::Image;

/// An image not taken.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImageRefused {
    /// Of another size than `[camera]`'s.
    #[error("is {width}×{height}, not the configured camera's {expected_width}×{expected_height}")]
    Size {
        /// Its columns.
        width: u32,
        /// Its rows.
        height: u32,
        /// `camera.width_px`.
        expected_width: u32,
        /// `camera.height_px`.
        expected_height: u32,
    },
    /// An encoding this driver does not convert.
    #[error("has the encoding {0:?} (taken: mono8, mono16, 8UC1, rgb8, bgr8, rgba8, bgra8, yuv422_yuy2)")]
    Encoding(String),
    /// Its `step` or `data` do not hold its rows.
    #[error("has step {step} and {bytes} bytes: too few for {height} rows of {width} pixels")]
    Short {
        /// Its columns.
        width: u32,
        /// Its rows.
        height: u32,
        /// Its bytes per row.
        step: u32,
        /// Its data's length.
        bytes: usize,
    },
}

impl ImageRefused {
    /// The kind of refusal, for a log that says each kind once.
    pub fn kind(&self) -> &'static str {
        match self {
            ImageRefused::Size { .. } => "image of another size",
            ImageRefused::Encoding(_) => "image of another encoding",
            ImageRefused::Short { .. } => "short image",
        }
    }
}

/// How a pixel's gray level is made from its bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layout {
    /// One byte: the gray level.
    Gray8,
    /// Two bytes: the gray level's high byte (the first if big-endian).
    Gray16 { big_endian: bool },
    /// Red, green, blue at these offsets in a pixel of `bytes` bytes.
    Colour { bytes: usize, r: usize, g: usize, b: usize },
    /// Y, U, Y, V: two pixels in four bytes.
    Yuyv,
}

impl Layout {
    fn of(image: &Image) -> Result<Self, ImageRefused> {
        Ok(match image.encoding.as_str() {
            "mono8" | "8UC1" => Layout::Gray8,
            "mono16" | "16UC1" => Layout::Gray16 { big_endian: image.is_bigendian != 0 },
            "rgb8" => Layout::Colour { bytes: 3, r: 0, g: 1, b: 2 },
            "bgr8" => Layout::Colour { bytes: 3, r: 2, g: 1, b: 0 },
            "rgba8" => Layout::Colour { bytes: 4, r: 0, g: 1, b: 2 },
            "bgra8" => Layout::Colour { bytes: 4, r: 2, g: 1, b: 0 },
            "yuv422_yuy2" | "yuyv" => Layout::Yuyv,
            other => return Err(ImageRefused::Encoding(other.to_string())),
        })
    }

    /// Bytes a row of `width` pixels takes.
    fn row_bytes(self, width: usize) -> usize {
        match self {
            Layout::Gray8 => width,
            Layout::Gray16 { .. } | Layout::Yuyv => 2 * width,
            Layout::Colour { bytes, .. } => bytes * width,
        }
    }
}

/// Writes `image` as 8-bit gray into `gray` (`width × height` bytes, rows packed), if it is of that size and
/// of an encoding taken.
pub fn to_gray8(image: &Image, width: u32, height: u32, gray: &mut [u8]) -> Result<(), ImageRefused> {
    if (image.width, image.height) != (width, height) {
        return Err(ImageRefused::Size {
            width: image.width,
            height: image.height,
            expected_width: width,
            expected_height: height,
        });
    }
    let layout = Layout::of(image)?;
    let (w, h, step) = (width as usize, height as usize, image.step as usize);
    let row_bytes = layout.row_bytes(w);
    let needed = if h == 0 { 0 } else { (h - 1) * step + row_bytes };
    if step < row_bytes || image.data.len() < needed {
        return Err(ImageRefused::Short { width, height, step: image.step, bytes: image.data.len() });
    }
    for (row, out) in gray.chunks_exact_mut(w).take(h).enumerate() {
        let source = &image.data[row * step..row * step + row_bytes];
        convert_row(layout, source, out);
    }
    Ok(())
}

fn convert_row(layout: Layout, source: &[u8], out: &mut [u8]) {
    match layout {
        Layout::Gray8 => out.copy_from_slice(source),
        Layout::Gray16 { big_endian } => {
            let high = usize::from(!big_endian);
            for (o, pixel) in out.iter_mut().zip(source.chunks_exact(2)) {
                *o = pixel[high];
            }
        }
        Layout::Colour { bytes, r, g, b } => {
            for (o, pixel) in out.iter_mut().zip(source.chunks_exact(bytes)) {
                *o = luma(pixel[r], pixel[g], pixel[b]);
            }
        }
        Layout::Yuyv => {
            for (o, pair) in out.iter_mut().zip(source.iter().step_by(2)) {
                *o = *pair;
            }
        }
    }
}

/// BT.601 luma in 14-bit fixed point, rounded: OpenCV's `COLOR_RGB2GRAY` (0.299 R + 0.587 G + 0.114 B).
fn luma(r: u8, g: u8, b: u8) -> u8 {
    const R: u32 = 4899; // 0.299 · 2¹⁴
    const G: u32 = 9617; // 0.587 · 2¹⁴
    const B: u32 = 1868; // 0.114 · 2¹⁴
    ((R * u32::from(r) + G * u32::from(g) + B * u32::from(b) + (1 << 13)) >> 14) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(encoding: &str, width: u32, height: u32, step: u32, data: Vec<u8>) -> Image {
        Image { height, width, encoding: encoding.into(), step, data, ..Image::default() }
    }

    #[test]
    fn each_encoding_as_gray() {
        let mut gray = [0u8; 4];
        // 2×2, with a padded step
        let mono = image("mono8", 2, 2, 3, vec![1, 2, 99, 3, 4]);
        to_gray8(&mono, 2, 2, &mut gray).expect("mono8");
        assert_eq!(gray, [1, 2, 3, 4]);
        let mono16_le = image("mono16", 2, 2, 4, vec![0xff, 10, 0, 20, 0, 30, 0xff, 40]);
        to_gray8(&mono16_le, 2, 2, &mut gray).expect("mono16");
        assert_eq!(gray, [10, 20, 30, 40]);
        let mut mono16_be = image("mono16", 2, 2, 4, vec![10, 0xff, 20, 0, 30, 0, 40, 0xff]);
        mono16_be.is_bigendian = 1;
        to_gray8(&mono16_be, 2, 2, &mut gray).expect("mono16 big-endian");
        assert_eq!(gray, [10, 20, 30, 40]);
        let rgb = image("rgb8", 2, 2, 6, vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 200, 200, 200]);
        to_gray8(&rgb, 2, 2, &mut gray).expect("rgb8");
        // OpenCV: cv2.cvtColor(np.array([[[255,0,0],[0,255,0]],[[0,0,255],[200,200,200]]], np.uint8),
        //                     cv2.COLOR_RGB2GRAY) = [[76, 150], [29, 200]]
        assert_eq!(gray, [76, 150, 29, 200]);
        let bgr = image("bgr8", 2, 2, 6, vec![0, 0, 255, 0, 255, 0, 255, 0, 0, 200, 200, 200]);
        to_gray8(&bgr, 2, 2, &mut gray).expect("bgr8");
        assert_eq!(gray, [76, 150, 29, 200]);
        let yuyv = image("yuv422_yuy2", 2, 2, 4, vec![5, 128, 6, 128, 7, 128, 8, 128]);
        to_gray8(&yuyv, 2, 2, &mut gray).expect("yuyv");
        assert_eq!(gray, [5, 6, 7, 8]);
    }

    #[test]
    fn refusals_say_why() {
        let mut gray = [0u8; 4];
        let small = image("mono8", 1, 2, 1, vec![0; 2]);
        assert!(matches!(to_gray8(&small, 2, 2, &mut gray), Err(ImageRefused::Size { width: 1, .. })));
        let bayer = image("bayer_rggb8", 2, 2, 2, vec![0; 4]);
        assert_eq!(to_gray8(&bayer, 2, 2, &mut gray), Err(ImageRefused::Encoding("bayer_rggb8".into())));
        let short = image("mono8", 2, 2, 2, vec![0; 3]);
        assert!(matches!(to_gray8(&short, 2, 2, &mut gray), Err(ImageRefused::Short { .. })));
        let narrow_step = image("rgb8", 2, 2, 4, vec![0; 12]);
        assert!(matches!(to_gray8(&narrow_step, 2, 2, &mut gray), Err(ImageRefused::Short { .. })));
    }
}
