//! The LQ weights Q and R, validated once ("parse, don't validate").

use nalgebra::{Matrix6, SMatrix};
use vservo_scene::FEATURES;

/// The state weight Q: 8 × 8, symmetric, positive semi-definite, finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateWeight(SMatrix<f64, FEATURES, FEATURES>);

/// The input weight R: 6 × 6, symmetric, positive definite, finite; written for `units`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputWeight {
    matrix: Matrix6<f64>,
    units: InputUnits,
}

/// The unit of the camera twist in which R is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InputUnits {
    /// m/s and rad/s.
    Si,
    /// mm/s and mrad/s, the paper's: its Q = 300·I₈ and R = diag(1,1,1,6,6,6) are meant in these.
    #[default]
    MillimetreMilliradian,
}

impl InputUnits {
    /// How many of these units make one SI unit (1000 for mm/s and mrad/s).
    pub fn per_si_unit(&self) -> f64 {
        match self {
            InputUnits::Si => 1.0,
            InputUnits::MillimetreMilliradian => 1000.0,
        }
    }

    /// The name used in configuration files.
    pub fn name(&self) -> &'static str {
        match self {
            InputUnits::Si => "si",
            InputUnits::MillimetreMilliradian => "mm-mrad",
        }
    }
}

/// Why a weight was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WeightError {
    /// A diagonal or matrix of the wrong size.
    #[error("expected {expected} values, got {got}")]
    WrongSize {
        /// What was needed.
        expected: String,
        /// What came.
        got: String,
    },
    /// An entry is NaN or infinite.
    #[error("entry ({row}, {column}) = {value} is not finite")]
    NotFinite {
        /// Zero-based row.
        row: usize,
        /// Zero-based column.
        column: usize,
        /// The value.
        value: f64,
    },
    /// The matrix is not symmetric.
    #[error("not symmetric: entry ({row}, {column}) = {a} but ({column}, {row}) = {b}")]
    NotSymmetric {
        /// Zero-based row.
        row: usize,
        /// Zero-based column.
        column: usize,
        /// One entry.
        a: f64,
        /// Its mirror.
        b: f64,
    },
    /// Q has a negative eigenvalue.
    #[error("not positive semi-definite: smallest eigenvalue {0}")]
    NotPositiveSemiDefinite(f64),
    /// R has a non-positive eigenvalue.
    #[error("not positive definite: smallest eigenvalue {0}")]
    NotPositiveDefinite(f64),
}

fn check_symmetric_finite<const N: usize>(m: &SMatrix<f64, N, N>) -> Result<f64, WeightError> {
    for row in 0..N {
        for column in 0..N {
            let value = m[(row, column)];
            if !value.is_finite() {
                return Err(WeightError::NotFinite { row, column, value });
            }
        }
    }
    let scale = m.amax().max(f64::MIN_POSITIVE);
    for row in 0..N {
        for column in (row + 1)..N {
            let (a, b) = (m[(row, column)], m[(column, row)]);
            if (a - b).abs() > 1e-12 * scale {
                return Err(WeightError::NotSymmetric { row, column, a, b });
            }
        }
    }
    Ok(scale)
}

impl StateWeight {
    /// Validates Q.
    pub fn new(matrix: SMatrix<f64, FEATURES, FEATURES>) -> Result<Self, WeightError> {
        let scale = check_symmetric_finite(&matrix)?;
        let smallest = matrix.symmetric_eigenvalues().min();
        if smallest < -1e-12 * scale {
            return Err(WeightError::NotPositiveSemiDefinite(smallest));
        }
        Ok(Self(matrix))
    }

    /// Q = q·I₈.
    pub fn scalar(q: f64) -> Result<Self, WeightError> {
        Self::new(SMatrix::identity() * q)
    }

    /// The matrix.
    pub fn matrix(&self) -> &SMatrix<f64, FEATURES, FEATURES> {
        &self.0
    }
}

impl InputWeight {
    /// Validates R, written for `units`.
    pub fn new(matrix: Matrix6<f64>, units: InputUnits) -> Result<Self, WeightError> {
        let scale = check_symmetric_finite(&matrix)?;
        let smallest = matrix.symmetric_eigenvalues().min();
        if smallest <= 1e-12 * scale || matrix.cholesky().is_none() {
            return Err(WeightError::NotPositiveDefinite(smallest));
        }
        Ok(Self { matrix, units })
    }

    /// R as written, in its own units.
    pub fn as_written(&self) -> &Matrix6<f64> {
        &self.matrix
    }

    /// The unit R is written for.
    pub fn units(&self) -> InputUnits {
        self.units
    }

    /// R for a twist in SI units: uᵀ_unit R u_unit = (s·u_SI)ᵀ R (s·u_SI), so R_SI = s²·R.
    pub fn si(&self) -> Matrix6<f64> {
        let s = self.units.per_si_unit();
        self.matrix * (s * s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn r_in_millimetres_is_a_million_times_r_in_metres() {
        let r = InputWeight::new(Matrix6::from_diagonal_element(6.0), InputUnits::MillimetreMilliradian)
            .expect("valid");
        assert_eq!(r.si()[(0, 0)], 6.0e6);
        let r = InputWeight::new(Matrix6::identity(), InputUnits::Si).expect("valid");
        assert_eq!(r.si(), Matrix6::identity());
    }

    #[test]
    fn bad_weights_are_refused_with_the_reason() {
        let mut q = SMatrix::<f64, 8, 8>::identity();
        q[(0, 1)] = 1.0;
        assert!(matches!(StateWeight::new(q), Err(WeightError::NotSymmetric { row: 0, column: 1, .. })));
        let q = SMatrix::<f64, 8, 8>::identity() * -1.0;
        assert!(matches!(StateWeight::new(q), Err(WeightError::NotPositiveSemiDefinite(_))));
        let mut q = SMatrix::<f64, 8, 8>::identity();
        q[(3, 3)] = f64::NAN;
        assert!(matches!(StateWeight::new(q), Err(WeightError::NotFinite { row: 3, column: 3, .. })));
        assert!(StateWeight::new(SMatrix::zeros()).is_ok(), "Q = 0 is semi-definite");
        let mut r = Matrix6::identity();
        r[(5, 5)] = 0.0;
        assert!(matches!(InputWeight::new(r, InputUnits::Si), Err(WeightError::NotPositiveDefinite(_))));
    }
}
