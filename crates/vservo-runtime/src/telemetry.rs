//! Loop telemetry: the hot loop hands each cycle's timings to a lock-free bounded channel and bumps
//! counters; a telemetry thread at normal priority turns them into percentiles and publishes a
//! [`TelemetryMsg`] every period. Nothing on the hot path allocates, locks or logs.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::thread::JoinHandle;

use crossbeam_channel::{Receiver, Sender, TrySendError};
use hdrhistogram::Histogram;
use vservo_protocol::{NodeRole, SCHEMA_VERSION, TelemetryMsg, TimingMsg, Topic};

use crate::RuntimeError;
use crate::clock::PeriodicTimer;
use crate::notes::NOTES_PER_PERIOD;
pub use crate::notes::Note;
use vservo_time::monotonic_ns;

/// Counters a node keeps since it started, shared with its telemetry thread.
#[derive(Debug, Default)]
pub struct Counters {
    /// Cycles run.
    pub cycles: AtomicU64,
    /// Cycles that started a period or more late (or, event driven, ran past their period).
    pub overruns: AtomicU64,
    /// Periods skipped after stalls.
    pub skipped_periods: AtomicU64,
    /// plant: answers from the rmrc that came late.
    pub late_answers: AtomicU64,
    /// Input messages refused.
    pub rejected_messages: AtomicU64,
    /// Gains version in use.
    pub gains_version: AtomicU64,
    /// See [`TelemetryMsg::progress`].
    pub progress: AtomicU64,
    /// See [`TelemetryMsg::mode`].
    pub mode: AtomicU32,
    /// The latest feature error (px), as f64 bits.
    pub feature_error_bits: AtomicU64,
    /// rmrc: times it re-synchronised to a new plant epoch (logged by the telemetry thread, not the loop).
    pub resyncs: AtomicU64,
    /// Notes the loop could not hand over (the channel full).
    pub notes_dropped: AtomicU64,
}

impl Counters {
    fn add(counter: &AtomicU64, n: u64) {
        counter.fetch_add(n, Ordering::Relaxed);
    }

    /// Counts an overrun.
    pub fn overrun(&self) {
        Self::add(&self.overruns, 1);
    }

    /// Counts skipped periods.
    pub fn skipped(&self, periods: u64) {
        Self::add(&self.skipped_periods, periods);
    }

    /// Counts a late answer.
    pub fn late_answer(&self) {
        Self::add(&self.late_answers, 1);
    }

    /// Counts a refused message.
    pub fn rejected(&self) {
        Self::add(&self.rejected_messages, 1);
    }

    /// Sets the progress value.
    pub fn set_progress(&self, value: u64) {
        self.progress.store(value, Ordering::Relaxed);
    }

    /// Sets the mode value.
    pub fn set_mode(&self, value: u32) {
        self.mode.store(value, Ordering::Relaxed);
    }

    /// Sets the gains version.
    pub fn set_gains_version(&self, value: u64) {
        self.gains_version.store(value, Ordering::Relaxed);
    }

    /// Counts a re-synchronisation to a new plant epoch.
    pub fn resynced(&self) {
        Self::add(&self.resyncs, 1);
    }

    /// Sets the feature error (px).
    pub fn set_feature_error_px(&self, value: f64) {
        self.feature_error_bits.store(value.to_bits(), Ordering::Relaxed);
    }
}

/// One cycle's timings (ns); zero where a timing does not apply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CycleSample {
    /// From the deadline (or the input's send time) to the wake-up.
    pub wake_latency_ns: u64,
    /// From the wake-up to the output.
    pub execution_ns: u64,
    /// plant: from publishing the state to the answer's arrival.
    pub round_trip_ns: u64,
    /// vision: from the previous image's capture to this one's.
    pub frame_period_ns: u64,
    /// servo: from the image's capture to the twist computed from it.
    pub capture_latency_ns: u64,
}

/// The hot loop's handle: record a cycle, bump a counter.
#[derive(Debug, Clone)]
pub struct LoopMonitor {
    samples: Sender<CycleSample>,
    notes: Sender<Note>,
    counters: Arc<Counters>,
}

impl LoopMonitor {
    /// Records one cycle. Never blocks: if the telemetry thread has fallen behind, the sample is dropped.
    pub fn record(&self, sample: CycleSample) {
        Counters::add(&self.counters.cycles, 1);
        if let Err(TrySendError::Full(_)) = self.samples.try_send(sample) {
            // the window's percentiles lose a sample; the counters stay exact
        }
    }

