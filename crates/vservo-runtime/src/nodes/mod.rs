//! The four node loops.

pub mod plant;
pub mod rmrc;
pub mod servo;
pub mod vision;

use std::time::Duration;

/// How long an event-driven node waits before it looks at its stop flag again.
const IDLE_WAIT: Duration = Duration::from_millis(100);

fn to_array<const N: usize>(v: &nalgebra::SVector<f64, N>) -> [f64; N] {
    let mut out = [0.0; N];
    out.copy_from_slice(v.as_slice());
    out
}
