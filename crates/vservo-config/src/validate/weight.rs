//! `controller.q` and `controller.r`: a number (times I), a list of N (the diagonal) or N lists of N (full).

use nalgebra::{SMatrix, SVector};

use super::checker::Checker;
use crate::ConfigError;

/// The largest entry of Q or R: beyond it the Riccati iteration loses its digits.
const MAX_WEIGHT: f64 = 1e12;

/// The weight as written, every entry finite and within ±[`MAX_WEIGHT`].
pub fn weight<const N: usize>(
    check: &Checker,
    key: &str,
    value: &toml::Value,
) -> Result<SMatrix<f64, N, N>, ConfigError> {
    let shape = format!("a number, a list of {N} numbers (the diagonal) or {N} lists of {N} numbers");
    let matrix = match value {
        toml::Value::Array(items) => from_rows_or_diagonal::<N>(check, key, value, items, &shape)?,
        scalar => match number(scalar) {
            Some(scalar) => SMatrix::<f64, N, N>::identity() * scalar,
            None => return Err(check.invalid(key, value, format!("expected {shape}"))),
        },
    };
    if !matrix.iter().all(|v| v.is_finite() && v.abs() <= MAX_WEIGHT) {
        return Err(check.invalid(key, value, format!("every entry must be within ±{MAX_WEIGHT:e}")));
    }
    Ok(matrix)
}

fn number(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// N numbers (the diagonal) or N rows of N numbers.
fn from_rows_or_diagonal<const N: usize>(
    check: &Checker,
    key: &str,
    value: &toml::Value,
    items: &[toml::Value],
    shape: &str,
) -> Result<SMatrix<f64, N, N>, ConfigError> {
    if items.len() != N {
        return Err(check.invalid(key, value, format!("has {} entries; expected {shape}", items.len())));
    }
    if let Some(diagonal) = items.iter().map(number).collect::<Option<Vec<f64>>>() {
        return Ok(SMatrix::<f64, N, N>::from_diagonal(&SVector::<f64, N>::from_column_slice(&diagonal)));
    }
    let mut matrix = SMatrix::<f64, N, N>::zeros();
    for (row, item) in items.iter().enumerate() {
        let entries = match item {
            toml::Value::Array(entries) if entries.len() == N => entries,
            _ => {
                return Err(check.invalid(
                    key,
                    value,
                    format!("row {} is not {N} numbers; expected {shape}", row + 1),
                ));
            }
        };
        for (column, entry) in entries.iter().enumerate() {
            matrix[(row, column)] = number(entry).ok_or_else(|| {
                check.invalid(key, value, format!("entry ({}, {}) is not a number", row + 1, column + 1))
            })?;
        }
    }
    Ok(matrix)
}
