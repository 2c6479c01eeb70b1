//! Plain-text and JSON rendering of vectors and matrices.

use std::fmt::Write;

use nalgebra::{Dim, Matrix, RawStorage};
use serde_json::Value;

/// A matrix as a JSON array of rows.
pub fn matrix_json<R: Dim, C: Dim, S: RawStorage<f64, R, C>>(m: &Matrix<f64, R, C, S>) -> Value {
    Value::from(
        (0..m.nrows()).map(|r| (0..m.ncols()).map(|c| m[(r, c)]).collect::<Vec<f64>>()).collect::<Vec<_>>(),
    )
}

/// A vector as a JSON array.
pub fn vector_json<R: Dim, S: RawStorage<f64, R, nalgebra::U1>>(
    v: &Matrix<f64, R, nalgebra::U1, S>,
) -> Value {
    Value::from(v.iter().copied().collect::<Vec<f64>>())
}

/// A titled matrix, one row a line, fixed-width columns.
pub fn matrix_text<R: Dim, C: Dim, S: RawStorage<f64, R, C>>(
    title: &str,
    m: &Matrix<f64, R, C, S>,
) -> String {
    let mut out = format!("{title}:\n");
    for r in 0..m.nrows() {
        out.push(' ');
        for c in 0..m.ncols() {
            // writing to a String cannot fail
            let _ = write!(out, " {:>12.6}", clean(m[(r, c)]));
        }
        out.push('\n');
    }
    out
}

/// A titled row vector on one line.
pub fn vector_text<R: Dim, S: RawStorage<f64, R, nalgebra::U1>>(
    title: &str,
    v: &Matrix<f64, R, nalgebra::U1, S>,
) -> String {
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

/// Writes `bytes` as `name` in `folder`, a folder of the user's own (checked, or made new, by
/// `vservo_config::new_file::folder` before any work): the user's own file at the name is replaced; a link or
/// another user's file there is refused, naming it, and never written through.
pub fn write_in(folder: &std::path::Path, name: &str, bytes: &[u8]) -> anyhow::Result<()> {
    vservo_config::new_file::write(&folder.join(name), bytes, true, 0o644)?;
    Ok(())
}
