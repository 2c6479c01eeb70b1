//! The LQ gain for any interaction matrix, designed on the frame: the paper's design (eq. 29–41) with the
//! closed-form Riccati solution, on statically sized matrices so that the servo can run it on every frame
//! without allocating. Used for the gains on three marks (the rows of a missing mark zeroed) and for a gain
//! scheduled on the current features.

use nalgebra::{Matrix6, SMatrix};
use vservo_scene::{FEATURES, MARKS};

use crate::lq::LqError;
use crate::{FeatureGain, InteractionMatrix};

/// The pseudo-inverse of an interaction matrix, 6 × 8: the least-squares twist for a feature motion.
pub type PseudoInverse = SMatrix<f64, 6, FEATURES>;

/// A bit per mark: bit m set when mark m is seen (`0b1111`: all four).
pub type MarkSet = u8;

/// All four marks.
pub const ALL_MARKS: MarkSet = (1 << MARKS) - 1;

/// How many marks a set holds.
pub fn mark_count(marks: MarkSet) -> u32 {
    (marks & ALL_MARKS).count_ones()
}

/// The marks whose two features are both finite.
pub fn finite_marks(features: &nalgebra::SVector<f64, FEATURES>) -> MarkSet {
    (0..MARKS)
        .filter(|&m| features[2 * m].is_finite() && features[2 * m + 1].is_finite())
        .fold(0, |set, m| set | (1 << m))
}

/// B with the rows of the marks not in `marks` zeroed: the model of what the visible marks do. With three
/// marks of the board B is 6 × 6 in effect and (away from degenerate images) non-singular: the paper's
/// design with N = 3 has no uncontrollable modes.
pub fn masked(b: &InteractionMatrix, marks: MarkSet) -> InteractionMatrix {
    let mut out = *b;
    for mark in (0..MARKS).filter(|m| marks & (1 << m) == 0) {
        out.fixed_view_mut::<2, 6>(2 * mark, 0).fill(0.0);
    }
    out
}

/// The gain and pseudo-inverse of one interaction matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameDesign {
    /// K = K_c S₁ (m/s and rad/s per px); zero columns for the rows B does not have.
    pub gain: FeatureGain,
    /// B⁺ = V Σ⁻¹ Uᵀ.
    pub pseudo_inverse: PseudoInverse,
}

/// The paper's LQ gain for `b` (eq. 29–41: S₁ = Uᵀ from the SVD, B_c = ΣVᵀ, Q_c = S₁QS₁ᵀ, the closed-form
/// DARE), with R in SI units. Allocates nothing.
pub fn design(
    b: &InteractionMatrix,
    q: &SMatrix<f64, FEATURES, FEATURES>,
    r_si: &Matrix6<f64>,
) -> Result<FrameDesign, LqError> {
    let svd = b.svd(true, true);
    let sigma = svd.singular_values;
    let as_array = || [sigma[0], sigma[1], sigma[2], sigma[3], sigma[4], sigma[5]];
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(LqError::Degenerate(as_array()));
    };
    let largest = sigma.max();
    if !sigma.iter().all(|s| s.is_finite()) || sigma.min() <= 1e-9 * largest {
        return Err(LqError::Degenerate(as_array()));
    }
    let controllable_rows = u.transpose();
    let b_c = Matrix6::from_diagonal(&sigma) * v_t;
    let q_c = controllable_rows * q * u;
    let q_c = (q_c + q_c.transpose()) * 0.5;
    let (_, k_c) = crate::dare::solve_identity(&b_c, &q_c, r_si)?;
    let sigma_inverse = Matrix6::from_diagonal(&sigma.map(|s| 1.0 / s));
    Ok(FrameDesign {
        gain: k_c * controllable_rows,
        pseudo_inverse: v_t.transpose() * sigma_inverse * controllable_rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_jacobian::interaction_matrix;
    use crate::weights::{InputUnits, InputWeight, StateWeight};
    use nalgebra::{Matrix6, SMatrix, Vector6};
    use vservo_scene::{CameraIntrinsics, FeatureVector, MarkDepths};

    fn paper() -> (InteractionMatrix, StateWeight, Matrix6<f64>) {
        let features = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0]);
        let b =
            interaction_matrix(&CameraIntrinsics::paper(), &features, &MarkDepths::from_element(0.5), 0.085);
        let r = InputWeight::new(
            Matrix6::from_diagonal(&Vector6::new(1.0, 1.0, 1.0, 6.0, 6.0, 6.0)),
            InputUnits::MillimetreMilliradian,
        )
        .expect("valid");
        (b, StateWeight::scalar(300.0).expect("valid"), r.si())
    }

    #[test]
    fn on_four_marks_it_is_the_paper_s_gain() {
        let (b, q, r) = paper();
        let ours = design(&b, q.matrix(), &r).expect("designable");
        let decomposition = crate::lq::ModeDecomposition::of(&b).expect("non-degenerate");
        let theirs = crate::lq::paper_gain(&decomposition, &q, &r).expect("designable");
        assert!((ours.gain - theirs.k).norm() < 1e-9 * theirs.k.norm());
        // B⁺ B = I
        assert!((ours.pseudo_inverse * b - Matrix6::identity()).amax() < 1e-9);
    }

    #[test]
    fn on_three_marks_the_gain_ignores_the_fourth_and_stabilizes_the_three() {
        let (b, q, r) = paper();
        for missing in 0..MARKS {
            let seen = ALL_MARKS & !(1 << missing);
            let b3 = masked(&b, seen);
            let three = design(&b3, q.matrix(), &r).expect("three marks are not degenerate");
            // zero to rounding (the law zeroes the missing mark's error before the product anyway)
            let columns = three.gain.fixed_view::<6, 2>(0, 2 * missing).amax();
            assert!(columns < 1e-12 * three.gain.amax(), "mark {missing}'s columns: {columns}");
            // the seen features' loop ξ ← (I − B K) ξ: all six modes inside the unit circle
            let mut rows = [0usize; 6];
            for (n, row) in (0..FEATURES).filter(|r| r / 2 != missing).enumerate() {
                rows[n] = row;
            }
            let loop_matrix = SMatrix::<f64, 6, 6>::from_fn(|i, j| {
                let identity = if i == j { 1.0 } else { 0.0 };
                identity - (b3.row(rows[i]) * three.gain.column(rows[j]))[0]
            });
            let largest = loop_matrix.complex_eigenvalues().iter().map(|e| e.norm()).fold(0.0, f64::max);
            assert!(largest < 1.0, "mark {missing} missing: spectral radius {largest}");
        }
    }

    #[test]
    fn two_marks_are_degenerate() {
        let (b, q, r) = paper();
        assert!(matches!(design(&masked(&b, 0b0011), q.matrix(), &r), Err(LqError::Degenerate(_))));
    }
}
