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
    /// The parent's death could not be made a SIGTERM.
    #[error("prctl(PR_SET_PDEATHSIG): {0}")]
    DeathSignal(nix::Error),
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

/// For a process vservod started (a driver, the bridge, the viewer, with `--daemon-pid`): however the daemon
/// `daemon_pid` ends (SIGKILL included), this process gets SIGTERM, which sets `stop`; if the daemon has already
/// gone (this process's parent is another), `stop` is set at once. Call after [`stop_flag`].
pub fn end_with_daemon(daemon_pid: i32, stop: &AtomicBool) -> Result<(), SignalError> {
    nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGTERM).map_err(SignalError::DeathSignal)?;
    if nix::unistd::getppid().as_raw() != daemon_pid {
        stop.store(true, Ordering::Relaxed);
    }
    Ok(())
}

/// The shape of every driver's and helper's `main`: the stop flag set up first ([`stop_flag`]), a process vservod
/// started (`daemon_pid`) ended with it ([`end_with_daemon`]), then `work` run with the flag until it returns.
pub fn run_until_stopped<E: From<SignalError>>(
    daemon_pid: Option<i32>,
    work: impl FnOnce(&AtomicBool) -> Result<(), E>,
) -> Result<(), E> {
    let stop = stop_flag()?;
    if let Some(pid) = daemon_pid {
        end_with_daemon(pid, &stop)?;
    }
    work(&stop)
}

/// Whether the flag was set.
pub fn stopped(flag: &AtomicBool) -> bool {
    flag.load(Ordering::Relaxed)
}
