//! The daemon's word to its nodes: `cell_mode`, published on every change and at least every
//! [`CELL_MODE_EVERY`] as a heartbeat, so that a node can tell a daemon that stopped supervising (SIGSTOP, a
//! debugger, a frozen machine) from one that has nothing new to say.
//!
//! A node that hears no sealed `cell_mode` for [`DAEMON_SILENT_AFTER`] holds the arm as in a safe stop, on its
//! own; the daemon, finding on its next cycle that it slept that long, latches the fault
//! `supervision_stalled`, which only a resume on command ends (docs/PROTOCOL.md, "Safe stop").

use std::time::Duration;

/// The daemon publishes the cell mode at least this often, the same mode again when nothing changed.
pub const CELL_MODE_EVERY: Duration = Duration::from_millis(100);

/// No sealed `cell_mode` for this long: the daemon is not supervising. Ten heartbeats: a shared machine stalls
/// for a few hundred milliseconds now and then, which is no reason to stop a cell.
pub const DAEMON_SILENT_AFTER: Duration = Duration::from_secs(1);
