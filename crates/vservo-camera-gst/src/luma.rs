//! The 8-bit gray the vision node takes, from the raw formats cameras give: the driver converts, so the
//! wire carries one format (`mono8`) whatever the camera.
//!
//! - gray (`GRAY8`): as it is;
//! - YUV, packed (`YUY2`, `YVYU`, `UYVY`, `VYUY`) or planar (`I420`, `YV12`, `NV12`, `NV21`, `Y42B`, `Y444`):
//!   the luma channel Y as the camera coded it (what a JPEG's or an MJPEG camera's decoded Y is);
//! - RGB in any byte order, with or without a fourth byte (`RGB`, `BGR`, `RGBx`, `BGRx`, `xRGB`, `xBGR`,
//!   `RGBA`, `BGRA`, `ARGB`, `ABGR`): the luma Y = 0.299 R + 0.587 G + 0.114 B (ITU-R BT.601), rounded, as
//!   `vservoctl tags` reads a colour picture.
//!
//! Encoded frames (an MJPEG camera's `image/jpeg`) are decoded in the pipeline by GStreamer's `jpegdec`, which
//! gives I420 (the caps check's error says so).

/// Where a pixel's luma is in a row of the frame's first plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Luma {
    /// One byte a pixel, the luma itself (gray, or a planar YUV format's Y plane).
    Bytes,
    /// Packed YUV 4:2:2: two pixels in four bytes, their Y at `first` and `first + 2`.
    Packed422 {
        /// The first pixel's Y byte (0 for YUY2 and YVYU, 1 for UYVY and VYUY).
        first: usize,
    },
    /// RGB: `bytes` a pixel, red, green and blue at these offsets.
    Rgb {
        /// Bytes a pixel (3 or 4).
        bytes: usize,
        /// Offset of red.
        r: usize,
        /// Offset of green.
        g: usize,
        /// Offset of blue.
        b: usize,
    },
}

/// The raw formats taken, by GStreamer's name.
pub const FORMATS: [&str; 21] = [
    "GRAY8", "I420", "YV12", "NV12", "NV21", "Y42B", "Y444", "YUY2", "YVYU", "UYVY", "VYUY", "RGB", "BGR",
    "RGBx", "BGRx", "xRGB", "xBGR", "RGBA", "BGRA", "ARGB", "ABGR",
];

/// Where the luma is in frames of GStreamer's raw format `format`; `None` for a format not taken.
pub fn of_format(format: &str) -> Option<Luma> {
    let rgb = |bytes, r, g, b| Some(Luma::Rgb { bytes, r, g, b });
    match format {
        "GRAY8" | "I420" | "YV12" | "NV12" | "NV21" | "Y42B" | "Y444" => Some(Luma::Bytes),
        "YUY2" | "YVYU" => Some(Luma::Packed422 { first: 0 }),
        "UYVY" | "VYUY" => Some(Luma::Packed422 { first: 1 }),
        "RGB" => rgb(3, 0, 1, 2),
        "BGR" => rgb(3, 2, 1, 0),
        "RGBx" | "RGBA" => rgb(4, 0, 1, 2),
        "BGRx" | "BGRA" => rgb(4, 2, 1, 0),
        "xRGB" | "ARGB" => rgb(4, 1, 2, 3),
        "xBGR" | "ABGR" => rgb(4, 3, 2, 1),
        _ => None,
    }
}

impl Luma {
    /// The bytes a row of `width` pixels takes in the first plane.
    pub fn row_bytes(self, width: usize) -> usize {
        match self {
            Luma::Bytes => width,
            Luma::Packed422 { .. } => 4 * width.div_ceil(2),
            Luma::Rgb { bytes, .. } => bytes * width,
        }
    }

    /// Writes the luma of `row` (at least [`Luma::row_bytes`] long) into `out`, one byte a pixel.
    pub fn convert_row(self, row: &[u8], out: &mut [u8]) {
        match self {
            Luma::Bytes => out.copy_from_slice(&row[..out.len()]),
            Luma::Packed422 { first } => {
                for (pixel, y) in out.iter_mut().enumerate() {
                    *y = row[2 * pixel + first];
                }
            }
            Luma::Rgb { bytes, r, g, b } => {
                for (pixel, y) in row.chunks_exact(bytes).zip(out.iter_mut()) {
                    *y = bt601(pixel[r], pixel[g], pixel[b]);
                }
            }
        }
    }
}

/// Y = 0.299 R + 0.587 G + 0.114 B, rounded half up, in integers.
fn bt601(r: u8, g: u8, b: u8) -> u8 {
    ((299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b) + 500) / 1000) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_format_taken_has_a_layout_and_others_none() {
        for format in FORMATS {
            assert!(of_format(format).is_some(), "{format}");
        }
        for format in ["GRAY16_LE", "P010_10LE", "v210", "RGB16", ""] {
            assert_eq!(of_format(format), None, "{format}");
        }
    }

    #[test]
    fn the_luma_of_rgb_is_bt601_in_every_byte_order() {
        // (R, G, B) and the luma by the formula in floating point
        let colours =
            [(255u8, 0u8, 0u8), (0, 255, 0), (0, 0, 255), (255, 255, 255), (12, 200, 77), (0, 0, 0)];
        for (r, g, b) in colours {
            let expected = (0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b)).round() as u8;
            let orders: [(&str, Vec<u8>); 6] = [
                ("RGB", vec![r, g, b]),
                ("BGR", vec![b, g, r]),
                ("RGBx", vec![r, g, b, 9]),
                ("BGRA", vec![b, g, r, 9]),
                ("xRGB", vec![9, r, g, b]),
                ("ABGR", vec![9, b, g, r]),
            ];
            for (format, pixel) in orders {
                let luma = of_format(format).expect("taken");
                let row: Vec<u8> = pixel.iter().chain(&pixel).copied().collect();
                let mut out = [0u8; 2];
                luma.convert_row(&row, &mut out);
                assert_eq!(out, [expected; 2], "{format} of {r} {g} {b}");
            }
        }
    }

    #[test]
    fn packed_yuv_gives_its_y_bytes_and_an_odd_width_its_last_pixel() {
        // Y0 U Y1 V Y2 U' (Y3) V': three pixels in two pairs
        let yuy2 = [10u8, 128, 20, 129, 30, 130, 0, 131];
        let mut out = [0u8; 3];
        of_format("YUY2").expect("taken").convert_row(&yuy2, &mut out);
        assert_eq!(out, [10, 20, 30]);
        let uyvy = [128u8, 10, 129, 20, 130, 30, 131, 0];
        of_format("UYVY").expect("taken").convert_row(&uyvy, &mut out);
        assert_eq!(out, [10, 20, 30]);
        assert_eq!(of_format("YUY2").expect("taken").row_bytes(3), 8);
    }
}
