//! The paper's figures from a run, as SVG (plotters' SVG backend needs no system fonts):
//! - `trajectory.svg`: the four points in the image plane, × where they start, □ at the reference (Figs. 6, 8);
//! - `error.svg`: the error of point 1 against time (Figs. 7, 9);
//! - for a moving object, `camera_position.svg`: the camera's path in the plane of the object's circle, with
//!   the circle itself (Figs. 11b, 12b). The trajectory plot is then the feature trajectory of Figs. 11a, 12a.

use std::path::Path;

use anyhow::{Result, anyhow};
use plotters::prelude::*;
use vservo_config::Config;
use vservo_lockstep::Trace;
use vservo_sim::world::ObjectMotion;

const COLOURS: [RGBColor; 4] =
    [RGBColor(200, 30, 30), RGBColor(30, 110, 200), RGBColor(30, 150, 60), RGBColor(150, 60, 170)];

/// Draws the figures into `dir` (the user's own folder: `crate::output::write_in`).
pub fn draw(trace: &Trace, config: &Config, dir: &Path) -> Result<()> {
    let mut svg = String::new();
    trajectory(trace, config, &mut svg)?;
    crate::output::write_in(dir, "trajectory.svg", svg.as_bytes())?;
    svg.clear();
    error(trace, &mut svg)?;
    crate::output::write_in(dir, "error.svg", svg.as_bytes())?;
    if let ObjectMotion::Circle { radius_m, .. } = config.cell.scenario.object {
        svg.clear();
        camera_position(trace, radius_m, &mut svg)?;
        crate::output::write_in(dir, "camera_position.svg", svg.as_bytes())?;
    }
    Ok(())
}

fn plot_error<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("drawing a plot: {e:?}")
}

fn finite_points(trace: &Trace, mark: usize) -> Vec<(f64, f64)> {
    trace
        .frames
        .iter()
        .map(|f| (f.measured[2 * mark], f.measured[2 * mark + 1]))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

fn trajectory(trace: &Trace, config: &Config, svg: &mut String) -> Result<()> {
    let root = SVGBackend::with_string(svg, (640, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let (w, h) = (f64::from(config.cell.camera.width_px()), f64::from(config.cell.camera.height_px()));
    let mut chart = ChartBuilder::on(&root)
        .caption("Trajectory of the 4 points (× start, □ reference)", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        // image y grows downwards
        .build_cartesian_2d(0.0..w, h..0.0)
        .map_err(plot_error)?;
    chart.configure_mesh().x_desc("x [px]").y_desc("y [px]").draw().map_err(plot_error)?;
    for (mark, &colour) in COLOURS.iter().enumerate() {
        let points = finite_points(trace, mark);
        chart
            .draw_series(LineSeries::new(points.iter().copied(), colour.stroke_width(1)))
            .map_err(plot_error)?
            .label(format!("point {}", mark + 1))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
        if let Some(&(x, y)) = points.first() {
            chart
                .draw_series(std::iter::once(Cross::new((x, y), 5, colour.stroke_width(2))))
                .map_err(plot_error)?;
        }
        let (xd, yd) = (trace.desired_features[2 * mark], trace.desired_features[2 * mark + 1]);
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(xd - 4.0, yd - 4.0), (xd + 4.0, yd + 4.0)],
                colour.stroke_width(1),
            )))
            .map_err(plot_error)?;
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

fn error(trace: &Trace, svg: &mut String) -> Result<()> {
    let points: Vec<(f64, f64)> = trace
        .frames
        .iter()
        .filter(|f| f.measured[0].is_finite() && f.measured[1].is_finite())
        .map(|f| {
            let dx = f.measured[0] - trace.desired_features[0];
            let dy = f.measured[1] - trace.desired_features[1];
            (f.t_s, (dx * dx + dy * dy).sqrt())
        })
        .collect();
    let t_end = trace.frames.last().map_or(1.0, |f| f.t_s).max(1e-3);
    let top = points.iter().map(|p| p.1).fold(1.0, f64::max) * 1.05;
    let root = SVGBackend::with_string(svg, (720, 400)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Error of point 1", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, 0.0..top)
        .map_err(plot_error)?;
    chart.configure_mesh().x_desc("time [s]").y_desc("|ξ₁ − ξ₁d| [px]").draw().map_err(plot_error)?;
    chart
        .draw_series(LineSeries::new(points, COLOURS[0].stroke_width(2)))
        .map_err(plot_error)?
        .label("point 1's distance from its desired place")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], COLOURS[0].stroke_width(2)));
    chart
        .draw_series(LineSeries::new([(0.0, 1.0), (t_end, 1.0)], BLACK.mix(0.4).stroke_width(1)))
        .map_err(plot_error)?
        .label("1 px")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.4)));
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

fn camera_position(trace: &Trace, radius_m: f64, svg: &mut String) -> Result<()> {
    let points: Vec<(f64, f64)> =
        trace.frames.iter().map(|f| (f.camera_in_desired_m.y, f.camera_in_desired_m.z)).collect();
    let circle: Vec<(f64, f64)> = (0..=200)
        .map(|i| {
            let a = std::f64::consts::TAU * f64::from(i) / 200.0;
            (radius_m * a.sin(), radius_m * (a.cos() - 1.0))
        })
        .collect();
    let span = 1.3 * radius_m;
    let root = SVGBackend::with_string(svg, (600, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let mut chart = ChartBuilder::on(&root)
        .caption("Camera position (grey: the object's circle)", ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-span..span, (-radius_m - span)..(span - radius_m))
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc("y, desired camera frame [m]")
        .y_desc("z, desired camera frame [m]")
        .draw()
        .map_err(plot_error)?;
    chart
        .draw_series(LineSeries::new(circle, BLACK.mix(0.3).stroke_width(1)))
        .map_err(plot_error)?
        .label("the object's circle")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.3)));
    chart
        .draw_series(LineSeries::new(points, COLOURS[1].stroke_width(2)))
        .map_err(plot_error)?
        .label("the camera")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], COLOURS[1].stroke_width(2)));
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}
