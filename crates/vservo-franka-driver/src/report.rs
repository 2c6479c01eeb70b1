//! What the Franka driver counts and logs: cycles, late answers, refused commands, the robot's command success
//! rate, the state → command latencies, the jerk of what it sent, the reflexes; a line every 10 s and one JSON
//! line at the end (`franka-summary: {…}`, which scripts/run-franka-sim.sh reads).

use std::time::Duration;

use vservo_franka::{DroppedCounts, MotionPhase, RobotState};
use vservo_protocol::MAX_JOINTS;

use vservo_time::monotonic_ns;

/// How often the counts are logged (ns).
const REPORT_EVERY_NS: u64 = 10_000_000_000;

/// The state → command latencies are counted per microsecond up to this (µs); longer ones in the last bucket.
const LATENCY_BUCKETS_US: usize = 5000;

/// What the driver counts and logs.
pub(crate) struct Report {
    cycles: u64,
    pub(crate) late_answers: u64,
    pub(crate) commands_refused: u64,
    pub(crate) publish_failed: u64,
    /// Whether the period check's fault has been named in the log.
    pub(crate) period_said: bool,
    said: std::collections::BTreeSet<&'static str>,
    pub(crate) reflexes: Vec<String>,
    /// How often the robot went away (its connection closed), and how often it was connected again.
    pub(crate) connections_lost: u64,
    pub(crate) reconnections: u64,
    /// The lowest `control_command_success_rate` the robot reported (after its first 100 cycles).
    min_success_rate: f64,
    last_success_rate: f64,
    /// The rates reported after the first 100 cycles of each motion: their sum and count (for the mean).
    success_rate_sum: f64,
    success_rates: u64,
    latencies: Latencies,
    last_report_ns: u64,
    /// The velocities sent in the last two periods of this motion, and the largest jerk they made (rad/s³).
    pub(crate) last_sent: Option<([f64; MAX_JOINTS], Option<[f64; MAX_JOINTS]>)>,
    max_jerk_rad_s3: f64,
    said_loss_ns: u64,
    /// Robot states since the motion started (its first 100 report fewer commands than their window).
    motion_cycles: u64,
    /// The fastest joint's commanded speed when the stop came (rad/s).
    pub(crate) speed_at_stop_rad_s: Option<f64>,
    /// The UDP datagrams dropped (not the robot's, not a state, an id jump).
    dropped: DroppedCounts,
}

/// State → command latencies, counted per microsecond (no allocation per cycle).
struct Latencies {
    counts: Vec<u64>,
    total: u64,
}

impl Latencies {
    pub(crate) fn new() -> Self {
        Self { counts: vec![0; LATENCY_BUCKETS_US + 1], total: 0 }
    }

    fn push(&mut self, latency: Duration) {
        let us = (latency.as_micros() as usize).min(LATENCY_BUCKETS_US);
        self.counts[us] += 1;
        self.total += 1;
    }

    /// The nearest-rank `pct`-th percentile (µs; 0 with none).
    fn percentile_us(&self, pct: f64) -> usize {
        let rank = ((pct / 100.0 * self.total as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (us, count) in self.counts.iter().enumerate() {
            seen += count;
            if seen >= rank {
                return us;
            }
        }
        0
    }
}

impl std::fmt::Display for Latencies {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "p50 {} µs, p99 {} µs, max {} µs",
            self.percentile_us(50.0),
            self.percentile_us(99.0),
            self.percentile_us(100.0)
        )
    }
}

impl Report {
    pub(crate) fn new() -> Self {
        Self {
            cycles: 0,
            late_answers: 0,
            commands_refused: 0,
            publish_failed: 0,
            period_said: false,
            said: Default::default(),
            reflexes: Vec::new(),
            connections_lost: 0,
            reconnections: 0,
            min_success_rate: 1.0,
            last_success_rate: 1.0,
            success_rate_sum: 0.0,
            success_rates: 0,
            latencies: Latencies::new(),
            last_report_ns: monotonic_ns(),
            last_sent: None,
            max_jerk_rad_s3: 0.0,
            said_loss_ns: 0,
            motion_cycles: 0,
            speed_at_stop_rad_s: None,
            dropped: DroppedCounts::default(),
        }
    }

    /// The connection's dropped datagrams: each kind said once in the log (as a warning: someone else is
    /// sending to the driver's port, or the robot's stream is not what it should be), all counted.
    pub(crate) fn datagrams(&mut self, dropped: &DroppedCounts) {
        if dropped.total() == self.dropped.total() {
            return;
        }
        if let Some(last) = dropped.last {
            let kind = match last {
                vservo_franka::Dropped::Foreign { .. } => "foreign datagram",
                vservo_franka::Dropped::Malformed(_) => "malformed datagram",
                vservo_franka::Dropped::IdJump { .. } => "message_id jump",
            };
            if self.said.insert(kind) {
                tracing::warn!("dropped {last} (said once per kind; counted; the motion goes on)");
            }
        }
        self.dropped = *dropped;
    }

