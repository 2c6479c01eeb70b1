//! The bridge's services: `vservo/safe_stop` (always taken); `vservo/resume`, `vservo/set_target_features`
//! and `vservo/set_target_pose` (refused unless `[ros2] allow_motion`); each request answered with what the
//! daemon did or why not, and counted.

use std::time::Duration;

use ros2_client::{Message, Server};
use vservo_client::Client;
use vservo_ros2::msg::{SetTargetFeaturesRequest, SetTargetPoseRequest, SetTargetResponse, TriggerResponse};
use vservo_ros2::target;

use crate::graph::Graph;

/// How long a safe stop waits for the daemon's status to show it.
const CONFIRM_SAFE_STOP_WITHIN: Duration = Duration::from_millis(500);

/// The most requests of one service answered per look: a flood of requests waits in DDS (which keeps the
/// newest few) rather than stall the topics.
const REQUESTS_PER_LOOK: usize = 4;

/// Requests by what came of them.
#[derive(Debug, Default, Clone, Copy)]
pub struct Counts {
    /// Done.
    pub done: u64,
    /// Refused: by the bridge (motion not allowed) or by the daemon.
    pub refused: u64,
    /// Unreadable (not of the service's request type) or not answered.
    pub bad: u64,
}

/// What the services need.
pub struct Services<'a> {
    pub client: &'a mut Client,
    pub allow_motion: bool,
    pub config_path: &'a std::path::Path,
    pub counts: &'a mut Counts,
}

/// Whether a response says it was done.
trait Done {
    fn done(&self) -> bool;
}

impl Done for TriggerResponse {
    fn done(&self) -> bool {
        self.success
    }
}

impl Done for SetTargetResponse {
    fn done(&self) -> bool {
        self.accepted
    }
}

impl Services<'_> {
    /// Answers every request waiting.
    pub fn serve(&mut self, graph: &Graph) {
        self.serve_one(&graph.safe_stop, |s, _| s.safe_stop());
        self.serve_one(&graph.resume, |s, _| s.resume());
        self.serve_one(&graph.set_target_features, Self::set_target_features);
        self.serve_one(&graph.set_target_pose, Self::set_target_pose);
    }

    fn serve_one<Q: Message + 'static, A: Message + Done + 'static>(
        &mut self,
        server: &Server<Q, A>,
        answer: fn(&mut Self, Q) -> A,
    ) {
        for _ in 0..REQUESTS_PER_LOOK {
            match server.receive_request() {
                Ok(Some((id, request))) => {
                    let response = answer(self, request);
                    if response.done() {
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
                    tracing::warn!(?error, "a service request was refused: not of the service's type");
                }
            }
        }
    }

    /// Why a motion command is refused when the configuration does not allow it.
    fn motion_off(&self, what: &str) -> Option<String> {
        (!self.allow_motion).then(|| {
            tracing::warn!("{what} over ROS 2 was refused: [ros2] allow_motion is off");
            format!(
                "refused: {what} over ROS 2 is off ([ros2] allow_motion = false in {})",
                self.config_path.display()
            )
        })
    }

    /// ξ_d, if motion is allowed, checked by the daemon.
    fn set_target_features(&mut self, request: SetTargetFeaturesRequest) -> SetTargetResponse {
        if let Some(reason) = self.motion_off("a target") {
            return target::refusal(reason);
        }
        match self.client.set_target_features(target::features_in_vservo_px(&request.features_px)) {
            Ok(reply) => target::response(&reply),
            Err(error) => target::refusal(format!("target: {error}")),
        }
    }

    /// The camera's desired pose relative to the target, if motion is allowed, checked by the daemon.
    fn set_target_pose(&mut self, request: SetTargetPoseRequest) -> SetTargetResponse {
        if let Some(reason) = self.motion_off("a target") {
            return target::refusal(reason);
        }
        let (translation_m, rotation_rpy_rad) =
            match target::pose_as_translation_rpy(&request.camera_from_target) {
                Ok(pose) => pose,
                Err(refused) => return target::refusal(format!("refused: {refused}")),
            };
        match self.client.set_target_pose(translation_m, rotation_rpy_rad) {
            Ok(reply) => target::response(&reply),
            Err(error) => target::refusal(format!("target: {error}")),
        }
    }

    /// Safe stop, on the instance's safe-stop path.
    fn safe_stop(&mut self) -> TriggerResponse {
        match vservo_client::safe_stop(self.client.instance(), CONFIRM_SAFE_STOP_WITHIN) {
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
        if let Some(message) = self.motion_off("resume") {
            return TriggerResponse { success: false, message };
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
