//! Rigid-body dynamics of the arm, and the drive terms on top of it.
//!
//! The equation of motion, with the toolbox's split of the motor terms:
//!
//! τ = M(q) q̈ + C(q, q̇) q̇ + g(q)  +  G²J_m q̈ + G²B q̇ + |G|·T_c(q̇)
//!     └──────── rigid body ───────┘  └────────── drive ──────────┘
//!
//! `*_rigid` functions compute the rigid-body part alone; the others add the [`Drive`](crate::Drive)
//! terms. An arm built with [`puma560_rigid`](crate::puma560::puma560_rigid) has no drive terms, so both
//! agree on it.

use nalgebra::{Matrix3, Vector3};

use crate::{JOINTS, JointMatrix, JointVector, SerialArm};

/// Why forward dynamics could not produce an acceleration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DynamicsError {
    /// The mass matrix was not positive definite (bad inertial data, or a non-finite state).
    #[error("the mass matrix is not positive definite at this configuration")]
    MassMatrixNotPositiveDefinite,
    /// The result held NaN or infinity (a non-finite state or torque).
    #[error("forward dynamics gave a non-finite acceleration (non-finite state or torque?)")]
    NonFinite,
}

impl SerialArm {
    /// Rigid-body inverse dynamics by recursive Newton–Euler (Luh, Walker & Paul), under a given
    /// gravity: the joint torques that give accelerations `qdd` at velocities `qd`.
    pub fn rne_rigid_with_gravity(
        &self,
        q: &JointVector,
        qd: &JointVector,
        qdd: &JointVector,
        gravity_in_base: &Vector3<f64>,
    ) -> JointVector {
        let z = Vector3::z();
        // outward: velocities and accelerations of each link, in its own frame
        let mut rotations = [Matrix3::identity(); JOINTS];
        let mut forces = [Vector3::zeros(); JOINTS];
        let mut moments = [Vector3::zeros(); JOINTS];
        let mut omega = Vector3::zeros();
        let mut omega_dot = Vector3::zeros();
        // a base accelerating upwards is gravity pulling down
        let mut accel = -gravity_in_base;
        for (i, link) in self.links.iter().enumerate() {
            let (s, c) = (q[i] + link.dh.offset()).sin_cos();
            let prev_from_this = link.dh.rotation(c, s);
            rotations[i] = prev_from_this;
            let this_from_prev = prev_from_this.transpose();
            let origin = link.dh.origin_in_this();
            let joint_rate = z * qd[i];
            let new_omega = this_from_prev * (omega + joint_rate);
            omega_dot = this_from_prev * (omega_dot + z * qdd[i] + omega.cross(&joint_rate));
            omega = new_omega;
            accel = omega_dot.cross(&origin)
                + omega.cross(&omega.cross(&origin))
                + this_from_prev * accel;
            let com = link.inertia.com_in_link;
            let com_accel = omega_dot.cross(&com) + omega.cross(&omega.cross(&com)) + accel;
            let inertia = link.inertia.inertia_about_com;
            forces[i] = com_accel * link.inertia.mass_kg;
            moments[i] = inertia * omega_dot + omega.cross(&(inertia * omega));
        }
        // inward: forces and moments each link exerts on the next, and the joint torques
        let mut tau = JointVector::zeros();
        let mut force = Vector3::zeros();
        let mut moment = Vector3::zeros();
        for i in (0..JOINTS).rev() {
            let link = &self.links[i];
            let origin = link.dh.origin_in_this();
            let (child_force, child_moment) = if i + 1 < JOINTS {
                (rotations[i + 1] * force, rotations[i + 1] * moment)
            } else {
                (force, moment)
            };
            moment = child_moment
                + origin.cross(&child_force)
                + (origin + link.inertia.com_in_link).cross(&forces[i])
                + moments[i];
            force = child_force + forces[i];
            // joint i turns about z of frame i-1, which in frame i is the last row of prev_from_this
            let r = &rotations[i];
            tau[i] = moment.x * r[(2, 0)] + moment.y * r[(2, 1)] + moment.z * r[(2, 2)];
        }
        tau
    }

    /// Rigid-body inverse dynamics under the arm's gravity: M q̈ + C q̇ + g.
    pub fn rne_rigid(&self, q: &JointVector, qd: &JointVector, qdd: &JointVector) -> JointVector {
        self.rne_rigid_with_gravity(q, qd, qdd, &self.gravity_in_base)
    }

    /// The drive torques alone: G²J_m q̈ + G²B q̇ + |G|·T_c(q̇), per joint.
    pub fn drive_torque(&self, qd: &JointVector, qdd: &JointVector) -> JointVector {
        JointVector::from_fn(|i, _| self.links[i].drive.torque(qd[i], qdd[i]))
    }

    /// Full inverse dynamics: the rigid body plus the drives' armature and friction.
    pub fn rne(&self, q: &JointVector, qd: &JointVector, qdd: &JointVector) -> JointVector {
        self.rne_rigid(q, qd, qdd) + self.drive_torque(qd, qdd)
    }

    /// The torque that holds the arm still against gravity, g(q).
    pub fn gravity_torque(&self, q: &JointVector) -> JointVector {
        let zero = JointVector::zeros();
        self.rne_rigid(q, &zero, &zero)
    }