    /// A velocity sent: the jerk it makes with the two before (the robot's measure).
    pub(crate) fn sent(&mut self, velocity: &[f64; MAX_JOINTS], dt: f64) {
        let acceleration = self.last_sent.map(|(v, _)| std::array::from_fn(|j| (velocity[j] - v[j]) / dt));
        if let (Some(a), Some((_, Some(before)))) = (acceleration, self.last_sent) {
            let a: [f64; MAX_JOINTS] = a;
            for j in 0..MAX_JOINTS {
                self.max_jerk_rad_s3 = self.max_jerk_rad_s3.max(((a[j] - before[j]) / dt).abs());
            }
        }
        self.last_sent = Some((*velocity, acceleration));
    }

    /// A new motion: its commands start afresh from the robot's state.
    pub(crate) fn motion_started(&mut self) {
        self.last_sent = None;
        self.motion_cycles = 0;
    }

    pub(crate) fn cycle(&mut self, state: &RobotState, now_ns: u64) {
        self.cycles += 1;
        self.motion_cycles += 1;
        if MotionPhase::of(state) == MotionPhase::Running {
            // the first states of a motion report no commands yet
            let lost =
                state.control_command_success_rate < self.last_success_rate && self.motion_cycles > 100;
            if lost && self.said_loss_ns + REPORT_EVERY_NS <= now_ns {
                self.said_loss_ns = now_ns;
                tracing::warn!(
                    cycle = self.cycles,
                    success_rate = state.control_command_success_rate,
                    late_answers = self.late_answers,
                    "the robot missed a command of this driver's (said at most every 10 s)"
                );
            }
            self.last_success_rate = state.control_command_success_rate;
            if self.motion_cycles > 100 {
                self.min_success_rate = self.min_success_rate.min(state.control_command_success_rate);
                self.success_rate_sum += state.control_command_success_rate;
                self.success_rates += 1;
            }
        }
        if now_ns.saturating_sub(self.last_report_ns) >= REPORT_EVERY_NS {
            self.last_report_ns = now_ns;
            self.log("running");
        }
    }

    pub(crate) fn latency(&mut self, latency: Duration) {
        self.latencies.push(latency);
    }

    pub(crate) fn refused(&mut self, refused: vservo_driver::CommandRefused) {
        self.commands_refused += 1;
        if self.said.insert(refused.kind()) {
            tracing::warn!("a joint command refused: {refused} (said once per kind; counted)");
        }
    }

    pub(crate) fn log(&self, what: &str) {
        tracing::info!(
            cycles = self.cycles,
            late_answers = self.late_answers,
            commands_refused = self.commands_refused,
            success_rate_min = self.min_success_rate,
            success_rate = self.last_success_rate,
            state_to_command = %self.latencies,
            "franka: {what}"
        );
    }

    /// One JSON line for scripts (scripts/run-franka-sim.sh): `franka-summary: {…}`.
    pub(crate) fn summary_line(&self) {
        let reflexes: Vec<String> = self.reflexes.iter().map(|r| format!("{r:?}")).collect();
        eprintln!(
            "franka-summary: {{\"cycles\": {}, \"late_answers\": {}, \"commands_refused\": {}, \
             \"min_control_command_success_rate\": {}, \"mean_control_command_success_rate\": {}, \
             \"reflex_errors\": [{}], \"state_to_command_p50_us\": {}, \
             \"state_to_command_p99_us\": {}, \"state_to_command_max_us\": {}, \"max_joint_jerk_rad_s3\": {}, \
             \"speed_at_stop_rad_s\": {}, \"datagrams_dropped\": {{\"foreign\": {}, \"malformed\": {}, \
             \"id_jumps\": {}}}, \"connections_lost\": {}, \"reconnections\": {}}}",
            self.cycles,
            self.late_answers,
            self.commands_refused,
            self.min_success_rate,
            if self.success_rates > 0 { self.success_rate_sum / self.success_rates as f64 } else { 1.0 },
            reflexes.join(", "),
            self.latencies.percentile_us(50.0),
            self.latencies.percentile_us(99.0),
            self.latencies.percentile_us(100.0),
            self.max_jerk_rad_s3,
            self.speed_at_stop_rad_s.unwrap_or(0.0),
            self.dropped.foreign,
            self.dropped.malformed,
            self.dropped.id_jumps,
            self.connections_lost,
            self.reconnections,
        );
    }
}
