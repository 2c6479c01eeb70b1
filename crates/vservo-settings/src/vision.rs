//! The vision stages' settings: how the simulated camera renders the scene, how the extractor finds the marks.

/// How the dark marks are separated from the board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Threshold {
    /// Otsu's threshold of the whole image's histogram.
    Otsu,
    /// A set gray level: pixels below it are dark.
    Fixed(u8),
}

/// The extractor's tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractorSettings {
    /// The threshold rule.
    pub threshold: Threshold,
    /// Smallest blob taken for a mark (pixels); smaller ones are noise.
    pub min_area_px: u32,
    /// Largest blob taken for a mark; larger ones are background or clutter.
    pub max_area_px: u32,
    /// Largest ratio of the long to the short axis of a mark's moment ellipse (a disc seen at 75° is ~3.9).
    pub max_elongation: f64,
    /// Smallest area over the area of its moment ellipse (1 for an ellipse; two discs run together ~0.89).
    pub min_ellipse_fill: f64,
    /// How far (px) a mark may move from its predicted position between frames and still be found there.
    pub gate_px: f64,
}

impl Default for ExtractorSettings {
    fn default() -> Self {
        Self {
            threshold: Threshold::Otsu,
            min_area_px: 12,
            max_area_px: 6000,
            max_elongation: 4.0,
            min_ellipse_fill: 0.93,
            gate_px: 40.0,
        }
    }
}

/// How the scene looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Gray of whatever is not the board (0–255).
    pub background_gray: f64,
    /// Gray of the white board.
    pub board_gray: f64,
    /// Gray of the black marks.
    pub mark_gray: f64,
    /// Standard deviation of the pixel noise (gray levels); 0 for none.
    pub noise_sigma_gray: f64,
    /// Seed of the noise; each frame mixes in its number.
    pub noise_seed: u64,
    /// Brightness change across the image, left to right and top to bottom, as a fraction (0.1: the right
    /// edge is 10 % brighter than the left).
    pub lighting_gradient: [f64; 2],
    /// Samples per axis in a pixel an edge may cross (8: 64 samples, coverage to 1/64).
    pub supersampling: u32,
    /// How long the shutter is open (s), ending at the capture instant: the board's motion relative to the
    /// camera over it blurs the image, as a real camera's does; 0 for an instant (no motion blur).
    pub exposure_s: f64,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            background_gray: 110.0,
            board_gray: 230.0,
            mark_gray: 20.0,
            noise_sigma_gray: 0.0,
            noise_seed: 1,
            lighting_gradient: [0.0, 0.0],
            supersampling: 8,
            exposure_s: 0.0,
        }
    }
}
