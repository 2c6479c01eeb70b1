//! Closed-loop analysis: eigenvalues with and without the image pipeline's delay, and the Corollary 1
//! stability margins.
//!
//! The loop is ξ̄(k+1) = ξ̄(k) + B u(k) with u(k) = −K_ξ ξ̄(k − d) − Σⱼ K_j u(k − j). Writing y = K_ξ ξ̄
//! (six numbers) closes it on y and the command history:
//! y(k+1) = y(k) + K_ξ B u(k), u(k) = −y(k − d) − Σ K_j u(k − j). By Sylvester's determinant identity its
//! eigenvalues are those of the full 8-feature loop less the 2N − 6 uncontrollable unit ones (and the
//! zeros of the pure delay); for d = 0 and the paper's law they are the six non-unit eigenvalues of
//! I − BK of Corollary 1.

use nalgebra::{Complex, DMatrix, Matrix6, Rotation3, SMatrix, Schur, Translation3, Vector3};
use vservo_scene::{Board, CameraIntrinsics, FEATURES, IsometryMatrix3};

use crate::image_jacobian::interaction_matrix;
use crate::{FeatureGain, InteractionMatrix};

/// The eigenvalues of a square matrix, or `None` when the QR iteration does not converge.
///
/// `nalgebra`'s own `complex_eigenvalues` iterates without limit and does not balance; on the loop matrices
/// here it failed to converge at isolated points of the margin search. So, as LAPACK does, the matrix is
/// balanced first (a diagonal similarity: same eigenvalues, better accuracy), the iteration is bounded, and
/// a failure is retried on the unbalanced matrix and its transpose, which take other paths.
pub fn eigenvalues(m: &DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    let attempt = |m: DMatrix<f64>| {
        Schur::try_new(m, f64::EPSILON, 10_000).map(|s| s.complex_eigenvalues().iter().copied().collect())
    };
    attempt(balanced(m)).or_else(|| attempt(m.clone())).or_else(|| attempt(m.transpose()))
}

/// A diagonal similarity D⁻¹ M D that evens out row and column norms (Parlett & Reinsch), with powers of
/// two so that it adds no rounding.
fn balanced(m: &DMatrix<f64>) -> DMatrix<f64> {
    let mut b = m.clone();
    let n = b.nrows();
    for _ in 0..20 {
        let mut changed = false;
        for i in 0..n {
            let column: f64 = (0..n).filter(|&j| j != i).map(|j| b[(j, i)].abs()).sum();
            let row: f64 = (0..n).filter(|&j| j != i).map(|j| b[(i, j)].abs()).sum();
            if column == 0.0 || row == 0.0 {
                continue;
            }
            let mut f = 1.0;
            while column * f < row / (2.0 * f) {
                f *= 2.0;
            }
            while column * f > 2.0 * row / f {
                f /= 2.0;
            }
            if f != 1.0 {
                changed = true;
                for j in 0..n {
                    b[(i, j)] /= f;
                    b[(j, i)] *= f;
                }
            }
        }
        if !changed {
            break;
        }
    }
    b
}

/// The spectral radius from the growth of ‖M^(2^j)‖ under repeated squaring, for when no eigenvalue
/// computation converges: ρ = lim ‖M^k‖^(1/k).
fn spectral_radius_by_squaring(m: &DMatrix<f64>) -> f64 {
    let mut power = m.clone();
    let mut log_scale = 0.0;
    let mut exponent = 1.0;
    for _ in 0..40 {
        let norm = power.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return if norm == 0.0 { 0.0 } else { f64::INFINITY };
        }
        power /= norm;
        log_scale += norm.ln();
        // (M^e)^2 = M^(2e): the scale doubles with the exponent
        power = &power * &power;
        log_scale *= 2.0;
        exponent *= 2.0;
    }
    let norm = power.norm();
    if norm == 0.0 { 0.0 } else { ((log_scale + norm.ln()) / exponent).exp() }
}

/// The largest eigenvalue magnitude.
pub fn spectral_radius(m: &DMatrix<f64>) -> f64 {
    match eigenvalues(m) {
        Some(e) => e.iter().map(|l| l.norm()).fold(0.0, f64::max),
        None => spectral_radius_by_squaring(m),
    }
}

/// The eigenvalues of I − BK (8 × 8): 2N − 6 of them are 1, the rest are the controlled modes.
pub fn nominal_eigenvalues(b: &InteractionMatrix, k: &FeatureGain) -> Vec<Complex<f64>> {
    let closed = SMatrix::<f64, FEATURES, FEATURES>::identity() - b * k;
    eigenvalues(&DMatrix::from_column_slice(FEATURES, FEATURES, closed.as_slice())).unwrap_or_default()
}