    /// Hands a note to the telemetry thread, which writes it. Never blocks: if 64 are waiting, it is
    /// dropped and counted in the thread's next summary.
    pub fn note(&self, note: Note) {
        if self.notes.try_send(note).is_err() {
            self.counters.notes_dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }
}

/// The telemetry thread of one node.
#[derive(Debug)]
pub struct TelemetryThread {
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl TelemetryThread {
    /// Starts the thread (call before the calling thread raises its own priority: threads inherit it).
    pub fn spawn(instance: &str, role: NodeRole, period_s: f64) -> Result<(Self, LoopMonitor), RuntimeError> {
        let (samples, receiver) = crossbeam_channel::bounded(8192);
        let (notes, notes_receiver) = crossbeam_channel::bounded(64);
        let counters = Arc::new(Counters::default());
        counters.set_feature_error_px(f64::NAN);
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = crossbeam_channel::bounded::<Result<(), RuntimeError>>(1);
        let (instance, thread_counters, thread_stop) = (instance.to_string(), counters.clone(), stop.clone());
        let period_ns = vservo_time::nanos(period_s);
        let handle = std::thread::Builder::new()
            .name(format!("{}-telemetry", role.name()))
            .spawn(move || {
                let publisher =
                    vservo_protocol::create_node(&instance, &format!("{}-telemetry", role.name())).and_then(
                        |node| {
                            vservo_protocol::publisher::<TelemetryMsg>(&node, &instance, Topic::Telemetry)
                                .map(|p| (node, p))
                        },
                    );
                match publisher {
                    Ok((_node, publisher)) => {
                        let _ = ready_tx.send(Ok(()));
                        let inputs =
                            Inputs { samples: &receiver, notes: &notes_receiver, counters: &thread_counters };
                        publish_loop(&publisher, role, period_ns, &inputs, &thread_stop);
                    }
                    Err(e) => {
                        let _ = ready_tx.send(Err(e.into()));
                    }
                }
            })
            .map_err(|e| RuntimeError::Thread(e.to_string()))?;
        match ready_rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e),
            Err(_) => {
                return Err(RuntimeError::Thread("the telemetry thread ended before it started".into()));
            }
        }
        Ok((Self { stop, handle: Some(handle) }, LoopMonitor { samples, notes, counters }))
    }
}

impl Drop for TelemetryThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(handle) = self.handle.take() {
            let _ = handle.join();
        }
    }
}

/// One histogram per timing of a [`TelemetryMsg`].
fn new_histograms() -> Option<[Histogram<u64>; 5]> {
    Some([new_histogram()?, new_histogram()?, new_histogram()?, new_histogram()?, new_histogram()?])
}

/// A histogram for loop timings (ns).
pub fn new_histogram() -> Option<Histogram<u64>> {
    // 1 ns to 60 s at three significant digits: allocated once
    Histogram::new_with_bounds(1, 60_000_000_000, 3).ok()
}

fn timing(histogram: &Histogram<u64>) -> TimingMsg {
    if histogram.is_empty() {
        return TimingMsg::default();
    }
    TimingMsg {
        count: histogram.len(),
        p50_ns: histogram.value_at_quantile(0.5),
        p99_ns: histogram.value_at_quantile(0.99),
        p999_ns: histogram.value_at_quantile(0.999),
        max_ns: histogram.max(),
    }
}

/// What the loop hands the telemetry thread.
struct Inputs<'a> {
    samples: &'a Receiver<CycleSample>,
    notes: &'a Receiver<Note>,
    counters: &'a Counters,
}

/// Writes the notes waiting: the first [`NOTES_PER_PERIOD`], then, if there were more, one line counting the
/// rest (those the loop dropped since `dropped_before` included) and the newest, so that the last line says
/// how things stand. Returns (notes written, notes counted in the summary).
fn write_notes(role: NodeRole, notes: &Receiver<Note>, dropped: u64, dropped_before: u64) -> (usize, u64) {
    let mut unwritten = dropped.saturating_sub(dropped_before);
    let mut written = 0;
    let mut newest_unwritten = None;
    for note in notes.try_iter() {
        if written < NOTES_PER_PERIOD {
            note.log();
            written += 1;
        } else if newest_unwritten.replace(note).is_some() {
            unwritten += 1;
        }
    }
    if unwritten > 0 {
        tracing::warn!(
            node = role.name(),
            "{unwritten} more changes in the last telemetry period, not written one by one; the latest:"
        );
    }
    if let Some(newest) = newest_unwritten {
        newest.log();
        written += 1;
    }
    (written, unwritten)
}

