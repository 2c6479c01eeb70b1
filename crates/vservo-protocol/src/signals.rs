//! SIGINT and SIGTERM as a flag, for the instance's processes that run until stopped (`vservoctl record`,
//! `echo`, `view`, the camera driver, the ROS 2 bridge): they end cleanly on them, closing their files and
//! leaving no iceoryx2 resources of their node behind.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Why the flag could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SignalError {
    /// The signals could not be blocked.
    #[error("blocking SIGINT and SIGTERM: {0}")]
    Block(#[from] nix::Error),
    /// The thread that takes them could not be started.
    #[error("starting the signal thread: {0}")]
    Thread(#[from] std::io::Error),
}

/// A flag set on the first SIGINT or SIGTERM. The signals are blocked in this thread and every thread
/// started after it (iceoryx2's, GStreamer's, DDS's: call it first) and taken by one thread with sigwait, so
/// no handler of anyone else's replaces this.
pub fn stop_flag() -> Result<Arc<AtomicBool>, SignalError> {
    use nix::sys::signal::{SigSet, Signal};
    let stop = Arc::new(AtomicBool::new(false));
    let mut signals = SigSet::empty();
    signals.add(Signal::SIGINT);
    signals.add(Signal::SIGTERM);
    signals.thread_block()?;
    let flag = stop.clone();
    std::thread::Builder::new().name("signals".into()).spawn(move || {
        if signals.wait().is_ok() {
            flag.store(true, Ordering::Relaxed);
        }
    })?;
    Ok(stop)
}

/// Whether the flag was set.
pub fn stopped(flag: &AtomicBool) -> bool {
    flag.load(Ordering::Relaxed)
}
