//! `vservoctl top`: a live terminal view of a running instance — the daemon's state and fault, the robot
//! driver, each node's loop timing and counters, the servo's verdict and the feature error over the last
//! minute — refreshed several times a second; `q` (or Esc, Ctrl-C) quits.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use clap::Args;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Block, Chart, Dataset, GraphType, Paragraph, Row, Table};
use vservo_client::{StatusView, TimingUs};
use vservo_protocol::{
    CameraTwistMsg, DaemonStatusMsg, NodeRole, TakeMessages, TelemetryMsg, Topic, Verdict,
};

use crate::instance::{Connection, InstanceArg, wait_for};

/// Arguments of `vservoctl top`.
#[derive(Args, Debug)]
pub struct TopArgs {
    #[command(flatten)]
    instance: InstanceArg,
    /// Seconds between refreshes.
    #[arg(long, default_value_t = 0.2, value_parser = crate::seconds_arg::seconds)]
    refresh_s: f64,
}

/// Feature errors kept for the curve: a minute of frames at 85 ms.
const HISTORY: usize = 700;

/// What the view shows, gathered from the instance's topics.
struct Gathered {
    daemon: DaemonStatusMsg,
    telemetry: [Option<TelemetryMsg>; 4],
    twist: Option<CameraTwistMsg>,
    /// RMS feature error per frame (px), newest last.
    errors_px: VecDeque<f64>,
}

fn verdict_name(code: u32) -> &'static str {
    Verdict::try_from(code).map_or("unknown", Verdict::name)
}

fn timing(t: Option<TimingUs>) -> String {
    t.map_or("-".into(), |t| format!("{:.0}/{:.0}/{:.0}", t.p50, t.p99, t.max))
}

/// The whole view: the instance, its nodes, the servo's last twist and the error curve.
fn draw(frame: &mut ratatui::Frame, gathered: &Gathered, view: &StatusView, refreshes: u64) {
    let [header, nodes, servo, curve, help] = Layout::vertical([
        Constraint::Length(4),
        Constraint::Length(7),
        Constraint::Length(3),
        Constraint::Min(5),
        Constraint::Length(1),
    ])
    .areas(frame.area());
    draw_instance(frame, header, view);
    draw_nodes(frame, nodes, view);
    draw_servo(frame, servo, gathered);
    draw_error_curve(frame, curve, gathered);
    frame.render_widget(Paragraph::new(format!("q quits · refresh {refreshes}")), help);
}

/// The instance's state, robot driver, error and fault.
fn draw_instance(frame: &mut ratatui::Frame, header: ratatui::layout::Rect, view: &StatusView) {
    let state_style = match view.state {
        "running" | "moving" => Style::default().fg(Color::Green),
        "safe-stop" => Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
        _ => Style::default().fg(Color::Yellow),
    };
    let mut lines = vec![Line::from(vec![
        Span::raw(format!("instance {}  ", view.instance)),
        Span::styled(view.state, state_style),
        Span::raw(format!(
            "  up {:.1} s  daemon pid {}  gains v{}  safe stops {}",
            view.uptime_s, view.daemon_pid, view.gains_version, view.safe_stops
        )),
    ])];
    lines.push(Line::from(format!(
        "robot driver {}  joint states {:.0}/s  feature error {} px  speed scale {}",
        view.robot,
        view.tick_rate_hz,
        view.feature_error_px.map_or("-".into(), |e| format!("{e:.3}")),
        view.speed_scale
    )));
    if let Some(clearance) = view.clearance_text() {
        lines.push(Line::from(clearance));
    }
    if let Some(fault) = &view.fault {
        let joints = fault.joints.iter().map(u32::to_string).collect::<Vec<_>>().join(",");
        lines.push(Line::styled(
            format!(
                "{} {}{} for {:.1} s{}",
                if fault.active { "fault" } else { "last fault" },
                fault.name,
                if joints.is_empty() { String::new() } else { format!(" (joint {joints})") },
                fault.since_s,
                if fault.active { " — `vservoctl resume` once its cause is gone" } else { "" }
            ),
            if fault.active { Style::default().fg(Color::Red) } else { Style::default() },
        ));
    }
    frame.render_widget(Paragraph::new(lines).block(Block::bordered().title(" vservo ")), header);
}

/// One row per node: state, counters and loop timing.
fn draw_nodes(frame: &mut ratatui::Frame, nodes: ratatui::layout::Rect, view: &StatusView) {
    let rows = NodeRole::ALL.into_iter().filter_map(|role| {
        let node = view.nodes.get(role.name())?;
        Some(Row::new(vec![
            role.name().to_string(),
            node.state.to_string(),
            node.pid.to_string(),
            node.restarts.to_string(),
            node.cycles.to_string(),
            node.overruns.to_string(),
            node.rejected_messages.to_string(),
            timing(node.wake_latency_us),
            timing(node.execution_us),
            timing(node.round_trip_us.or(node.capture_latency_us)),
        ]))
    });
    let widths = [
        Constraint::Length(7),
        Constraint::Length(12),
        Constraint::Length(8),
        Constraint::Length(8),
        Constraint::Length(9),
        Constraint::Length(9),
        Constraint::Length(9),
        Constraint::Length(16),
        Constraint::Length(16),
        Constraint::Min(16),
    ];
    let header_row = Row::new(vec![
        "node", "state", "pid", "restarts", "cycles", "overruns", "refused", "wake µs", "exec µs", "trip µs",
    ])
    .style(Style::default().add_modifier(Modifier::BOLD));
    frame.render_widget(
        Table::new(rows, widths)
            .header(header_row)
            .block(Block::bordered().title(" nodes (timing: p50/p99/max over the last 0.1 s) ")),
        nodes,
    );
}

