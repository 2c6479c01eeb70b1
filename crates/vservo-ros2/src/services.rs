//! The bridge's services: `vservo/safe_stop` (always taken) and `vservo/resume` (refused unless `[ros2]
//! allow_motion`), each request answered with what the daemon did or why not, and counted.

use std::time::Duration;

use vservo_client::Client;
use vservo_ros2::msg::{TriggerRequest, TriggerResponse};

use crate::graph::TriggerServer;

/// How long a safe stop waits for the daemon's status to show it.
const CONFIRM_SAFE_STOP_WITHIN: Duration = Duration::from_millis(500);

/// Requests by what came of them.
#[derive(Debug, Default, Clone, Copy)]
pub struct Counts {
    /// Done.
    pub done: u64,
    /// Refused: by the bridge (motion not allowed) or by the daemon.
    pub refused: u64,
    /// Unreadable (not a `std_srvs/Trigger` request) or not answered.
    pub bad: u64,
}

/// What the services need.
pub struct Services<'a> {
    pub client: &'a mut Client,
    pub instance: &'a str,
    pub allow_motion: bool,
    pub config_path: &'a std::path::Path,
    pub counts: &'a mut Counts,
}

impl Services<'_> {
    /// Answers every request waiting.
    pub fn serve(&mut self, safe_stop: &TriggerServer, resume: &TriggerServer) {
        self.serve_one(safe_stop, Self::safe_stop);
        self.serve_one(resume, Self::resume);
    }

    fn serve_one(&mut self, server: &TriggerServer, answer: fn(&mut Self) -> TriggerResponse) {
        loop {
            match server.receive_request() {
                Ok(Some((id, TriggerRequest { .. }))) => {
                    let response = answer(self);
                    if response.success {
                        self.counts.done += 1;
                    } else {
                        self.counts.refused += 1;
                    }
                    if let Err(error) = server.send_response(id, response) {
                        self.counts.bad += 1;
                        tracing::warn!(?error, "a service reply could not be sent");
                    }
                }
                Ok(None) => return,
                Err(error) => {
                    self.counts.bad += 1;
                    tracing::warn!(?error, "a service request was refused: not a std_srvs/Trigger request");
                }
            }
        }
    }

    /// Safe stop, on the instance's safe-stop path.
    fn safe_stop(&mut self) -> TriggerResponse {
        match vservo_client::safe_stop(self.instance, CONFIRM_SAFE_STOP_WITHIN) {
            Ok(stopped) => {
                tracing::warn!("safe stop asked for over ROS 2");
                let held = if stopped.held_before { "already held" } else { "held" };
                TriggerResponse {
                    success: true,
                    message: format!(
                        "safe stop: the arm is brought to rest and {held} (fault {}), confirmed after {:.0} ms",
                        stopped.fault.name(),
                        stopped.confirmed_after.as_secs_f64() * 1e3
                    ),
                }
            }
            Err(error) => TriggerResponse { success: false, message: format!("safe stop: {error}") },
        }
    }

    /// Resume, if the configuration lets the ROS graph move the arm.
    fn resume(&mut self) -> TriggerResponse {
        if !self.allow_motion {
            tracing::warn!("a resume over ROS 2 was refused: [ros2] allow_motion is off");
            return TriggerResponse {
                success: false,
                message: format!(
                    "refused: resume over ROS 2 is off ([ros2] allow_motion = false in {})",
                    self.config_path.display()
                ),
            };
        }
        match self.client.resume() {
            Ok(reply) => {
                tracing::info!(accepted = reply.accepted, reason = %reply.reason, "resume asked for over ROS 2");
                TriggerResponse { success: reply.accepted, message: reply.reason }
            }
            Err(error) => TriggerResponse { success: false, message: format!("resume: {error}") },
        }
    }
}