fn publish_loop(
    publisher: &iceoryx2::port::publisher::Publisher<iceoryx2::prelude::ipc::Service, TelemetryMsg, ()>,
    role: NodeRole,
    period_ns: u64,
    inputs: &Inputs<'_>,
    stop: &AtomicBool,
) {
    let (receiver, counters) = (inputs.samples, inputs.counters);
    let mut notes_dropped = 0;
    // wake latency, execution, round trip, frame period, capture latency: the window's and the whole run's
    const NAMES: [&str; 5] = ["wake_latency", "execution", "round_trip", "frame_period", "capture_latency"];
    let Some(mut window) = new_histograms() else { return };
    let Some(mut total) = new_histograms() else { return };
    let mut timer = PeriodicTimer::start(period_ns);
    let mut window_start = monotonic_ns();
    let pid = std::process::id();
    let mut resyncs_logged = 0;
    while !stop.load(Ordering::Relaxed) {
        timer.wait();
        let resyncs = counters.resyncs.load(Ordering::Relaxed);
        if resyncs != resyncs_logged {
            resyncs_logged = resyncs;
            tracing::info!(
                node = role.name(),
                resyncs,
                "following a new driver epoch (or a driver back after a gap) from its joints, at rest"
            );
        }
        let dropped = counters.notes_dropped.load(Ordering::Relaxed);
        let _ = write_notes(role, inputs.notes, dropped, notes_dropped);
        notes_dropped = dropped;
        for sample in receiver.try_iter() {
            window[0].saturating_record(sample.wake_latency_ns.max(1));
            window[1].saturating_record(sample.execution_ns.max(1));
            let optional = [sample.round_trip_ns, sample.frame_period_ns, sample.capture_latency_ns];
            for (histogram, value) in window[2..].iter_mut().zip(optional) {
                if value > 0 {
                    histogram.saturating_record(value);
                }
            }
        }
        let now = monotonic_ns();
        let message = TelemetryMsg {
            schema: SCHEMA_VERSION,
            node: role as u32,
            stamp_ns: now,
            window_ns: now - window_start,
            cycles: counters.cycles.load(Ordering::Relaxed),
            overruns: counters.overruns.load(Ordering::Relaxed),
            skipped_periods: counters.skipped_periods.load(Ordering::Relaxed),
            late_answers: counters.late_answers.load(Ordering::Relaxed),
            rejected_messages: counters.rejected_messages.load(Ordering::Relaxed),
            gains_version: counters.gains_version.load(Ordering::Relaxed),
            progress: counters.progress.load(Ordering::Relaxed),
            wake_latency: timing(&window[0]),
            execution: timing(&window[1]),
            round_trip: timing(&window[2]),
            frame_period: timing(&window[3]),
            capture_latency: timing(&window[4]),
            feature_error_px: f64::from_bits(counters.feature_error_bits.load(Ordering::Relaxed)),
            pid,
            mode: counters.mode.load(Ordering::Relaxed),
        };
        if let Ok(sample) = publisher.loan_uninit() {
            let _ = sample.write_payload(message).send();
        }
        for (sum, histogram) in total.iter_mut().zip(window.iter_mut()) {
            let _ = sum.add(&*histogram);
            histogram.reset();
        }
        window_start = now;
    }
    let _ = write_notes(role, inputs.notes, counters.notes_dropped.load(Ordering::Relaxed), notes_dropped);
    tracing::info!(
        node = role.name(),
        "loop totals {}",
        totals_json(&[
            (NAMES[0], &total[0]),
            (NAMES[1], &total[1]),
            (NAMES[2], &total[2]),
            (NAMES[3], &total[3]),
            (NAMES[4], &total[4]),
        ])
    );
}

/// Percentiles of whole-run histograms as one JSON object (ns): `{"name": {"count", "p50", "p99", "p999",
/// "max"}, …}`; scripts/latency.sh reads it from the log.
pub fn totals_json(histograms: &[(&str, &Histogram<u64>)]) -> String {
    let parts: Vec<String> = histograms
        .iter()
        .map(|(name, h)| {
            let t = timing(h);
            format!(
                "\"{name}\": {{\"count\": {}, \"p50\": {}, \"p99\": {}, \"p999\": {}, \"max\": {}}}",
                t.count, t.p50_ns, t.p99_ns, t.p999_ns, t.max_ns
            )
        })
        .collect();
    format!("{{{}}}", parts.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flood_of_notes_is_written_as_a_few_lines_and_a_count_and_the_loop_never_waits() {
        let (receiver, monitor) = {
            // the monitor alone, without a telemetry thread draining it
            let (samples, _) = crossbeam_channel::bounded(1);
            let (notes, receiver) = crossbeam_channel::bounded(64);
            (receiver, LoopMonitor { samples, notes, counters: Arc::new(Counters::default()) })
        };
        let note = Note::ServoVerdict {
            before: (vservo_protocol::Verdict::Servoing, 0),
            now: (vservo_protocol::Verdict::ServoingOnThree, 2),
            mark_status: [0, 5, 0, 0].map(|code| vservo_protocol::MarkStatus::try_from(code).ok()),
        };
        for _ in 0..100 {
            monitor.note(note);
        }
        let dropped = monitor.counters().notes_dropped.load(Ordering::Relaxed);
        assert_eq!(dropped, 36, "64 held, the rest dropped without waiting");
        let (written, counted) = write_notes(NodeRole::Servo, &receiver, dropped, 0);
        // the first four and the newest written, the rest counted
        assert_eq!((written, counted), (NOTES_PER_PERIOD + 1, 100 - NOTES_PER_PERIOD as u64 - 1));
        // the next period: nothing new
        assert_eq!(write_notes(NodeRole::Servo, &receiver, dropped, dropped), (0, 0));
    }
}
