//! The paper's figures from a run, as SVG (plotters' SVG backend needs no system fonts), each titled with the law
//! and its weights, and the scenario's events (the board's step, a mark covered) marked on the time axes:
//! - `trajectory.svg`: the four points in the image plane, × where they start, □ at the reference (Figs. 6, 8);
//!   through a lens that distorts, the points as the servo took them (undistorted), where ξ_d is;
//! - `error.svg`: each point's distance from its desired place against time, point 1's bold (Figs. 7, 9);
//! - `joints.svg`: the joint angles against time; `twist.svg`: the camera twist the servo sent;
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
    error(trace, config, &mut svg)?;
    crate::output::write_in(dir, "error.svg", svg.as_bytes())?;
    svg.clear();
    joints(trace, config, &mut svg)?;
    crate::output::write_in(dir, "joints.svg", svg.as_bytes())?;
    svg.clear();
    twist(trace, config, &mut svg)?;
    crate::output::write_in(dir, "twist.svg", svg.as_bytes())?;
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

/// Mark `mark` of a frame as the servo took it: the extractor's position, through the lens to its pinhole pixel
/// when the lens distorts and the features are undistorted (`vision.undistort`), where ξ_d is.
fn as_servoed(config: &Config, measured: &vservo_scene::FeatureVector, mark: usize) -> (f64, f64) {
    let seen = nalgebra::Point2::new(measured[2 * mark], measured[2 * mark + 1]);
    let camera = &config.cell.camera;
    if !config.cell.vision.undistort
        || camera.distortion().is_none()
        || !(seen.x.is_finite() && seen.y.is_finite())
    {
        return (seen.x, seen.y);
    }
    camera.pinhole_of_observed(&seen).map_or((f64::NAN, f64::NAN), |p| (p.x, p.y))
}

fn finite_points(trace: &Trace, config: &Config, mark: usize) -> Vec<(f64, f64)> {
    trace
        .frames
        .iter()
        .map(|f| as_servoed(config, &f.measured, mark))
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect()
}

