//! The discrete algebraic Riccati equation P = AᵀPA − AᵀPB(R + BᵀPB)⁻¹BᵀPA + Q.
//!
//! - [`solve_identity`]: the closed form for A = I and a square, non-singular B, which the
//!   paper's design needs on its controllable modes. With R = LLᵀ, M = BᵀQB, M̃ = L⁻¹ML⁻ᵀ = VΛVᵀ:
//!   X̃ = V·diag((λ + √(λ² + 4λ))/2)·Vᵀ, X = LX̃Lᵀ = BᵀPB, P = B⁻ᵀXB⁻¹, K = (R + X)⁻¹XB⁻¹.
//! - [`solve`]: any A, by the structure-preserving doubling algorithm (Chu, Fan & Lin 2005), for the
//!   delay-augmented design. It converges quadratically when (A, B) is stabilizable and (Q, A) detectable.
//!
//! Failure is an error, never a NaN gain: a weight that is not definite, no convergence, a result that does
//! not satisfy the equation, or a gain that does not stabilize.

use nalgebra::{DMatrix, Matrix6};

/// Why the Riccati equation has no usable solution.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DareError {
    /// A matrix that must be positive definite is not.
    #[error("{what} is not positive definite (smallest eigenvalue {smallest_eigenvalue:e})")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
        /// Its smallest eigenvalue.
        smallest_eigenvalue: f64,
    },
    /// B is singular, so the closed form does not apply.
    #[error("the input matrix B is singular")]
    SingularInput,
    /// The doubling iteration met a singular I + GH (the problem is not stabilizable or not detectable).
    #[error(
        "the doubling iteration broke down at step {0}: the pair (A, B) is not stabilizable or (Q, A) not detectable"
    )]
    Breakdown(usize),
    /// The doubling iteration did not settle.
    #[error("no convergence after {iterations} doubling steps (relative change {relative_change:e})")]
    NotConverged {
        /// Steps taken.
        iterations: usize,
        /// The last relative change of P.
        relative_change: f64,
    },
    /// The result does not satisfy the equation.
    #[error("the solution's relative residual is {0:e}")]
    Residual(f64),
    /// The resulting closed loop A − BK is not stable.
    #[error("the resulting gain does not stabilize the loop (spectral radius {0})")]
    NotStabilizing(f64),
    /// Inputs or results held NaN or infinity.
    #[error("non-finite values in the Riccati equation")]
    NonFinite,
    /// Matrix sizes do not fit together.
    #[error("matrix sizes do not fit: {0}")]
    Shape(String),
}

/// Residual above which a solution is refused.
pub const RESIDUAL_LIMIT: f64 = 1e-9;

/// The closed form for A = I with `b` square and non-singular: returns (P, K) with
/// K = (R + BᵀPB)⁻¹BᵀP. `q` must be positive definite (a zero weight on a mode leaves it unstabilized).
pub fn solve_identity(
    b: &Matrix6<f64>,
    q: &Matrix6<f64>,
    r: &Matrix6<f64>,
) -> Result<(Matrix6<f64>, Matrix6<f64>), DareError> {
    if !(b.iter().chain(q.iter()).chain(r.iter()).all(|v| v.is_finite())) {
        return Err(DareError::NonFinite);
    }
    let q_smallest = q.symmetric_eigenvalues().min();
    if q_smallest <= 1e-12 * q.amax() {
        return Err(DareError::NotPositiveDefinite { what: "Q_c", smallest_eigenvalue: q_smallest });
    }
    let b_inverse = b.try_inverse().ok_or(DareError::SingularInput)?;
    let cholesky = r.cholesky().ok_or(DareError::NotPositiveDefinite {
        what: "R",
        smallest_eigenvalue: r.symmetric_eigenvalues().min(),
    })?;
    let l = cholesky.l();
    let l_inverse =
        l.try_inverse().ok_or(DareError::NotPositiveDefinite { what: "R", smallest_eigenvalue: 0.0 })?;
    let m = b.transpose() * q * b;
    let m_tilde = l_inverse * m * l_inverse.transpose();
    let m_tilde = (m_tilde + m_tilde.transpose()) * 0.5;
    let eigen = m_tilde.symmetric_eigen();
    let x_diag = eigen.eigenvalues.map(|lambda| {
        let lambda = lambda.max(0.0);
        0.5 * (lambda + (lambda * lambda + 4.0 * lambda).sqrt())
    });
    let x_tilde = eigen.eigenvectors * Matrix6::from_diagonal(&x_diag) * eigen.eigenvectors.transpose();
    let x = l * x_tilde * l.transpose();
    let x = (x + x.transpose()) * 0.5;
    let p = b_inverse.transpose() * x * b_inverse;
    let p = (p + p.transpose()) * 0.5;
    let gain = (r + x).cholesky().ok_or(DareError::NonFinite)?.solve(&(x * b_inverse));
    if !(p.iter().chain(gain.iter()).all(|v| v.is_finite())) {
        return Err(DareError::NonFinite);
    }
    Ok((p, gain))
}