    /// The rigid-body mass matrix M(q), by the composite rigid body algorithm in base coordinates.
    pub fn mass_matrix_rigid(&self, q: &JointVector) -> JointMatrix {
        let frames = self.frames(q);
        let mut mass = JointMatrix::zeros();
        // composite body of links j..n: its mass, first moment and inertia about the base origin
        let mut composite_mass = 0.0;
        let mut first_moment = Vector3::zeros();
        let mut inertia_about_origin = Matrix3::zeros();
        for j in (0..JOINTS).rev() {
            let link = &self.links[j];
            let rotation = frames.rotations[j];
            let m = link.inertia.mass_kg;
            let com = frames.origins[j] + rotation * link.inertia.com_in_link;
            let inertia = rotation * link.inertia.inertia_about_com * rotation.transpose();
            composite_mass += m;
            first_moment += com * m;
            inertia_about_origin += inertia + point_mass_inertia(m, &com);
            let (composite_com, composite_inertia) = if composite_mass > 0.0 {
                let c = first_moment / composite_mass;
                (
                    c,
                    inertia_about_origin - point_mass_inertia(composite_mass, &c),
                )
            } else {
                (Vector3::zeros(), inertia_about_origin)
            };
            let (axis_j, point_j) = joint_axis(&frames, j);
            let momentum = axis_j.cross(&(composite_com - point_j)) * composite_mass;
            let spin = composite_inertia * axis_j;
            for i in 0..=j {
                let (axis_i, point_i) = joint_axis(&frames, i);
                let angular_momentum = spin + (composite_com - point_i).cross(&momentum);
                let value = axis_i.dot(&angular_momentum);
                mass[(i, j)] = value;
                mass[(j, i)] = value;
            }
        }
        mass
    }

    /// The mass matrix with the drives' armature inertia G²J_m on the diagonal.
    pub fn mass_matrix(&self, q: &JointVector) -> JointMatrix {
        let mut mass = self.mass_matrix_rigid(q);
        for (i, link) in self.links.iter().enumerate() {
            mass[(i, i)] += link.drive.reflected_inertia();
        }
        mass
    }

    /// The Coriolis and centrifugal matrix C(q, q̇) built from the Christoffel symbols of M, so that
    /// C q̇ is the velocity term of the rigid-body dynamics and Ṁ − 2C is skew-symmetric.
    ///
    /// Computed as the toolbox does, from n(n+1)/2 Newton–Euler passes: fine for analysis, not for a 1 ms
    /// loop (use [`rne`](Self::rne) there).
    pub fn coriolis_matrix(&self, q: &JointVector, qd: &JointVector) -> JointMatrix {
        let zero_g = Vector3::zeros();
        let zero = JointVector::zeros();
        let unit = |j: usize| JointVector::from_fn(|k, _| if k == j { 1.0 } else { 0.0 });
        // torque from a single unit joint speed: the squared terms Γ_ijj
        let mut squared = JointMatrix::zeros();
        for j in 0..JOINTS {
            squared.set_column(j, &self.rne_rigid_with_gravity(q, &unit(j), &zero, &zero_g));
        }
        let mut coriolis = JointMatrix::zeros();
        for j in 0..JOINTS {
            for k in (j + 1)..JOINTS {
                // from unit speeds on j and k: Γ_ijj + Γ_ikk + 2Γ_ijk
                let pair = unit(j) + unit(k);
                let tau = self.rne_rigid_with_gravity(q, &pair, &zero, &zero_g);
                let cross = (tau - squared.column(j) - squared.column(k)) * 0.5;
                for i in 0..JOINTS {
                    coriolis[(i, k)] += cross[i] * qd[j];
                    coriolis[(i, j)] += cross[i] * qd[k];
                }
            }
        }
        for j in 0..JOINTS {
            for i in 0..JOINTS {
                coriolis[(i, j)] += squared[(i, j)] * qd[j];
            }
        }
        coriolis
    }

    /// Forward dynamics of the full model: the joint accelerations that torques `tau` give at (q, q̇),
    /// q̈ = M⁻¹(τ − C q̇ − g − friction), with M including the armature.
    pub fn forward_dynamics(
        &self,
        q: &JointVector,
        qd: &JointVector,
        tau: &JointVector,
    ) -> Result<JointVector, DynamicsError> {
        let bias = self.rne(q, qd, &JointVector::zeros());
        solve_mass(self.mass_matrix(q), tau - bias)
    }

    /// Forward dynamics of the rigid body alone (no armature, no friction).
    pub fn forward_dynamics_rigid(
        &self,
        q: &JointVector,
        qd: &JointVector,
        tau: &JointVector,
    ) -> Result<JointVector, DynamicsError> {
        let bias = self.rne_rigid(q, qd, &JointVector::zeros());
        solve_mass(self.mass_matrix_rigid(q), tau - bias)
    }
}

fn solve_mass(mass: JointMatrix, rhs: JointVector) -> Result<JointVector, DynamicsError> {
    let cholesky = mass
        .cholesky()
        .ok_or(DynamicsError::MassMatrixNotPositiveDefinite)?;
    let qdd = cholesky.solve(&rhs);
    if qdd.iter().all(|v| v.is_finite()) {
        Ok(qdd)
    } else {
        Err(DynamicsError::NonFinite)
    }
}

/// Inertia of a point mass `m` at `p` about the origin: m(|p|²E − p pᵀ).
#[inline]
fn point_mass_inertia(m: f64, p: &Vector3<f64>) -> Matrix3<f64> {
    (Matrix3::identity() * p.norm_squared() - p * p.transpose()) * m
}

/// The axis (unit, base frame) and a point on it for joint `j`: z and origin of frame j-1.
#[inline]
fn joint_axis(frames: &crate::kinematics::LinkFrames, j: usize) -> (Vector3<f64>, Vector3<f64>) {
    if j == 0 {
        (Vector3::z(), Vector3::zeros())
    } else {
        (
            frames.rotations[j - 1].column(2).into_owned(),
            frames.origins[j - 1],
        )
    }
}
