//! The daemon's side of the safe-stop path (`vservo_protocol::stop_path`): every supervisor cycle, the FIFO kept
//! the daemon's own, and the requests written to it taken.

use std::time::Instant;

use super::Daemon;
use crate::stop_path::BurstEvent;

impl Daemon {
    /// The safe-stop path replaced (by a process of the daemon's user: a plain file swallows every request): a
    /// safe stop, as if asked for on it, and the FIFO made again.
    fn keep_stop_path(&mut self) {
        if self.stop_path.intact() {
            return;
        }
        let path = self.stop_path.path().display().to_string();
        let already_held = self.safety.request_safe_stop_by_path().err().map(|held| held.to_string());
        let not_remade = self.stop_path.remake().err().map(|e| e.to_string());
        tracing::error!(
            path,
            already_held,
            not_remade,
            "the safe-stop path was replaced by something that is not this daemon's FIFO: a safe stop (requested), \
             and the FIFO made again"
        );
    }

    /// The safe-stop path: any byte asks for a safe stop (fault `requested`); logged once per burst.
    pub(super) fn hear_stop_path(&mut self, now: Instant) {
        self.keep_stop_path();
        let requests = self.stop_path.drain();
        let burst = self.stop_bursts.on_cycle(requests, now);
        let path = self.stop_path.path().display().to_string();
        if requests > 0 {
            let outcome = self.safety.request_safe_stop_by_path();
            if let (Some(BurstEvent::Began), Err(held)) = (burst, outcome) {
                tracing::warn!(path, "safe-stop path: a safe stop asked for, and {held}");
            }
        }
        if let Some(BurstEvent::Ended { requests }) = burst {
            tracing::info!(
                path,
                requests,
                "safe-stop path: a burst of requests ended (each one a safe stop)"
            );
        }
    }
}