fn trajectory(trace: &Trace, config: &Config, svg: &mut String) -> Result<()> {
    let root = SVGBackend::with_string(svg, (640, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let (w, h) = (f64::from(config.cell.camera.width_px()), f64::from(config.cell.camera.height_px()));
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("The 4 points (× start, □ reference); {}", law_title(config)), ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        // image y grows downwards
        .build_cartesian_2d(0.0..w, h..0.0)
        .map_err(plot_error)?;
    chart.configure_mesh().x_desc("x [px]").y_desc("y [px]").draw().map_err(plot_error)?;
    for (mark, &colour) in COLOURS.iter().enumerate() {
        let points = finite_points(trace, config, mark);
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

fn error(trace: &Trace, config: &Config, svg: &mut String) -> Result<()> {
    let distances = |mark: usize| -> Vec<(f64, f64)> {
        let (xd, yd) = (trace.desired_features[2 * mark], trace.desired_features[2 * mark + 1]);
        trace
            .frames
            .iter()
            .map(|f| (f.t_s, as_servoed(config, &f.measured, mark)))
            .filter(|(_, (x, y))| x.is_finite() && y.is_finite())
            .map(|(t, (x, y))| (t, (x - xd).hypot(y - yd)))
            .collect()
    };
    let series: Vec<Vec<(f64, f64)>> = (0..4).map(distances).collect();
    let t_end = trace.frames.last().map_or(1.0, |f| f.t_s).max(1e-3);
    let top = series.iter().flatten().map(|p| p.1).fold(1.0, f64::max) * 1.05;
    let root = SVGBackend::with_string(svg, (720, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Feature error; {}", law_title(config)), ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, 0.0..top)
        .map_err(plot_error)?;
    chart.configure_mesh().x_desc("time [s]").y_desc("|ξᵢ − ξᵢd| [px]").draw().map_err(plot_error)?;
    for (mark, points) in series.iter().enumerate() {
        // point 1's as the paper draws it, the others beside it
        let style = COLOURS[mark].stroke_width(if mark == 0 { 2 } else { 1 });
        chart
            .draw_series(LineSeries::new(points.iter().copied(), style))
            .map_err(plot_error)?
            .label(format!("point {}", mark + 1))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style));
    }
    // point 1's again, over the others
    chart
        .draw_series(LineSeries::new(series[0].iter().copied(), COLOURS[0].stroke_width(2)))
        .map_err(plot_error)?;
    chart
        .draw_series(LineSeries::new([(0.0, 1.0), (t_end, 1.0)], BLACK.mix(0.4).stroke_width(1)))
        .map_err(plot_error)?
        .label("1 px")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK.mix(0.4)));
    mark_events(&mut chart, config, (t_end, top))?;
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// The joint angles against time.
fn joints(trace: &Trace, config: &Config, svg: &mut String) -> Result<()> {
    let count = config.cell.arm.joint_count();
    let t_end = trace.joints.last().map_or(1.0, |j| j.t_s).max(1e-3);
    let values = trace.joints.iter().flat_map(|j| j.q.iter().take(count).copied()).filter(|v| v.is_finite());
    let (low, high) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(v), h.max(v)));
    let (low, high) = if low <= high { (low - 0.05, high + 0.05) } else { (-1.0, 1.0) };
    let root = SVGBackend::with_string(svg, (720, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Joint angles; {}", law_title(config)), ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, low..high)
        .map_err(plot_error)?;
    chart.configure_mesh().x_desc("time [s]").y_desc("q [rad]").draw().map_err(plot_error)?;
    for joint in 0..count {
        let colour = Palette99::pick(joint).to_rgba();
        let points: Vec<(f64, f64)> = trace.joints.iter().map(|j| (j.t_s, j.q[joint])).collect();
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(1)))
            .map_err(plot_error)?
            .label(format!("joint {}", joint + 1))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
    }
    mark_events(&mut chart, config, (t_end, high))?;
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// The camera twist the servo sent, frame by frame: its linear (m/s) and angular (rad/s) parts on one axis.
fn twist(trace: &Trace, config: &Config, svg: &mut String) -> Result<()> {
    let t_end = trace.frames.last().map_or(1.0, |f| f.t_s).max(1e-3);
    let largest = trace.frames.iter().flat_map(|f| f.twist.iter().map(|v| v.abs())).filter(|v| v.is_finite());
    let span = largest.fold(0.01, f64::max) * 1.05;
    let root = SVGBackend::with_string(svg, (720, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("Camera twist; {}", law_title(config)), ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, -span..span)
        .map_err(plot_error)?;
    chart.configure_mesh().x_desc("time [s]").y_desc("v [m/s], ω [rad/s]").draw().map_err(plot_error)?;
    let names = ["vx", "vy", "vz", "ωx", "ωy", "ωz"];
    for (axis, name) in names.iter().enumerate() {
        let colour = Palette99::pick(axis).to_rgba();
        let points: Vec<(f64, f64)> = trace.frames.iter().map(|f| (f.t_s, f.twist[axis])).collect();
        let style = if axis < 3 { colour.stroke_width(2) } else { colour.stroke_width(1) };
        chart
            .draw_series(LineSeries::new(points, style))
            .map_err(plot_error)?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style));
    }
    mark_events(&mut chart, config, (t_end, span))?;
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw().map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// The law and its weights, for a plot's title: "law paper, Q = 300·I, R = 1·I (m/s, rad/s)".
fn law_title(config: &Config) -> String {
    let controller = &config.cell.controller;
    let r = controller.r.as_written();
    format!(
        "law {}, Q = {}, R = {} ({})",
        controller.law.name(),
        describe(controller.q.matrix().as_view()),
        describe(r.as_view()),
        controller.r.units().name()
    )
}

/// A square weight in a few characters: c·I, diag(…), or full with its trace.
fn describe<const N: usize>(
    m: nalgebra::Matrix<
        f64,
        nalgebra::Const<N>,
        nalgebra::Const<N>,
        nalgebra::ViewStorage<
            '_,
            f64,
            nalgebra::Const<N>,
            nalgebra::Const<N>,
            nalgebra::Const<1>,
            nalgebra::Const<N>,
        >,
    >,
) -> String {
    let diagonal = (0..N).all(|i| (0..N).all(|j| i == j || m[(i, j)] == 0.0));
    if !diagonal {
        return format!("full (trace {})", m.trace());
    }
    let d: Vec<f64> = (0..N).map(|i| m[(i, i)]).collect();
    if d.iter().all(|v| *v == d[0]) {
        return format!("{}·I", d[0]);
    }
    format!("diag({})", d.iter().map(f64::to_string).collect::<Vec<_>>().join(", "))
}

/// The scenario's events on a plot against time: the board's step, and each covered mark's span, as grey
/// vertical lines labelled at the top.
fn mark_events<DB: DrawingBackend>(
    chart: &mut ChartContext<
        '_,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    config: &Config,
    (t_end, top): (f64, f64),
) -> Result<()> {
    let scenario = &config.cell.scenario;
    let mut events: Vec<(f64, String)> = Vec::new();
    if let vservo_sim::world::ObjectMotion::Step { at_s, .. } = scenario.object {
        events.push((at_s, "the board steps".to_string()));
    }
    for occlusion in scenario.occlusions.iter().flatten() {
        events.push((occlusion.from_s, format!("mark {} covered", occlusion.mark + 1)));
        events.push((occlusion.until_s, format!("mark {} uncovered", occlusion.mark + 1)));
    }
    let y_range = chart.y_range();
    for (t, label) in events.into_iter().filter(|(t, _)| (0.0..=t_end).contains(t)) {
        let grey = BLACK.mix(0.35);
        chart
            .draw_series(std::iter::once(PathElement::new(vec![(t, y_range.start), (t, y_range.end)], grey)))
            .map_err(plot_error)?;
        chart
            .draw_series(std::iter::once(Text::new(
                label,
                (t, top),
                ("sans-serif", 11).into_font().color(&grey),
            )))
            .map_err(plot_error)?;
    }
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
