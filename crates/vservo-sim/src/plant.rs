//! The simulated PUMA 560: full dynamics, or joints that follow the reference exactly.

use vservo_arm::{DH_JOINTS, DynamicsError, JointVector, SerialArm};
pub use vservo_settings::simulation::{KinematicFollows, KinematicResponse, PlantMode};

/// Fault flags, one bit per joint in each mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Faults {
    /// Joints outside their position range.
    pub position_limit: u8,
    /// Joints faster than their velocity limit.
    pub velocity_limit: u8,
    /// Joints whose commanded torque was cut to the limit.
    pub torque_saturated: u8,
    /// The dynamics could not be integrated (non-finite state); the plant stopped.
    pub integration_failed: bool,
}

impl Faults {
    /// Whether any limit is violated (saturation alone is not a fault of the arm).
    pub fn any_limit(&self) -> bool {
        self.position_limit != 0 || self.velocity_limit != 0 || self.integration_failed
    }
}

/// The plant's state after a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointState {
    /// Ticks so far.
    pub tick: u64,
    /// Joint angles (rad).
    pub q: JointVector,
    /// Joint velocities (rad/s).
    pub qd: JointVector,
    /// The torque applied during the last tick, after saturation (N·m).
    pub applied_torque: JointVector,
    /// Limits met.
    pub faults: Faults,
}

/// The plant.
#[derive(Debug, Clone)]
pub struct Plant {
    arm: SerialArm,
    mode: PlantMode,
    substeps: u32,
    kinematic: KinematicResponse,
    state: JointState,
}

impl Plant {
    /// A plant at rest at `q`; `substeps` RK4 steps per tick in the dynamic mode.
    pub fn new(arm: SerialArm, mode: PlantMode, substeps: u32, q: JointVector) -> Self {
        Self {
            arm,
            mode,
            substeps: substeps.max(1),
            kinematic: KinematicResponse::default(),
            state: JointState {
                tick: 0,
                q,
                qd: JointVector::zeros(),
                applied_torque: JointVector::zeros(),
                faults: Faults::default(),
            },
        }
    }

    /// The same plant with the kinematic mode's joints responding as `response` says.
    pub fn with_kinematic_response(mut self, response: KinematicResponse) -> Self {
        self.kinematic = response;
        self
    }

    /// The same plant with its tick counter starting at `tick` (a plant restarted where the arm stopped).
    pub fn starting_at_tick(mut self, tick: u64) -> Self {
        self.state.tick = tick;
        self
    }

    /// The arm model.
    pub fn arm(&self) -> &SerialArm {
        &self.arm
    }

    /// The mode.
    pub fn mode(&self) -> PlantMode {
        self.mode
    }

    /// The current state.
    pub fn state(&self) -> &JointState {
        &self.state
    }

    /// Advances by `dt_s` under `torque` (saturated at the limits, held for the whole tick).
    pub fn step_dynamic(&mut self, torque: &JointVector, dt_s: f64) -> &JointState {
        let applied = self.arm.saturate_torques(torque);
        let mut saturated = 0;
        for j in 0..DH_JOINTS {
            if applied[j] != torque[j] {
                saturated |= 1 << j;
            }
        }
        let h = dt_s / f64::from(self.substeps);
        let (mut q, mut qd) = (self.state.q, self.state.qd);
        let mut failed = false;
        for _ in 0..self.substeps {
            match rk4(&self.arm, &q, &qd, &applied, h) {
                Ok((q_next, qd_next)) => {
                    q = q_next;
                    qd = qd_next;
                }
                Err(_) => {
                    failed = true;
                    break;
                }
            }
        }
        if failed {
            // keep the last good state, stopped
            qd = JointVector::zeros();
            q = self.state.q;
        }
        self.finish(q, qd, applied, saturated, failed)
    }

    /// Advances by `dt_s` with the joints following the reference as the kinematic response says: with no
    /// lag, taking it exactly (position) or integrating its velocity; with a lag τ, through e^(−t/τ) over
    /// the tick, solved exactly for a reference held over it.
    pub fn step_kinematic(
        &mut self,
        q_reference: &JointVector,
        qd_reference: &JointVector,
        dt_s: f64,
    ) -> &JointState {
        let KinematicResponse { follows, lag_s } = self.kinematic;
        let (q0, qd0) = (self.state.q, self.state.qd);
        let (q, qd) = match (follows, lag_s > 0.0) {
            (KinematicFollows::Position, false) => (*q_reference, *qd_reference),
            (KinematicFollows::Position, true) => {
                let decay = (-dt_s / lag_s).exp();
                let q = q_reference + (q0 - q_reference) * decay;
                (q, (q - q0) / dt_s)
            }
            (KinematicFollows::Velocity, false) => (q0 + qd_reference * dt_s, *qd_reference),
            (KinematicFollows::Velocity, true) => {
                let decay = (-dt_s / lag_s).exp();
                let qd = qd_reference + (qd0 - qd_reference) * decay;
                (q0 + qd_reference * dt_s + (qd0 - qd_reference) * (lag_s * (1.0 - decay)), qd)
            }
        };
        self.finish(q, qd, JointVector::zeros(), 0, false)
    }

    fn finish(
        &mut self,
        q: JointVector,
        qd: JointVector,
        applied: JointVector,
        saturated: u8,
        failed: bool,
    ) -> &JointState {
        let mut faults =
            Faults { torque_saturated: saturated, integration_failed: failed, ..Faults::default() };
        for (j, link) in self.arm.joints().iter().enumerate() {
            if !link.limits.position_ok(q[j]) {
                faults.position_limit |= 1 << j;
            }
            if qd[j].is_nan() || qd[j].abs() > link.limits.velocity_max {
                faults.velocity_limit |= 1 << j;
            }
        }
        self.state = JointState { tick: self.state.tick + 1, q, qd, applied_torque: applied, faults };
        &self.state
    }
}

/// One classical Runge–Kutta step of (q, q̇)' = (q̇, q̈(q, q̇, τ)).
fn rk4(
    arm: &SerialArm,
    q: &JointVector,
    qd: &JointVector,
    tau: &JointVector,
    h: f64,
) -> Result<(JointVector, JointVector), DynamicsError> {
    let accel = |q: &JointVector, qd: &JointVector| arm.forward_dynamics(q, qd, tau);
    let a1 = accel(q, qd)?;
    let (q2, qd2) = (q + qd * (0.5 * h), qd + a1 * (0.5 * h));
    let a2 = accel(&q2, &qd2)?;
    let (q3, qd3) = (q + qd2 * (0.5 * h), qd + a2 * (0.5 * h));
    let a3 = accel(&q3, &qd3)?;
    let (q4, qd4) = (q + qd3 * h, qd + a3 * h);
    let a4 = accel(&q4, &qd4)?;
    let q_next = q + (qd + (qd2 + qd3) * 2.0 + qd4) * (h / 6.0);
    let qd_next = qd + (a1 + (a2 + a3) * 2.0 + a4) * (h / 6.0);
    Ok((q_next, qd_next))
}
