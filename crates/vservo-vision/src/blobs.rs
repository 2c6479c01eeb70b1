//! Connected components of the dark pixels, by runs and union-find, with per-component statistics.
//!
//! Written here rather than taken from `imageproc::region_labelling::connected_components` because the
//! vision loop must not allocate per frame (that function returns a new label image each call) and needs,
//! in the same pass, each component's area, moments, bounding box and whether it touches the image border,
//! which the label image alone does not give. The tests check it against `imageproc`.

use image::GrayImage;

/// Statistics of one connected component of pixels darker than the threshold (8-connected).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blob {
    /// Pixel count.
    pub area: u32,
    /// Mean of the pixel centres (u + ½, v + ½).
    pub centroid: (f64, f64),
    /// Second central moments of the pixel centres: (μ_uu, μ_vv, μ_uv) / area.
    pub covariance: (f64, f64, f64),
    /// Bounding box: lowest u, lowest v, highest u, highest v (inclusive).
    pub bbox: (u32, u32, u32, u32),
    /// Whether a pixel of the blob lies on the image's outermost rows or columns.
    pub touches_border: bool,
}

impl Blob {
    /// The ratio of the longer to the shorter axis of the moment ellipse (1 for a disc).
    pub fn elongation(&self) -> f64 {
        let (a, b, c) = self.covariance;
        let mean = 0.5 * (a + b);
        let root = (0.25 * (a - b).powi(2) + c * c).sqrt();
        let (major, minor) = (mean + root, (mean - root).max(1e-12));
        (major / minor).sqrt()
    }

    /// Area over the area of the ellipse with the same second moments, 4π√det Σ: 1 for a filled
    /// ellipse, less for shapes with lobes (two marks run together).
    pub fn ellipse_fill(&self) -> f64 {
        let (a, b, c) = self.covariance;
        let det = (a * b - c * c).max(1e-12);
        // pixel quantization adds 1/12 px² to each axis's variance
        let det_continuous = ((a - 1.0 / 12.0) * (b - 1.0 / 12.0) - c * c).max(det * 0.25);
        f64::from(self.area) / (4.0 * std::f64::consts::PI * det_continuous.sqrt())
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct Run {
    row: u32,
    start: u32,
    /// Exclusive.
    end: u32,
}

#[derive(Debug, Clone, Copy, Default)]
struct Accumulator {
    area: u64,
    sum_u: f64,
    sum_v: f64,
    sum_uu: f64,
    sum_vv: f64,
    sum_uv: f64,
    u_min: u32,
    v_min: u32,
    u_max: u32,
    v_max: u32,
    border: bool,
}

/// Finds the components; buffers are kept between frames.
#[derive(Debug, Clone, Default)]
pub struct BlobFinder {
    runs: Vec<Run>,
    parent: Vec<u32>,
    slot: Vec<u32>,
    accumulators: Vec<Accumulator>,
    blobs: Vec<Blob>,
}

impl BlobFinder {
    /// A finder with room for an image of `width` × `height` (no allocation on later calls of that size).
    pub fn with_capacity(width: u32, height: u32) -> Self {
        let most_runs = (width as usize).div_ceil(2) * height as usize + 1;
        Self {
            runs: Vec::with_capacity(most_runs),
            parent: Vec::with_capacity(most_runs),
            slot: Vec::with_capacity(most_runs),
            accumulators: Vec::with_capacity(most_runs),
            blobs: Vec::with_capacity(most_runs),
        }
    }

    fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grandparent = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grandparent;
            i = grandparent;
        }
        i
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (low, high) = if ra < rb { (ra, rb) } else { (rb, ra) };
            self.parent[high as usize] = low;
        }
    }

    /// The 8-connected components of pixels with gray < `threshold`, in order of their first pixel
    /// (top to bottom, left to right).
    pub fn find_blobs(&mut self, image: &GrayImage, threshold: u8) -> &[Blob] {
        let (width, height) = image.dimensions();
        self.runs.clear();
        self.parent.clear();
        let pixels = image.as_raw();
        let mut previous_row = 0..0;
        for v in 0..height {
            let row = &pixels[(v * width) as usize..((v + 1) * width) as usize];
            let row_start = self.runs.len();
            let mut u = 0;
            while u < width {
                if row[u as usize] < threshold {
                    let start = u;
                    while u < width && row[u as usize] < threshold {
                        u += 1;
                    }
                    let index = self.runs.len() as u32;
                    self.runs.push(Run { row: v, start, end: u });
                    self.parent.push(index);
                } else {
                    u += 1;
                }
            }
            // join with the previous row's runs that touch, diagonals included
            let current = row_start..self.runs.len();
            let mut p = previous_row.start;
            for c in current.clone() {
                let run = self.runs[c];
                while p < previous_row.end && self.runs[p].end < run.start {
                    p += 1;
                }
                let mut q = p;
                while q < previous_row.end && self.runs[q].start <= run.end {
                    self.union(q as u32, c as u32);
                    q += 1;
                }
            }
            previous_row = current;
        }
        // gather each component's statistics at its root
        self.slot.clear();
        self.slot.resize(self.runs.len(), u32::MAX);
        self.accumulators.clear();
        for i in 0..self.runs.len() {
            let root = self.find(i as u32) as usize;
            if self.slot[root] == u32::MAX {
                self.slot[root] = self.accumulators.len() as u32;
                self.accumulators.push(Accumulator {
                    u_min: u32::MAX,
                    v_min: u32::MAX,
                    ..Default::default()
                });
            }
            let run = self.runs[i];
            let acc = &mut self.accumulators[self.slot[root] as usize];
            let n = u64::from(run.end - run.start);
            let nf = n as f64;
            // pixel centres k + ½ for k = start … end − 1
            let sum_k = |m: f64| m * (m - 1.0) / 2.0;
            let sum_k2 = |m: f64| (m - 1.0) * m * (2.0 * m - 1.0) / 6.0;
            let (s, e) = (f64::from(run.start), f64::from(run.end));
            let sum_centre = sum_k(e) - sum_k(s) + 0.5 * nf;
            let sum_centre_sq = sum_k2(e) - sum_k2(s) + (sum_k(e) - sum_k(s)) + 0.25 * nf;
            let y = f64::from(run.row) + 0.5;
            acc.area += n;
            acc.sum_u += sum_centre;
            acc.sum_uu += sum_centre_sq;
            acc.sum_v += nf * y;
            acc.sum_vv += nf * y * y;
            acc.sum_uv += y * sum_centre;
            acc.u_min = acc.u_min.min(run.start);
            acc.u_max = acc.u_max.max(run.end - 1);
            acc.v_min = acc.v_min.min(run.row);
            acc.v_max = acc.v_max.max(run.row);
            acc.border |= run.start == 0 || run.end == width || run.row == 0 || run.row + 1 == height;
        }
        self.blobs.clear();
        for acc in &self.accumulators {
            let n = acc.area as f64;
            let (mu, mv) = (acc.sum_u / n, acc.sum_v / n);
            self.blobs.push(Blob {
                area: acc.area as u32,
                centroid: (mu, mv),
                covariance: (acc.sum_uu / n - mu * mu, acc.sum_vv / n - mv * mv, acc.sum_uv / n - mu * mv),
                bbox: (acc.u_min, acc.v_min, acc.u_max, acc.v_max),
                touches_border: acc.border,
            });
        }
        &self.blobs
    }
}
