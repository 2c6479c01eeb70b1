//! Plain-text and JSON rendering of vectors and matrices.

use std::fmt::Write;

use nalgebra::SMatrix;
use serde_json::Value;

/// A matrix as a JSON array of rows.
pub fn matrix_json<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> Value {
    Value::from((0..R).map(|r| (0..C).map(|c| m[(r, c)]).collect::<Vec<f64>>()).collect::<Vec<_>>())
}

/// A vector as a JSON array.
pub fn vector_json<const R: usize>(v: &SMatrix<f64, R, 1>) -> Value {
    Value::from(v.iter().copied().collect::<Vec<f64>>())
}

/// A titled matrix, one row a line, fixed-width columns.
pub fn matrix_text<const R: usize, const C: usize>(title: &str, m: &SMatrix<f64, R, C>) -> String {
    let mut out = format!("{title}:\n");
    for r in 0..R {
        out.push(' ');
        for c in 0..C {
            // writing to a String cannot fail
            let _ = write!(out, " {:>12.6}", clean(m[(r, c)]));
        }
        out.push('\n');
    }
    out
}

/// A titled row vector on one line.
pub fn vector_text<const R: usize>(title: &str, v: &SMatrix<f64, R, 1>) -> String {
    let mut out = format!("{:<26}", format!("{title}:"));
    for value in v.iter() {
        let _ = write!(out, " {:>12.6}", clean(*value));
    }
    out.push('\n');
    out
}

/// Shows −0.000000 and 1e-17 noise as 0.
fn clean(value: f64) -> f64 {
    if value.abs() < 5e-13 { 0.0 } else { value }
}

/// Writes to standard output; a closed pipe (`vservoctl … | head`) ends the output quietly.
pub fn print_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    match stdout.write_all(text.as_bytes()).and_then(|()| stdout.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}
