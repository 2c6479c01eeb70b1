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
    twist: Twist,
}

/// The link twist α, with the right angles that most arms use (the PUMA's are all 0 or ±π/2) kept apart:
/// Rx(α) is then a swap of two axes, with no arithmetic on the per-tick path.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Twist {
    Zero,
    PlusHalfPi,
    MinusHalfPi,
    General,
}

impl Twist {
    fn of(alpha: f64) -> Twist {
        use std::f64::consts::FRAC_PI_2;
        // only the exact values: anything else keeps its own sin and cos
        if alpha == 0.0 {
            Twist::Zero
        } else if alpha == FRAC_PI_2 {
            Twist::PlusHalfPi
        } else if alpha == -FRAC_PI_2 {
            Twist::MinusHalfPi
        } else {
            Twist::General
        }
    }
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
            twist: Twist::of(alpha),
        }
    }

    /// Rx(α)ᵀ applied to (y, z): the (y, z) of a vector re-expressed in the twisted frame.
    #[inline(always)]
    fn untwist(&self, y: f64, z: f64) -> (f64, f64) {
        match self.twist {
            Twist::Zero => (y, z),
            Twist::PlusHalfPi => (z, -y),
            Twist::MinusHalfPi => (-z, y),
            Twist::General => {
                let (ca, sa) = (self.cos_alpha, self.sin_alpha);
                (ca * y + sa * z, -sa * y + ca * z)
            }
        }
    }

    /// Rx(α) applied to (y, z).
    #[inline(always)]
    fn twist(&self, y: f64, z: f64) -> (f64, f64) {
        match self.twist {
            Twist::Zero => (y, z),
            Twist::PlusHalfPi => (-z, y),
            Twist::MinusHalfPi => (z, -y),
            Twist::General => {
                let (ca, sa) = (self.cos_alpha, self.sin_alpha);
                (ca * y - sa * z, sa * y + ca * z)
            }
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

    /// sin θ and cos θ of the joint angle θ = q + offset.
    ///
    /// `libm::sincos` shares one range reduction between the two: a third faster than `f64::sin_cos`
    /// (which calls sin and cos apart) on the per-tick path, and the same bits on every platform, which
    /// the lockstep simulator's bit-for-bit repeatability wants.
    #[inline]
    pub(crate) fn sin_cos_theta(&self, q: f64) -> (f64, f64) {
        libm::sincos(q + self.offset)
    }

    /// `v` in the previous frame's coordinates, re-expressed in this frame: Rx(α)ᵀ Rz(θ)ᵀ v.
    #[inline]
    pub(crate) fn express_in_this(&self, cos_theta: f64, sin_theta: f64, v: &Vector3<f64>) -> Vector3<f64> {
        let x = cos_theta * v.x + sin_theta * v.y;
        let y = -sin_theta * v.x + cos_theta * v.y;
        let (y, z) = self.untwist(y, v.z);
        Vector3::new(x, y, z)
    }

    /// `v` in this frame's coordinates, re-expressed in the previous frame: Rz(θ) Rx(α) v.
    #[inline]
    pub(crate) fn express_in_prev(&self, cos_theta: f64, sin_theta: f64, v: &Vector3<f64>) -> Vector3<f64> {
        let (y, z) = self.twist(v.y, v.z);
        Vector3::new(cos_theta * v.x - sin_theta * y, sin_theta * v.x + cos_theta * y, z)
    }

    /// The joint axis (z of the previous frame) in this frame's coordinates: `[0, sin α, cos α]`.
    #[inline]
    pub(crate) fn joint_axis_in_this(&self) -> Vector3<f64> {
        Vector3::new(0.0, self.sin_alpha, self.cos_alpha)
    }

    /// Turns the previous frame's axes (columns x, y, z in some outer frame) into this frame's, in place,
    /// and returns the step from the previous origin to this one in the same outer frame.
    #[inline]
    pub(crate) fn advance_axes(
        &self,
        cos_theta: f64,
        sin_theta: f64,
        axes: &mut [Vector3<f64>; 3],
    ) -> Vector3<f64> {
        let [x, y, z] = *axes;
        // Rz(θ)
        let x1 = x * cos_theta + y * sin_theta;
        let y1 = y * cos_theta - x * sin_theta;
        // Tz(d) Tx(a)
        let step = match (self.d_m == 0.0, self.a_m == 0.0) {
            (true, true) => Vector3::zeros(),
            (false, true) => z * self.d_m,
            (true, false) => x1 * self.a_m,
            (false, false) => z * self.d_m + x1 * self.a_m,
        };
        // Rx(α): the new y and z axes are combinations of y1 and z
        *axes = match self.twist {
            Twist::Zero => [x1, y1, z],
            Twist::PlusHalfPi => [x1, z, -y1],
            Twist::MinusHalfPi => [x1, -z, y1],
            Twist::General => {
                let (ca, sa) = (self.cos_alpha, self.sin_alpha);
                [x1, y1 * ca + z * sa, z * ca - y1 * sa]
            }
        };
        step
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
        Vector3::new(self.a_m, self.d_m * self.sin_alpha, self.d_m * self.cos_alpha)
    }

    /// `prev_from_this` at joint angle `q`.
    pub fn prev_from_this(&self, q: f64) -> Transform {
        let (s, c) = self.sin_cos_theta(q);
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

impl Link {
    /// A link that is not there: the slots of an arm's links past its joint count, and the DH, mass and
    /// drive of a chain's links (zero DH parameters, no mass, no drive, zero limits).
    pub const UNUSED: Link = Link {
        dh: DhParameters {
            a_m: 0.0,
            alpha: 0.0,
            d_m: 0.0,
            offset: 0.0,
            cos_alpha: 1.0,
            sin_alpha: 0.0,
            twist: Twist::Zero,
        },
        inertia: LinkInertia {
            mass_kg: 0.0,
            com_in_link: Vector3::new(0.0, 0.0, 0.0),
            inertia_about_com: Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        },
        drive: crate::Drive::NONE,
        limits: crate::JointLimits {
            position_min: 0.0,
            position_max: 0.0,
            velocity_max: 0.0,
            torque_max: 0.0,
        },
    };
}
