//! One link of the arm: its standard DH parameters, inertial data, drive and limits.

use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

use crate::{Drive, JointLimits, Transform};

/// Standard Denavit–Hartenberg parameters of one revolute joint and its link:
/// `prev_from_this = Rz(θ) · Tz(d) · Tx(a) · Rx(α)` with θ = q + offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DhParameters {
    a_m: f64,
    alpha: f64,
    d_m: f64,
    offset: f64,
    cos_alpha: f64,
    sin_alpha: f64,
}

impl DhParameters {
    /// Link length `a` (m), twist `α` (rad), offset along z `d` (m) and joint angle offset (rad).
    pub fn new(a_m: f64, alpha: f64, d_m: f64, offset: f64) -> Self {
        Self {
            a_m,
            alpha,
            d_m,
            offset,
            cos_alpha: alpha.cos(),
            sin_alpha: alpha.sin(),
        }
    }
    /// Link length a (m).
    pub fn a(&self) -> f64 {
        self.a_m
    }
    /// Link twist α (rad).
    pub fn alpha(&self) -> f64 {
        self.alpha
    }
    /// Link offset d (m).
    pub fn d(&self) -> f64 {
        self.d_m
    }
    /// Joint angle offset (rad), added to q.
    pub fn offset(&self) -> f64 {
        self.offset
    }

    /// The rotation of `prev_from_this` given cos θ and sin θ.
    #[inline]
    pub(crate) fn rotation(&self, cos_theta: f64, sin_theta: f64) -> Matrix3<f64> {
        let (ca, sa) = (self.cos_alpha, self.sin_alpha);
        Matrix3::new(
            cos_theta,
            -sin_theta * ca,
            sin_theta * sa,
            sin_theta,
            cos_theta * ca,
            -cos_theta * sa,
            0.0,
            sa,
            ca,
        )
    }

    /// The origin of this link's frame in the previous frame, given cos θ and sin θ.
    #[inline]
    pub(crate) fn origin_in_prev(&self, cos_theta: f64, sin_theta: f64) -> Vector3<f64> {
        Vector3::new(self.a_m * cos_theta, self.a_m * sin_theta, self.d_m)
    }

    /// The origin of this link's frame relative to the previous one, expressed in this link's frame
    /// (Luh–Walker–Paul's p*): `[a, d·sin α, d·cos α]`, independent of θ.
    #[inline]
    pub(crate) fn origin_in_this(&self) -> Vector3<f64> {
        Vector3::new(
            self.a_m,
            self.d_m * self.sin_alpha,
            self.d_m * self.cos_alpha,
        )
    }

    /// `prev_from_this` at joint angle `q`.
    pub fn prev_from_this(&self, q: f64) -> Transform {
        let (s, c) = (q + self.offset).sin_cos();
        Transform::from_parts(
            Translation3::from(self.origin_in_prev(c, s)),
            Rotation3::from_matrix_unchecked(self.rotation(c, s)),
        )
    }
}

/// Mass properties of a link, in the link's own DH frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkInertia {
    /// Mass (kg).
    pub mass_kg: f64,
    /// Centre of mass in the link frame (m).
    pub com_in_link: Vector3<f64>,
    /// Inertia tensor about the centre of mass, axes of the link frame (kg·m²).
    pub inertia_about_com: Matrix3<f64>,
}

impl LinkInertia {
    /// From the toolbox's notation: mass, centre of mass `r`, and `I = [Ixx, Iyy, Izz, Ixy, Iyz, Ixz]`.
    pub fn from_toolbox(mass_kg: f64, r: [f64; 3], i: [f64; 6]) -> Self {
        let [ixx, iyy, izz, ixy, iyz, ixz] = i;
        Self {
            mass_kg,
            com_in_link: Vector3::from(r),
            inertia_about_com: Matrix3::new(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz),
        }
    }
}

/// One link: geometry, mass, drive and limits of the joint that moves it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Standard DH parameters.
    pub dh: DhParameters,
    /// Rigid-body mass properties.
    pub inertia: LinkInertia,
    /// Motor, gearbox and friction of the joint.
    pub drive: Drive,
    /// Position, velocity and torque limits of the joint.
    pub limits: JointLimits,
}