/// The loop matrix on [y(k), …, y(k − d), u(k − 1), …, u(k − d)] (the command history only when some
/// K_j is used). `b` is the true plant, which may differ from the design's.
pub fn loop_matrix(
    b: &InteractionMatrix,
    feature_gain: &FeatureGain,
    past_input_gains: &[Matrix6<f64>],
    delay_frames: usize,
) -> DMatrix<f64> {
    let d = delay_frames;
    let uses_history = past_input_gains.iter().take(d).any(|k| k.amax() > 0.0);
    let y_blocks = d + 1;
    let u_blocks = if uses_history { d } else { 0 };
    let n = 6 * (y_blocks + u_blocks);
    let g = feature_gain * b;
    let identity = Matrix6::<f64>::identity();
    let mut m = DMatrix::<f64>::zeros(n, n);
    let mut add = |row: usize, column: usize, block: &Matrix6<f64>| {
        let mut view = m.view_mut((6 * row, 6 * column), (6, 6));
        view += block;
    };
    // y(k+1) = y(k) − G y(k−d) − Σ G K_j u(k−j)
    add(0, 0, &identity);
    add(0, d, &-g);
    for (j, k_j) in past_input_gains.iter().enumerate().take(u_blocks) {
        add(0, y_blocks + j, &-(g * k_j));
    }
    // the y history shifts
    for i in 1..y_blocks {
        add(i, i - 1, &identity);
    }
    if uses_history {
        // the new u(k−1) is u(k) = −y(k−d) − Σ K_j u(k−j)
        add(y_blocks, d, &-identity);
        for (j, k_j) in past_input_gains.iter().enumerate().take(u_blocks) {
            add(y_blocks, y_blocks + j, &-k_j);
        }
        for i in 1..u_blocks {
            add(y_blocks + i, y_blocks + i - 1, &identity);
        }
    }
    m
}

/// The eigenvalues of [`loop_matrix`].
pub fn loop_eigenvalues(
    b: &InteractionMatrix,
    feature_gain: &FeatureGain,
    past_input_gains: &[Matrix6<f64>],
    delay_frames: usize,
) -> Vec<Complex<f64>> {
    eigenvalues(&loop_matrix(b, feature_gain, past_input_gains, delay_frames)).unwrap_or_default()
}

/// Eigenvalue magnitudes, largest first.
pub fn magnitudes(eigenvalues: &[Complex<f64>]) -> Vec<f64> {
    let mut m: Vec<f64> = eigenvalues.iter().map(|l| l.norm()).collect();
    m.sort_by(|a, b| b.total_cmp(a));
    m
}

/// What ended a margin search.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// An eigenvalue left the unit circle.
    Instability,
    /// A mark went behind the camera (no image, no Jacobian).
    MarkBehindCamera,
    /// The search range ended with the loop still stable: the margin is at least this.
    SearchLimit,
}

impl Bound {
    /// A short name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Bound::Instability => "instability",
            Bound::MarkBehindCamera => "mark behind camera",
            Bound::SearchLimit => "search limit",
        }
    }
}

/// The largest displacement, in both directions along one axis, for which the loop stays stable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margin {
    /// m for translations, rad for rotations.
    pub magnitude: f64,
    /// What the search ran into first.
    pub bounded_by: Bound,
}

/// Corollary 1 margins along and about the camera's x, y, z axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StabilityMargins {
    /// Object translation along camera x, y, z from the desired pose (m).
    pub translation: [Margin; 3],
    /// Object rotation about camera x, y, z through the camera centre (rad) — the same as turning the
    /// camera the other way about its own axes.
    pub rotation: [Margin; 3],
}

/// The loop being tested: a fixed gain and the plant's geometry.
#[derive(Debug, Clone, Copy)]
pub struct LoopUnderTest<'a> {
    /// The camera.
    pub camera: &'a CameraIntrinsics,
    /// The object.
    pub board: &'a Board,
    /// The object at the desired pose.
    pub camera_from_board_desired: &'a IsometryMatrix3<f64>,
    /// The vision period (s).
    pub period_s: f64,
    /// K_ξ.
    pub feature_gain: &'a FeatureGain,
    /// K_j.
    pub past_input_gains: &'a [Matrix6<f64>],
    /// The pipeline delay (frames).
    pub delay_frames: usize,
}

