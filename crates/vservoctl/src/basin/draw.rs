//! `basin.svg`: one panel per class of starts, each start drawn by its outcome.

use anyhow::Result;
use plotters::prelude::*;

use super::{CLASSES, Class, Outcome, Run};

/// What a class's panel plots: the start's translation and rotation; for the roll class (no translation), the roll
/// and the settling time (a run that never settled drawn at the top).
struct PanelAxes {
    rolls: bool,
    max_x: f64,
    max_y: f64,
    x_desc: &'static str,
    y_desc: &'static str,
}

impl PanelAxes {
    fn of(class: Class, runs: &[&Run]) -> Self {
        let largest = |value: &dyn Fn(&Run) -> f64| runs.iter().map(|r| value(r)).fold(1.0, f64::max);
        if class.roll_deg.is_some() {
            return Self {
                rolls: true,
                max_x: largest(&|r| r.start.rotation.norm().to_degrees()),
                max_y: largest(&|r| r.settling_time_s.unwrap_or(0.0)),
                x_desc: "roll [deg]",
                y_desc: "settling time [s] (above: not settled)",
            };
        }
        Self {
            rolls: false,
            max_x: largest(&|r| r.start.translation_m.norm() * 100.0),
            max_y: largest(&|r| r.start.rotation.norm().to_degrees()),
            x_desc: "translation [cm]",
            y_desc: "rotation [deg]",
        }
    }

    fn point(&self, run: &Run) -> (f64, f64) {
        if self.rolls {
            let settled = run.settling_time_s.unwrap_or(self.max_y * 1.1);
            (run.start.rotation.norm().to_degrees(), settled)
        } else {
            (run.start.translation_m.norm() * 100.0, run.start.rotation.norm().to_degrees())
        }
    }
}

pub(super) fn draw(runs: &[Run], svg: &mut String) -> Result<()> {
    let plot_error = |e: &dyn std::fmt::Debug| anyhow::anyhow!("drawing basin.svg: {e:?}");
    let root = SVGBackend::with_string(svg, (1200, 360)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_error(&e))?;
    let panels = root.split_evenly((1, CLASSES.len()));
    for (class, panel) in panels.iter().enumerate() {
        let c = CLASSES[class];
        let mine: Vec<&Run> = runs.iter().filter(|r| r.start.class == class).collect();
        let axes = PanelAxes::of(c, &mine);
        let mut chart = ChartBuilder::on(panel)
            .caption(c.name, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(40)
            // headroom above the starts for the legend
            .build_cartesian_2d(0.0..axes.max_x * 1.05, 0.0..axes.max_y * 1.5)
            .map_err(|e| plot_error(&e))?;
        chart.configure_mesh().x_desc(axes.x_desc).y_desc(axes.y_desc).draw().map_err(|e| plot_error(&e))?;
        // one series per outcome, each in the legend (filled: counted; a ring: not counted)
        for outcome in Outcome::ALL {
            let points: Vec<(f64, f64)> =
                mine.iter().filter(|r| r.drawn_as() == outcome).map(|r| axes.point(r)).collect();
            if points.is_empty() {
                continue;
            }
            let style =
                if outcome.counted() { outcome.colour().filled() } else { outcome.colour().stroke_width(1) };
            chart
                .draw_series(points.into_iter().map(|point| Circle::new(point, 3, style)))
                .map_err(|e| plot_error(&e))?
                .label(format!(
                    "{} ({})",
                    outcome.name(),
                    mine.iter().filter(|r| r.drawn_as() == outcome).count()
                ))
                .legend(move |(x, y)| Circle::new((x + 6, y), 3, style));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 11))
            .border_style(BLACK)
            .background_style(WHITE.mix(0.85))
            .draw()
            .map_err(|e| plot_error(&e))?;
    }
    root.present().map_err(|e| plot_error(&e))?;
    Ok(())
}
