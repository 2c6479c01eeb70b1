//! The LQ gains: the paper's, on the controllable/uncontrollable mode decomposition (eq. 19–41), and the
//! delay-aware one, LQ on the state augmented with the commands still in the image pipeline.

use nalgebra::{DMatrix, Matrix2, Matrix6, SMatrix, Vector6};
use vservo_scene::FEATURES;

use crate::dare::{self, DareError};
use crate::weights::StateWeight;
use crate::{FeatureGain, InteractionMatrix, MAX_DELAY_FRAMES};

/// Why a gain could not be designed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LqError {
    /// B loses rank: the features are degenerate (eq. 6), some camera motion does not move them.
    #[error("the interaction matrix B has rank < 6 (singular values {0:?}): degenerate features")]
    Degenerate([f64; 6]),
    /// The Riccati equation failed.
    #[error("Riccati equation: {0}")]
    Riccati(#[from] DareError),
    /// A pipeline delay longer than supported.
    #[error("a pipeline delay of {0} frames is more than the {MAX_DELAY_FRAMES} supported")]
    DelayTooLong(usize),
}

/// The decomposition of eq. (19)–(21) with S from the SVD (eq. 40–41): S B = [B_c; 0].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeDecomposition {
    /// Singular values of B, largest first (px per m/s or per rad/s).
    pub singular_values: Vector6<f64>,
    /// S₁ = the first six rows of S = Uᵀ: the controllable modes ξ_c = S₁ ξ̄.
    pub controllable_rows: SMatrix<f64, 6, FEATURES>,
    /// S₂ = the last 2N − 6 rows: the uncontrollable modes, which the rigid object keeps at zero.
    pub uncontrollable_rows: SMatrix<f64, { FEATURES - 6 }, FEATURES>,
    /// B_c = Σ Vᵀ, non-singular.
    pub b_c: Matrix6<f64>,
}

impl ModeDecomposition {
    /// The decomposition of B by its singular value decomposition.
    pub fn of(b: &InteractionMatrix) -> Result<Self, LqError> {
        let svd = b.svd(true, true);
        let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
            return Err(LqError::Degenerate([f64::NAN; 6]));
        };
        let sigma = svd.singular_values;
        let sigma_array = [sigma[0], sigma[1], sigma[2], sigma[3], sigma[4], sigma[5]];
        if !sigma.iter().all(|s| s.is_finite()) || sigma[5] <= 1e-9 * sigma[0] {
            return Err(LqError::Degenerate(sigma_array));
        }
        // the orthogonal complement of range(B): eigenvectors of I − UUᵀ with eigenvalue 1
        let projector = SMatrix::<f64, FEATURES, FEATURES>::identity() - u * u.transpose();
        let eigen = projector.symmetric_eigen();
        let mut order: Vec<usize> = (0..FEATURES).collect();
        order.sort_by(|&i, &j| eigen.eigenvalues[j].total_cmp(&eigen.eigenvalues[i]));
        let mut uncontrollable_rows = SMatrix::<f64, { FEATURES - 6 }, FEATURES>::zeros();
        for (row, &index) in order.iter().take(FEATURES - 6).enumerate() {
            uncontrollable_rows.set_row(row, &eigen.eigenvectors.column(index).transpose());
        }
        Ok(Self {
            singular_values: sigma,
            controllable_rows: u.transpose(),
            uncontrollable_rows,
            b_c: Matrix6::from_diagonal(&sigma) * v_t,
        })
    }

    /// The whole S, 8 × 8 orthogonal.
    pub fn s(&self) -> SMatrix<f64, FEATURES, FEATURES> {
        let mut s = SMatrix::<f64, FEATURES, FEATURES>::zeros();
        s.fixed_view_mut::<6, FEATURES>(0, 0).copy_from(&self.controllable_rows);
        s.fixed_view_mut::<{ FEATURES - 6 }, FEATURES>(6, 0).copy_from(&self.uncontrollable_rows);
        s
    }

    /// Another valid choice of S (eq. 36): blockdiag(T₁, T₂)·S with T₁, T₂ orthogonal.
    pub fn transformed(&self, t1: &Matrix6<f64>, t2: &Matrix2<f64>) -> Self {
        Self {
            singular_values: self.singular_values,
            controllable_rows: t1 * self.controllable_rows,
            uncontrollable_rows: t2 * self.uncontrollable_rows,
            b_c: t1 * self.b_c,
        }
    }

    /// Q_c, the upper-left 6 × 6 of S Q Sᵀ (eq. 29).
    pub fn controllable_weight(&self, q: &StateWeight) -> Matrix6<f64> {
        let q_c = self.controllable_rows * q.matrix() * self.controllable_rows.transpose();
        (q_c + q_c.transpose()) * 0.5
    }
}