/// The servo's latest verdict and twist.
fn draw_servo(frame: &mut ratatui::Frame, servo: ratatui::layout::Rect, gathered: &Gathered) {
    let servo_line = match &gathered.twist {
        Some(t) => format!(
            "{}  frame {}  gains v{}  twist [{}]",
            verdict_name(t.verdict),
            t.frame,
            t.gains_version,
            t.twist.iter().map(|v| format!("{v:+.3}")).collect::<Vec<_>>().join(" ")
        ),
        None => "no twist yet".into(),
    };
    frame.render_widget(Paragraph::new(servo_line).block(Block::bordered().title(" servo ")), servo);
}

/// The feature error of each frame, newest right, on axes: frames ago and pixels.
fn draw_error_curve(frame: &mut ratatui::Frame, curve: ratatui::layout::Rect, gathered: &Gathered) {
    let points = error_points(&gathered.errors_px, usize::from(curve.width.saturating_sub(8)).max(2));
    let oldest = points.first().map_or(1.0, |p| -p.0).max(1.0);
    let largest = points.iter().map(|p| p.1).fold(0.0, f64::max).max(0.01);
    let dataset = Dataset::default()
        .marker(Marker::Braille)
        .graph_type(GraphType::Line)
        .style(Style::default().fg(Color::Cyan))
        .data(&points);
    let label = |text: String| Span::raw(text);
    let chart = Chart::new(vec![dataset])
        .block(Block::bordered().title(format!(" feature error per frame (largest {largest:.2} px) ")))
        .x_axis(Axis::default().title("frames ago").bounds([-oldest, 0.0]).labels([
            label(format!("{oldest:.0}")),
            label(format!("{:.0}", oldest / 2.0)),
            label("0".into()),
        ]))
        .y_axis(Axis::default().title("px").bounds([0.0, largest]).labels([
            label("0".into()),
            label(format!("{:.2}", largest / 2.0)),
            label(format!("{largest:.2}")),
        ]));
    frame.render_widget(chart, curve);
}

/// The newest `count` errors as (frames ago, negative; error px), oldest first; a frame without an error at 0.
fn error_points(errors_px: &VecDeque<f64>, count: usize) -> Vec<(f64, f64)> {
    let newest = errors_px.len();
    errors_px
        .iter()
        .enumerate()
        .skip(newest.saturating_sub(count))
        .map(|(i, e)| (i as f64 - (newest - 1) as f64, if e.is_finite() { *e } else { 0.0 }))
        .collect()
}

pub fn run(args: &TopArgs) -> anyhow::Result<()> {
    let connection = Connection::open(&args.instance)?;
    let no_daemon = || {
        anyhow::anyhow!(
            "no vservod of instance {:?} answered within 2 s (is it running, as the same user?)",
            connection.instance
        )
    };
    let status =
        wait_for(Duration::from_secs(2), || connection.subscriber::<DaemonStatusMsg>(Topic::Status).ok())
            .ok_or_else(no_daemon)?;
    let telemetry = connection.subscriber::<TelemetryMsg>(Topic::Telemetry)?;
    let twists = connection.subscriber::<CameraTwistMsg>(Topic::CameraTwist)?;
    let first = wait_for(Duration::from_secs(2), || status.newest_message(&mut 0)).ok_or_else(no_daemon)?;
    let mut gathered = Gathered {
        daemon: first,
        telemetry: [None; 4],
        twist: None,
        errors_px: VecDeque::with_capacity(HISTORY),
    };
    let refresh = Duration::from_secs_f64(args.refresh_s.max(0.02));

    let mut terminal = ratatui::try_init()?;
    let outcome = (|| -> anyhow::Result<()> {
        let mut refreshes = 0u64;
        loop {
            if let Some(daemon) = status.newest_message(&mut 0) {
                gathered.daemon = daemon;
            }
            telemetry.each_message(|sample| {
                if let Some(role) = NodeRole::from_index(sample.node)
                    && gathered.daemon.nodes[role as usize].pid == sample.pid
                {
                    gathered.telemetry[role as usize] = Some(sample);
                }
            });
            twists.each_message(|sample| {
                if gathered.errors_px.len() == HISTORY {
                    gathered.errors_px.pop_front();
                }
                gathered.errors_px.push_back(sample.feature_error_px);
                gathered.twist = Some(sample);
            });
            refreshes += 1;
            let view = StatusView::new(&connection.instance, &gathered.daemon, &gathered.telemetry);
            terminal.draw(|frame| draw(frame, &gathered, &view, refreshes))?;
            let until = Instant::now() + refresh;
            while let Some(left) = until.checked_duration_since(Instant::now()) {
                if !event::poll(left)? {
                    break;
                }
                if let Event::Key(key) = event::read()?
                    && key.kind == KeyEventKind::Press
                    && (matches!(key.code, KeyCode::Char('q') | KeyCode::Esc)
                        || (key.code == KeyCode::Char('c') && key.modifiers.contains(KeyModifiers::CONTROL)))
                {
                    return Ok(());
                }
            }
        }
    })();
    ratatui::restore();
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curve_holds_the_newest_errors_by_frames_ago_and_a_missing_one_at_zero() {
        let errors: VecDeque<f64> = [3.0, 2.0, f64::NAN, 0.5].into_iter().collect();
        assert_eq!(error_points(&errors, 3), vec![(-2.0, 2.0), (-1.0, 0.0), (0.0, 0.5)]);
        assert_eq!(error_points(&errors, 10).len(), 4);
        assert!(error_points(&VecDeque::new(), 5).is_empty());
    }
}
