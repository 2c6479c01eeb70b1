//! systemd's notify protocol (sd_notify): READY, STATUS, WATCHDOG, STOPPING. Without NOTIFY_SOCKET every
//! call does nothing. Failures are logged once per kind, never fatal.

use std::time::Duration;

use sd_notify::NotifyState;

/// The daemon's link to systemd.
#[derive(Debug, Default)]
pub struct Systemd {
    ready_sent: bool,
    warned: bool,
    /// Half the watchdog interval systemd asked for, if it asked.
    pub watchdog_every: Option<Duration>,
}

impl Systemd {
    /// Reads WATCHDOG_USEC (the interval systemd expects keep-alives in).
    pub fn new() -> Self {
        let watchdog_every = sd_notify::watchdog_enabled().map(|interval| interval / 2);
        Self { ready_sent: false, warned: false, watchdog_every }
    }

    fn send(&mut self, states: &[NotifyState]) {
        if let Err(e) = sd_notify::notify(states)
            && !self.warned
        {
            self.warned = true;
            tracing::warn!("sd_notify failed ({e}); further failures are not logged");
        }
    }

    /// READY=1, once.
    pub fn ready(&mut self, status: &str) {
        if !self.ready_sent {
            self.ready_sent = true;
            self.send(&[NotifyState::Ready, NotifyState::Status(status)]);
        }
    }

    /// STATUS=…
    pub fn status(&mut self, status: &str) {
        self.send(&[NotifyState::Status(status)]);
    }

    /// WATCHDOG=1: only while the loops are healthy.
    pub fn watchdog(&mut self) {
        self.send(&[NotifyState::Watchdog]);
    }

    /// RELOADING=1 with MONOTONIC_USEC (systemd's reload protocol, for `Type=notify-reload` too).
    pub fn reloading(&mut self) {
        let usec = i128::from(vservo_time::monotonic_ns() / 1000);
        self.send(&[NotifyState::Reloading, NotifyState::MonotonicUsec(usec)]);
    }

    /// READY=1 after a reload, with what came of it.
    pub fn reloaded(&mut self, status: &str) {
        self.send(&[NotifyState::Ready, NotifyState::Status(status)]);
    }

    /// STOPPING=1.
    pub fn stopping(&mut self) {
        self.send(&[NotifyState::Stopping, NotifyState::Status("stopping: ramping the arm to rest")]);
    }
}