/// The relative residual ‖AᵀPA − P − AᵀPB(R + BᵀPB)⁻¹BᵀPA + Q‖ / max(‖P‖, ‖Q‖) (Frobenius norms).
pub fn relative_residual(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> f64 {
    let bt_p = b.transpose() * p;
    let inner = r + &bt_p * b;
    let Some(inner_inverse) = inner.try_inverse() else { return f64::INFINITY };
    let residual =
        a.transpose() * p * a - p - a.transpose() * bt_p.transpose() * inner_inverse * &bt_p * a + q;
    residual.norm() / p.norm().max(q.norm()).max(f64::MIN_POSITIVE)
}

/// The LQ gain K = (R + BᵀPB)⁻¹BᵀPA for a solution P.
pub fn gain(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> Result<DMatrix<f64>, DareError> {
    let bt_p = b.transpose() * p;
    let inner = r + &bt_p * b;
    let cholesky = inner
        .cholesky()
        .ok_or(DareError::NotPositiveDefinite { what: "R + BᵀPB", smallest_eigenvalue: f64::NAN })?;
    Ok(cholesky.solve(&(bt_p * a)))
}

/// The stabilizing solution P of the DARE for any A, by structure-preserving doubling. Returns P and the
/// gain K; checks the residual and that A − BK is stable.
pub fn solve(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>), DareError> {
    let n = a.nrows();
    let m = b.ncols();
    if a.ncols() != n || b.nrows() != n || q.shape() != (n, n) || r.shape() != (m, m) {
        return Err(DareError::Shape(format!(
            "A {:?}, B {:?}, Q {:?}, R {:?}",
            a.shape(),
            b.shape(),
            q.shape(),
            r.shape()
        )));
    }
    if !(a.iter().chain(b.iter()).chain(q.iter()).chain(r.iter()).all(|v| v.is_finite())) {
        return Err(DareError::NonFinite);
    }
    let r_cholesky = r.clone().cholesky().ok_or(DareError::NotPositiveDefinite {
        what: "R",
        smallest_eigenvalue: r.clone().symmetric_eigenvalues().min(),
    })?;
    let identity = DMatrix::<f64>::identity(n, n);
    let mut a_k = a.clone();
    let mut g_k = b * r_cholesky.solve(&b.transpose());
    let mut h_k = q.clone();
    const MAX_STEPS: usize = 100;
    let mut relative_change = f64::INFINITY;
    for step in 0..MAX_STEPS {
        let w = &identity + &g_k * &h_k;
        let lu = w.lu();
        // W⁻¹A and W⁻¹G, then the three updates
        let w_inv_a = lu.solve(&a_k).ok_or(DareError::Breakdown(step))?;
        let w_inv_g = lu.solve(&g_k).ok_or(DareError::Breakdown(step))?;
        let a_next = &a_k * &w_inv_a;
        let g_next = &g_k + &a_k * &w_inv_g * a_k.transpose();
        let h_next = &h_k + a_k.transpose() * &h_k * &w_inv_a;
        let g_next = (&g_next + g_next.transpose()) * 0.5;
        let h_next = (&h_next + h_next.transpose()) * 0.5;
        relative_change = (&h_next - &h_k).norm() / h_next.norm().max(f64::MIN_POSITIVE);
        if !relative_change.is_finite() {
            return Err(DareError::NonFinite);
        }
        a_k = a_next;
        g_k = g_next;
        h_k = h_next;
        if relative_change < 1e-14 {
            let p = h_k;
            return check_solution(a, b, q, r, p);
        }
    }
    Err(DareError::NotConverged { iterations: MAX_STEPS, relative_change })
}

fn check_solution(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    q: &DMatrix<f64>,
    r: &DMatrix<f64>,
    p: DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>), DareError> {
    let residual = relative_residual(a, b, q, r, &p);
    if residual.is_nan() || residual >= RESIDUAL_LIMIT {
        return Err(DareError::Residual(residual));
    }
    let smallest = p.clone().symmetric_eigenvalues().min();
    if smallest < -1e-9 * p.amax() {
        return Err(DareError::NotPositiveDefinite { what: "P", smallest_eigenvalue: smallest });
    }
    let k = gain(a, b, r, &p)?;
    let closed_loop = a - b * &k;
    let radius = crate::analysis::spectral_radius(&closed_loop);
    if radius.is_nan() || radius >= 1.0 {
        return Err(DareError::NotStabilizing(radius));
    }
    Ok((p, k))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dynamic(m: &Matrix6<f64>) -> DMatrix<f64> {
        DMatrix::from_column_slice(6, 6, m.as_slice())
    }

    fn example() -> (Matrix6<f64>, Matrix6<f64>, Matrix6<f64>) {
        let b = Matrix6::from_fn(|i, j| if i == j { 2.0 + i as f64 } else { 0.1 * (i as f64 - j as f64) });
        let q = Matrix6::from_fn(|i, j| if i == j { 3.0 } else { 0.2 });
        let r = Matrix6::from_fn(|i, j| if i == j { 1.0 + 0.5 * j as f64 } else { 0.05 });
        (b, q, r)
    }

    #[test]
    fn closed_form_satisfies_the_equation_and_equals_the_doubling_solver() {
        let (b, q, r) = example();
        let (p, k) = solve_identity(&b, &q, &r).expect("solvable");
        let a = DMatrix::identity(6, 6);
        let residual = relative_residual(&a, &dynamic(&b), &dynamic(&q), &dynamic(&r), &dynamic(&p));
        assert!(residual < 1e-12, "residual {residual:e}");
        let (p_sda, k_sda) = solve(&a, &dynamic(&b), &dynamic(&q), &dynamic(&r)).expect("converges");
        assert!((p_sda - dynamic(&p)).norm() / p.norm() < 1e-10);
        assert!((k_sda - dynamic(&k)).norm() / k.norm() < 1e-10);
    }

    #[test]
    fn failures_are_errors_not_nan() {
        let (b, q, r) = example();
        assert!(matches!(
            solve_identity(&Matrix6::zeros(), &q, &r),
            Err(DareError::SingularInput) | Err(DareError::NotPositiveDefinite { .. })
        ));
        let mut q_singular = q;
        q_singular.fill_row(0, 0.0);
        q_singular.fill_column(0, 0.0);
        assert!(matches!(
            solve_identity(&b, &q_singular, &r),
            Err(DareError::NotPositiveDefinite { what: "Q_c", .. })
        ));
        // an unstable mode the input cannot reach: not stabilizable
        let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.5, 0.5]));
        let b = DMatrix::from_column_slice(2, 1, &[0.0, 1.0]);
        let q = DMatrix::identity(2, 2);
        let r = DMatrix::identity(1, 1);
        assert!(solve(&a, &b, &q, &r).is_err());
        let mut nan = dynamic(&example().0);
        nan[(0, 0)] = f64::NAN;
        let id = DMatrix::identity(6, 6);
        assert!(matches!(solve(&id, &nan, &id, &id), Err(DareError::NonFinite)));
    }
}
