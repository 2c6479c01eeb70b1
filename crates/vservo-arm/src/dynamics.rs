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

use crate::{DH_JOINTS, JointMatrix, JointVector, SerialArm};

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
        let sin_cos = self.joint_sin_cos(q);
        let mut forces = [Vector3::zeros(); DH_JOINTS];
        let mut moments = [Vector3::zeros(); DH_JOINTS];
        let mut omega = Vector3::zeros();
        let mut omega_dot = Vector3::zeros();
        // a base accelerating upwards is gravity pulling down
        let mut accel = -gravity_in_base;
        for (i, link) in self.dh_links().iter().enumerate() {
            let dh = &link.dh;
            let (s, c) = sin_cos[i];
            let origin = dh.origin_in_this();
            let joint_rate = z * qd[i];
            let new_omega = dh.express_in_this(c, s, &(omega + joint_rate));
            omega_dot = dh.express_in_this(c, s, &(omega_dot + z * qdd[i] + omega.cross(&joint_rate)));
            omega = new_omega;
            accel = omega_dot.cross(&origin)
                + omega.cross(&omega.cross(&origin))
                + dh.express_in_this(c, s, &accel);
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
        for i in (0..DH_JOINTS).rev() {
            let link = &self.links[i];
            let origin = link.dh.origin_in_this();
            let (child_force, child_moment) = if i + 1 < DH_JOINTS {
                let child = &self.links[i + 1].dh;
                let (s, c) = sin_cos[i + 1];
                (child.express_in_prev(c, s, &force), child.express_in_prev(c, s, &moment))
            } else {
                (force, moment)
            };
            moment = child_moment
                + origin.cross(&child_force)
                + (origin + link.inertia.com_in_link).cross(&forces[i])
                + moments[i];
            force = child_force + forces[i];
            tau[i] = moment.dot(&link.dh.joint_axis_in_this());
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
        // each joint's axis as a line: direction s and moment o × s
        let axes: [(Vector3<f64>, Vector3<f64>); DH_JOINTS] = std::array::from_fn(|j| {
            let (axis, point) = frames.joint_axis(j);
            (axis, point.cross(&axis))
        });
        let mut mass = JointMatrix::zeros();
        // the composite body of links j..n: mass, first moment and inertia about the base origin
        let mut composite_mass = 0.0;
        let mut first_moment = Vector3::zeros();
        let mut inertia_about_origin = SymmetricMatrix3::default();
        for j in (0..DH_JOINTS).rev() {
            let link = &self.links[j];
            let rotation = frames.rotations[j];
            let m = link.inertia.mass_kg;
            let com = frames.origins[j] + rotation * link.inertia.com_in_link;
            inertia_about_origin.add_rotated(&link.inertia.inertia_about_com, &rotation);
            inertia_about_origin.add_point_mass(m, &com);
            composite_mass += m;
            first_moment += com * m;
            // momentum of the composite turning at unit rate about joint j's axis (s_j through o_j):
            // linear p = s_j × (h − M o_j), angular about the base origin A = I_O s_j − h × (s_j × o_j)
            let (axis_j, point_j) = frames.joint_axis(j);
            let linear = axis_j.cross(&(first_moment - point_j * composite_mass));
            let angular = inertia_about_origin * axis_j - first_moment.cross(&axis_j.cross(&point_j));
            // the torque joint i needs for it: the axis line of joint i against the momentum
            for (i, (axis_i, moment_i)) in axes.iter().enumerate().take(j + 1) {
                let value = axis_i.dot(&angular) + moment_i.dot(&linear);
                mass[(i, j)] = value;
                mass[(j, i)] = value;
            }
        }
        mass
    }

    /// The mass matrix with the drives' armature inertia G²J_m on the diagonal.
    pub fn mass_matrix(&self, q: &JointVector) -> JointMatrix {
        let mut mass = self.mass_matrix_rigid(q);
        for (i, link) in self.dh_links().iter().enumerate() {
            mass[(i, i)] += link.drive.reflected_inertia();
        }
        mass
    }

    /// M(q) q̈ with the full model's mass matrix (armature included), over a DH arm's six joints.
    pub fn inertia_torque(&self, q: &JointVector, qdd: &JointVector) -> JointVector {
        let torque = self.mass_matrix(q) * qdd.fixed_rows::<DH_JOINTS>(0);
        let mut padded = JointVector::zeros();
        padded.fixed_rows_mut::<DH_JOINTS>(0).copy_from(&torque);
        padded
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
        for j in 0..DH_JOINTS {
            squared.set_column(
                j,
                &self.rne_rigid_with_gravity(q, &unit(j), &zero, &zero_g).fixed_rows::<DH_JOINTS>(0),
            );
        }
        let mut coriolis = JointMatrix::zeros();
        for j in 0..DH_JOINTS {
            for k in (j + 1)..DH_JOINTS {
                // from unit speeds on j and k: Γ_ijj + Γ_ikk + 2Γ_ijk
                let pair = unit(j) + unit(k);
                let tau = self.rne_rigid_with_gravity(q, &pair, &zero, &zero_g);
                let cross = (tau.fixed_rows::<DH_JOINTS>(0) - squared.column(j) - squared.column(k)) * 0.5;
                for i in 0..DH_JOINTS {
                    coriolis[(i, k)] += cross[i] * qd[j];
                    coriolis[(i, j)] += cross[i] * qd[k];
                }
            }
        }
        for j in 0..DH_JOINTS {
            for i in 0..DH_JOINTS {
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

/// M⁻¹ rhs over a DH arm's six joints (the seventh entry of the result zero).
fn solve_mass(mass: JointMatrix, rhs: JointVector) -> Result<JointVector, DynamicsError> {
    let cholesky = mass.cholesky().ok_or(DynamicsError::MassMatrixNotPositiveDefinite)?;
    let qdd = cholesky.solve(&rhs.fixed_rows::<DH_JOINTS>(0));
    if !qdd.iter().all(|v| v.is_finite()) {
        return Err(DynamicsError::NonFinite);
    }
    let mut padded = JointVector::zeros();
    padded.fixed_rows_mut::<DH_JOINTS>(0).copy_from(&qdd);
    Ok(padded)
}

/// A symmetric 3×3 matrix kept as its six distinct entries: the mass matrix's inertia sums touch half
/// the numbers a full `Matrix3` would.
#[derive(Debug, Clone, Copy, Default)]
struct SymmetricMatrix3 {
    xx: f64,
    yy: f64,
    zz: f64,
    xy: f64,
    yz: f64,
    xz: f64,
}

impl SymmetricMatrix3 {
    /// Adds `weight · v vᵀ`.
    #[inline(always)]
    fn add_outer(&mut self, weight: f64, v: &Vector3<f64>) {
        let w = v * weight;
        self.xx += w.x * v.x;
        self.yy += w.y * v.y;
        self.zz += w.z * v.z;
        self.xy += w.x * v.y;
        self.yz += w.y * v.z;
        self.xz += w.x * v.z;
    }

    /// Adds `R I Rᵀ`, an inertia tensor turned into the outer frame; the common diagonal `I` (principal
    /// axes along the link frame's) costs three outer products.
    #[inline]
    fn add_rotated(&mut self, inertia: &Matrix3<f64>, rotation: &Matrix3<f64>) {
        let off_diagonal_zero = inertia[(0, 1)] == 0.0 && inertia[(0, 2)] == 0.0 && inertia[(1, 2)] == 0.0;
        if off_diagonal_zero {
            for k in 0..3 {
                if inertia[(k, k)] != 0.0 {
                    self.add_outer(inertia[(k, k)], &rotation.column(k).into_owned());
                }
            }
        } else {
            let full = rotation * inertia * rotation.transpose();
            self.xx += full[(0, 0)];
            self.yy += full[(1, 1)];
            self.zz += full[(2, 2)];
            self.xy += full[(0, 1)];
            self.yz += full[(1, 2)];
            self.xz += full[(0, 2)];
        }
    }

    /// Adds the inertia of a point mass `m` at `p` about the origin: m(|p|²E − p pᵀ).
    #[inline(always)]
    fn add_point_mass(&mut self, m: f64, p: &Vector3<f64>) {
        let (x2, y2, z2) = (p.x * p.x, p.y * p.y, p.z * p.z);
        self.xx += m * (y2 + z2);
        self.yy += m * (x2 + z2);
        self.zz += m * (x2 + y2);
        self.xy -= m * p.x * p.y;
        self.yz -= m * p.y * p.z;
        self.xz -= m * p.x * p.z;
    }
}

impl std::ops::Mul<Vector3<f64>> for SymmetricMatrix3 {
    type Output = Vector3<f64>;
    #[inline(always)]
    fn mul(self, v: Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.xx * v.x + self.xy * v.y + self.xz * v.z,
            self.xy * v.x + self.yy * v.y + self.yz * v.z,
            self.xz * v.x + self.yz * v.y + self.zz * v.z,
        )
    }
}