/// The paper's gain and what it was made of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperGain {
    /// K = [K_c 0] S, 6 × 8 (m/s and rad/s per pixel).
    pub k: FeatureGain,
    /// K_c = (R + B_cᵀPB_c)⁻¹B_cᵀP (eq. 30).
    pub k_c: Matrix6<f64>,
    /// The DARE solution (eq. 31).
    pub p: Matrix6<f64>,
    /// Q_c (eq. 29).
    pub q_c: Matrix6<f64>,
}

/// The paper's LQ gain on a given decomposition, with R in SI units.
pub fn paper_gain(
    decomposition: &ModeDecomposition,
    q: &StateWeight,
    r_si: &Matrix6<f64>,
) -> Result<PaperGain, LqError> {
    let q_c = decomposition.controllable_weight(q);
    let (p, k_c) = dare::solve_identity(&decomposition.b_c, &q_c, r_si)?;
    Ok(PaperGain { k: k_c * decomposition.controllable_rows, k_c, p, q_c })
}

/// The delay-aware gain: u(k) = −K_ξ ξ̄(k − d) − Σⱼ K_j u(k − j), j = 1…d.
#[derive(Debug, Clone, PartialEq)]
pub struct DelayAwareGain {
    /// K_ξ, on the delayed feature error (m/s and rad/s per pixel).
    pub feature_gain: FeatureGain,
    /// K_j on the command sent j frames ago, j = 1…d.
    pub past_input_gains: Vec<Matrix6<f64>>,
    /// The DARE solution on the augmented state.
    pub p: DMatrix<f64>,
}

/// LQ on the delay-augmented state, solved by the general (doubling) DARE solver.
///
/// With a pipeline delay of d frames the servo sees ξ̄(k − d) when it computes u(k). The state
/// x(k) = [ξ_c(k − d); u(k − d); …; u(k − 1)] is then fully known, and
/// x(k + 1) = A x(k) + B u(k) with ξ_c(k − d + 1) = ξ_c(k − d) + B_c u(k − d). The weights are the paper's:
/// Q_c on ξ_c, R on u. For d = 0 this is the paper's gain.
pub fn delay_aware_gain(
    decomposition: &ModeDecomposition,
    q: &StateWeight,
    r_si: &Matrix6<f64>,
    delay_frames: usize,
) -> Result<DelayAwareGain, LqError> {
    if delay_frames > MAX_DELAY_FRAMES {
        return Err(LqError::DelayTooLong(delay_frames));
    }
    let d = delay_frames;
    let n = 6 * (d + 1);
    let mut a = DMatrix::<f64>::zeros(n, n);
    let mut b = DMatrix::<f64>::zeros(n, 6);
    let mut q_aug = DMatrix::<f64>::zeros(n, n);
    let identity = Matrix6::<f64>::identity();
    a.view_mut((0, 0), (6, 6)).copy_from(&identity);
    q_aug.view_mut((0, 0), (6, 6)).copy_from(&decomposition.controllable_weight(q));
    if d == 0 {
        b.view_mut((0, 0), (6, 6)).copy_from(&decomposition.b_c);
    } else {
        // ξ_c(k−d+1) = ξ_c(k−d) + B_c u(k−d)
        a.view_mut((0, 6), (6, 6)).copy_from(&decomposition.b_c);
        // the command history shifts by one frame; u(k) enters last
        for block in 1..d {
            a.view_mut((6 * block, 6 * (block + 1)), (6, 6)).copy_from(&identity);
        }
        b.view_mut((6 * d, 0), (6, 6)).copy_from(&identity);
    }
    let r = DMatrix::from_column_slice(6, 6, r_si.as_slice());
    let (p, k) = dare::solve(&a, &b, &q_aug, &r)?;
    let k_state: Matrix6<f64> = k.fixed_view::<6, 6>(0, 0).into_owned();
    // u(k−d) sits in block 1, u(k−1) in block d: K_j is the block of u(k−j)
    let past_input_gains = (1..=d).map(|j| k.fixed_view::<6, 6>(0, 6 * (d + 1 - j)).into_owned()).collect();
    Ok(DelayAwareGain { feature_gain: k_state * decomposition.controllable_rows, past_input_gains, p })
}
