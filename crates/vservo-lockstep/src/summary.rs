//! The numbers a run is judged by, as the paper reports them.

use vservo_scene::MARKS;
use vservo_sim::world::ObjectMotion;

use crate::Trace;

/// The summary of a run (`summary.json`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Time after which every mark's true error stays below 1 px; `None` if it never does.
    pub settling_time_s: Option<f64>,
    /// For a step: how far mark 1 passes the target, as a percentage of its initial error.
    pub overshoot_percent: Option<f64>,
    /// The largest mark error in the last frame (px).
    pub final_error_px: f64,
    /// For tracking, after the first revolution: the largest x error of any mark (px).
    pub max_error_x_px: Option<f64>,
    /// …and the largest y error (px).
    pub max_error_y_px: Option<f64>,
    /// …the camera's half peak-to-peak motion along the desired camera frame's y (m); the object's is the
    /// circle's radius.
    pub camera_amplitude_y_m: Option<f64>,
    /// …and along z (m).
    pub camera_amplitude_z_m: Option<f64>,
}

/// The largest true error of any mark in frame `index` (px).
pub fn frame_error_px(trace: &Trace, index: usize) -> f64 {
    let f = &trace.frames[index];
    (0..MARKS)
        .map(|m| {
            let dx = f.truth[2 * m] - trace.desired_features[2 * m];
            let dy = f.truth[2 * m + 1] - trace.desired_features[2 * m + 1];
            (dx * dx + dy * dy).sqrt()
        })
        .fold(0.0, f64::max)
}

/// Summarizes a run of a scenario whose object moved as `object`.
pub fn summarize(trace: &Trace, object: &ObjectMotion) -> Summary {
    let n = trace.frames.len();
    let errors: Vec<f64> = (0..n).map(|i| frame_error_px(trace, i)).collect();
    let settling_time_s = match errors.iter().rposition(|e| e.is_nan() || *e >= 1.0) {
        None => Some(0.0),
        Some(i) if i + 1 < n => Some(trace.frames[i + 1].t_s),
        Some(_) => None,
    };
    let final_error_px = errors.last().copied().unwrap_or(f64::NAN);
    let mut summary = Summary {
        settling_time_s,
        overshoot_percent: None,
        final_error_px,
        max_error_x_px: None,
        max_error_y_px: None,
        camera_amplitude_y_m: None,
        camera_amplitude_z_m: None,
    };
    match object {
        ObjectMotion::Hold | ObjectMotion::Step { .. } => {
            // mark 1's error along its initial direction (after a step of the object, from the step)
            let start = match object {
                ObjectMotion::Step { at_s, .. } => {
                    trace.frames.iter().position(|f| f.t_s >= *at_s).unwrap_or(0)
                }
                _ => 0,
            };
            let error_of = |i: usize| {
                let f = &trace.frames[i];
                (f.truth[0] - trace.desired_features[0], f.truth[1] - trace.desired_features[1])
            };
            if start < n {
                let (x0, y0) = error_of(start);
                let size = x0 * x0 + y0 * y0;
                if size > 0.0 {
                    let lowest = (start..n)
                        .map(|i| {
                            let (x, y) = error_of(i);
                            (x * x0 + y * y0) / size
                        })
                        .fold(f64::INFINITY, f64::min);
                    summary.overshoot_percent = Some(100.0 * (-lowest).max(0.0));
                }
            }
        }
        ObjectMotion::Circle { rev_per_min, .. } => {
            let first_revolution_s = 60.0 / rev_per_min;
            let after: Vec<usize> = (0..n).filter(|&i| trace.frames[i].t_s >= first_revolution_s).collect();
            if !after.is_empty() {
                let (mut ex, mut ey) = (0.0_f64, 0.0_f64);
                let (mut y_lo, mut y_hi, mut z_lo, mut z_hi) =
                    (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
                for &i in &after {
                    let f = &trace.frames[i];
                    for m in 0..MARKS {
                        ex = ex.max((f.truth[2 * m] - trace.desired_features[2 * m]).abs());
                        ey = ey.max((f.truth[2 * m + 1] - trace.desired_features[2 * m + 1]).abs());
                    }
                    let p = f.camera_in_desired_m;
                    y_lo = y_lo.min(p.y);
                    y_hi = y_hi.max(p.y);
                    z_lo = z_lo.min(p.z);
                    z_hi = z_hi.max(p.z);
                }
                summary.max_error_x_px = Some(ex);
                summary.max_error_y_px = Some(ey);
                summary.camera_amplitude_y_m = Some(0.5 * (y_hi - y_lo));
                summary.camera_amplitude_z_m = Some(0.5 * (z_hi - z_lo));
            }
        }
    }
    summary
}