impl LoopUnderTest<'_> {
    /// Stable with the object at `camera_from_board`, or what went wrong.
    pub fn check(&self, camera_from_board: &IsometryMatrix3<f64>) -> Result<(), Bound> {
        let (features, depths) = self
            .camera
            .project_marks_with_depths(self.board, camera_from_board)
            .map_err(|_| Bound::MarkBehindCamera)?;
        let b = interaction_matrix(self.camera, &features, &depths, self.period_s);
        let radius =
            spectral_radius(&loop_matrix(&b, self.feature_gain, self.past_input_gains, self.delay_frames));
        if radius < 1.0 { Ok(()) } else { Err(Bound::Instability) }
    }

    /// The Corollary 1 margins: for each axis, the largest displacement s such that every displacement up
    /// to s, either way, keeps the loop stable. Translations are searched to 10 m, rotations to 180°.
    pub fn stability_margins(&self) -> StabilityMargins {
        StabilityMargins {
            translation: std::array::from_fn(|axis| self.translation_margin(axis)),
            rotation: std::array::from_fn(|axis| self.rotation_margin(axis)),
        }
    }

    /// The object translated by `s` metres along camera axis `axis` (0, 1, 2 for x, y, z).
    pub fn translated(&self, axis: usize, s: f64) -> IsometryMatrix3<f64> {
        Translation3::from(Vector3::ith(axis, s)) * self.camera_from_board_desired
    }

    /// The object turned by `s` radians about camera axis `axis` through the camera centre.
    pub fn rotated(&self, axis: usize, s: f64) -> IsometryMatrix3<f64> {
        Rotation3::from_scaled_axis(Vector3::ith(axis, s)) * self.camera_from_board_desired
    }

    /// The translation margin along one camera axis (m), searched to 10 m.
    pub fn translation_margin(&self, axis: usize) -> Margin {
        self.margin(10.0, 2e-3, |s| self.translated(axis, s))
    }

    /// The rotation margin about one camera axis (rad), searched to 180°.
    pub fn rotation_margin(&self, axis: usize) -> Margin {
        self.margin(std::f64::consts::PI, 2e-3, |s| self.rotated(axis, s))
    }

    fn margin(&self, limit: f64, first_step: f64, displaced: impl Fn(f64) -> IsometryMatrix3<f64>) -> Margin {
        let both_ways = |s: f64| self.check(&displaced(s)).and_then(|()| self.check(&displaced(-s)));
        if let Err(bound) = both_ways(0.0) {
            return Margin { magnitude: 0.0, bounded_by: bound };
        }
        // march outwards (steps of 4 % once past the first few millimetres or milliradians), then bisect
        let mut stable = 0.0_f64;
        loop {
            let next = (stable + first_step.max(0.04 * stable)).min(limit);
            match both_ways(next) {
                Ok(()) if next >= limit => {
                    return Margin { magnitude: limit, bounded_by: Bound::SearchLimit };
                }
                Ok(()) => stable = next,
                Err(mut bound) => {
                    let mut failing = next;
                    for _ in 0..32 {
                        let middle = 0.5 * (stable + failing);
                        match both_ways(middle) {
                            Ok(()) => stable = middle,
                            Err(b) => {
                                failing = middle;
                                bound = b;
                            }
                        }
                    }
                    return Margin { magnitude: stable, bounded_by: bound };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squaring_estimate_agrees_with_the_eigenvalues() {
        let matrices = [
            DMatrix::from_row_slice(2, 2, &[0.5, 10.0, 0.0, 0.9]),
            DMatrix::from_row_slice(2, 2, &[0.0, -1.02, 1.0, 0.0]),
            DMatrix::from_row_slice(3, 3, &[0.2, 0.3, 0.1, -0.4, 0.9, 0.2, 0.0, 0.1, -0.7]),
        ];
        for m in &matrices {
            let exact =
                eigenvalues(m).expect("small matrices converge").iter().map(|l| l.norm()).fold(0.0, f64::max);
            let estimate = spectral_radius_by_squaring(m);
            assert!((exact - estimate).abs() < 1e-6 * exact, "{exact} vs {estimate}");
        }
        assert_eq!(spectral_radius_by_squaring(&DMatrix::zeros(3, 3)), 0.0);
    }

    #[test]
    fn badly_scaled_matrices_get_accurate_eigenvalues() {
        // eigenvalues 0 and 3 ± √2; unbalanced, the QR iteration puts 3e-5 where 0 is
        let m = DMatrix::from_row_slice(3, 3, &[1.0, 1e6, 0.0, 1e-6, 2.0, 3e5, 0.0, 1e-5, 3.0]);
        let mut found = magnitudes(&eigenvalues(&m).expect("converges"));
        found.sort_by(f64::total_cmp);
        let expected = [0.0, 3.0 - 2f64.sqrt(), 3.0 + 2f64.sqrt()];
        for (x, y) in found.iter().zip(expected) {
            assert!((x - y).abs() < 1e-9, "{found:?} vs {expected:?}");
        }
    }
}
