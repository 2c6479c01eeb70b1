//! The safe stop on the instance's safe-stop path (docs/PROTOCOL.md, "The safe-stop path"): one byte
//! written to the FIFO `safe_stop` in the instance's directory, which no client can crowd out (the `command`
//! service's 16 slots can all be held), then the daemon's status read until it shows the cell in a safe stop.

use std::time::{Duration, Instant};

use vservo_protocol::stop_path::{Asked, SafeStopPathError, ask_for_safe_stop};
use vservo_protocol::{DaemonState, DaemonStatusMsg, Fault, InstanceDir};
use vservo_time::monotonic_ns;

use crate::{Client, ClientError};

/// A safe stop the status confirmed.
#[derive(Debug, Clone, PartialEq)]
pub struct SafeStopped {
    /// The safe-stop path written to.
    pub path: std::path::PathBuf,
    /// Whether the byte was written now or joined requests already pending.
    pub asked: Asked,
    /// The fault the cell is held for (`requested` when this request stopped it).
    pub fault: Fault,
    /// Whether the cell was already held, for another reason or an earlier request, before this one.
    pub held_before: bool,
    /// From the request to the status that showed the safe stop.
    pub confirmed_after: Duration,
}

/// What one status says of a safe stop asked for at `asked_at_ns` (CLOCK_MONOTONIC).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopSeen {
    /// Not in a safe stop (yet).
    NotYet,
    /// In a safe stop latched at or after the request: this request's.
    Stopped(Fault),
    /// In a safe stop latched before the request.
    HeldBefore(Fault),
}

/// Judges one status.
pub fn judge(status: &DaemonStatusMsg, asked_at_ns: u64) -> StopSeen {
    if DaemonState::try_from(status.state) != Ok(DaemonState::SafeStop) {
        return StopSeen::NotYet;
    }
    let fault = Fault::try_from(status.fault).unwrap_or(Fault::None);
    if status.fault_since_ns >= asked_at_ns { StopSeen::Stopped(fault) } else { StopSeen::HeldBefore(fault) }
}

/// Asks instance `instance` for a safe stop on its safe-stop path, then waits up to `confirm_within` for
/// the status to show the cell in a safe stop. The stop itself needs no command slot and no iceoryx2 port;
/// only the confirmation reads the status ([`ClientError::SafeStopNotConfirmed`] when it could not).
pub fn safe_stop(instance: &str, confirm_within: Duration) -> Result<SafeStopped, ClientError> {
    let dir = InstanceDir::locate(instance).map_err(vservo_protocol::ProtocolError::from)?;
    let asked_at_ns = monotonic_ns();
    let started = Instant::now();
    let asked = match ask_for_safe_stop(&dir) {
        Ok(asked) => asked,
        // something else at the path (replaced by a process of the daemon's user): the daemon stops the cell
        // when it sees that and makes the FIFO again; ask over the command service too
        Err(SafeStopPathError::NotAFifo { .. }) => {
            Client::connect(instance)?.safe_stop_command()?;
            Asked::Now
        }
        Err(error) => return Err(error.into()),
    };
    let path = dir.safe_stop_path();
    let not_confirmed = |why: String| ClientError::SafeStopNotConfirmed {
        instance: instance.to_string(),
        path: path.clone(),
        waited: confirm_within,
        why,
    };
    let client = Client::connect(instance).map_err(|e| not_confirmed(e.to_string()))?;
    let subscriber = client
        .subscribe::<DaemonStatusMsg>(vservo_protocol::Topic::Status)
        .map_err(|e| not_confirmed(e.to_string()))?;
    let mut last = None;
    while started.elapsed() < confirm_within {
        while let Ok(Some(sample)) = subscriber.receive() {
            if let Ok(status) = vservo_protocol::inbox::accept(*sample) {
                last = Some(judge(&status, asked_at_ns));
            }
        }
        match last {
            Some(StopSeen::Stopped(fault)) | Some(StopSeen::HeldBefore(fault)) => {
                return Ok(SafeStopped {
                    path,
                    asked,
                    fault,
                    held_before: last != Some(StopSeen::Stopped(fault)),
                    confirmed_after: started.elapsed(),
                });
            }
            _ => std::thread::sleep(Duration::from_millis(5)),
        }
    }
    Err(not_confirmed(match last {
        None => "no status arrived".to_string(),
        Some(_) => "the status does not show a safe stop".to_string(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(state: DaemonState, fault: Fault, since_ns: u64) -> DaemonStatusMsg {
        DaemonStatusMsg {
            state: state.into(),
            fault: fault.into(),
            fault_since_ns: since_ns,
            ..DaemonStatusMsg::default()
        }
    }

    #[test]
    fn a_status_confirms_this_request_an_earlier_hold_or_nothing_yet() {
        let asked = 1_000;
        assert_eq!(judge(&status(DaemonState::Running, Fault::None, 0), asked), StopSeen::NotYet);
        assert_eq!(
            judge(&status(DaemonState::SafeStop, Fault::Requested, 1_050), asked),
            StopSeen::Stopped(Fault::Requested)
        );
        assert_eq!(
            judge(&status(DaemonState::SafeStop, Fault::TargetLost, 900), asked),
            StopSeen::HeldBefore(Fault::TargetLost)
        );
        // a fault latched in the same instant as the request is this request's
        assert_eq!(
            judge(&status(DaemonState::SafeStop, Fault::Requested, asked), asked),
            StopSeen::Stopped(Fault::Requested)
        );
    }
}
