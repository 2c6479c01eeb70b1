//! The camera's frame counter and the frames lost on the way.
//!
//! A frame that never reached the driver shows as a gap: in the buffer offsets where the source numbers its
//! frames (`videotestsrc`, `v4l2src`: the frame's sequence number), else in the timestamps against the
//! nominal frame period (the caps' frame rate, or the configured vision period). Frames an appsink dropped
//! because the driver was late show the same way. The counter published in `camera_image` is the camera's:
//! it advances over the lost frames, so a reader sees the gap too.

/// What one frame adds to the count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameStep {
    /// The camera's counter for this frame (0 for the first).
    pub frame: u64,
    /// Frames lost just before this one.
    pub lost: u64,
}

/// Counts frames and gaps over a run.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FrameCounter {
    last: Option<Seen>,
    /// Frames lost on the way (gaps), over the run.
    pub lost: u64,
    /// Frames taken from the pipeline, over the run.
    pub taken: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Seen {
    frame: u64,
    offset: Option<u64>,
    pts_ns: Option<u64>,
}

/// The most frames one gap may count: beyond it the source restarted its numbering, not lost a day.
const MOST_LOST_PER_GAP: u64 = 1_000_000;

impl FrameCounter {
    /// Counts a frame with buffer `offset` (None: the source does not number frames) and timestamp
    /// `pts_ns`, for a nominal frame period of `period_ns`.
    pub fn count(&mut self, offset: Option<u64>, pts_ns: Option<u64>, period_ns: u64) -> FrameStep {
        let lost = self.last.map_or(0, |last| gap(last, offset, pts_ns, period_ns));
        let frame = self.last.map_or(0, |last| last.frame.saturating_add(1).saturating_add(lost));
        self.last = Some(Seen { frame, offset, pts_ns });
        self.lost = self.lost.saturating_add(lost);
        self.taken = self.taken.saturating_add(1);
        FrameStep { frame, lost }
    }
}

/// Frames missing between `last` and this frame: from the offsets when both have one, else from the
/// timestamps (a gap of about n periods lost n − 1 frames); none when neither tells, or numbering restarted.
fn gap(last: Seen, offset: Option<u64>, pts_ns: Option<u64>, period_ns: u64) -> u64 {
    let lost = match (last.offset, offset, last.pts_ns, pts_ns) {
        (Some(before), Some(now), _, _) => now.checked_sub(before).map_or(0, |d| d.saturating_sub(1)),
        (_, _, Some(before), Some(now)) if period_ns > 0 => now
            .checked_sub(before)
            .map_or(0, |d| (d.saturating_add(period_ns / 2) / period_ns).saturating_sub(1)),
        _ => 0,
    };
    if lost > MOST_LOST_PER_GAP { 0 } else { lost }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn consecutive_offsets_lose_nothing_and_count_from_zero() {
        let mut counter = FrameCounter::default();
        for (i, offset) in (100..105).enumerate() {
            assert_eq!(counter.count(Some(offset), None, 0), FrameStep { frame: i as u64, lost: 0 });
        }
        assert_eq!((counter.taken, counter.lost), (5, 0));
    }

    #[test]
    fn an_offset_gap_is_lost_frames_and_advances_the_counter() {
        let mut counter = FrameCounter::default();
        counter.count(Some(7), None, 0);
        assert_eq!(counter.count(Some(10), None, 0), FrameStep { frame: 3, lost: 2 });
        assert_eq!(counter.count(Some(11), None, 0), FrameStep { frame: 4, lost: 0 });
        assert_eq!(counter.lost, 2);
    }

    #[test]
    fn without_offsets_a_timestamp_gap_of_three_periods_lost_two() {
        let mut counter = FrameCounter::default();
        counter.count(None, Some(1_000_000), 85_000_000);
        assert_eq!(counter.count(None, Some(86_000_000), 85_000_000).lost, 0);
        // 2.9 periods and 3.1 periods both round to 3
        assert_eq!(counter.count(None, Some(86_000_000 + 246_500_000), 85_000_000).lost, 2);
        assert_eq!(counter.count(None, Some(86_000_000 + 246_500_000 + 263_500_000), 85_000_000).lost, 2);
    }

    #[test]
    fn nothing_to_tell_from_or_a_restart_counts_no_loss() {
        let mut counter = FrameCounter::default();
        counter.count(None, None, 85_000_000);
        assert_eq!(counter.count(None, None, 85_000_000), FrameStep { frame: 1, lost: 0 });
        counter.count(Some(50), None, 0);
        assert_eq!(counter.count(Some(3), None, 0).lost, 0, "numbering went back: a restart");
        assert_eq!(counter.count(Some(u64::MAX), None, 0).lost, 0, "beyond any plausible gap");
        assert_eq!(counter.count(None, Some(5), 0).lost, 0, "no period: no timestamp rule");
    }
}
