//! Closed-form inverse kinematics of the PUMA 560 geometry (Paul & Zhang 1986), all eight solutions.
//!
//! The solution follows the Robotics Toolbox's `Puma560.ikine_a`: the waist from the wrist centre (left or
//! right arm), the shoulder and elbow from the arm's plane (elbow up or down), then the spherical wrist as
//! ZYZ Euler angles (wrist not flipped or flipped). The configuration codes are the toolbox's: `l`/`r`,
//! `u`/`d`, `n`/`f`.
//!
//! It applies to arms of the PUMA's form: a₁ = 0, α = (π/2, 0, −π/2, π/2, −π/2, 0), and a spherical wrist
//! whose centre is the tool origin (a₄ = a₅ = a₆ = d₅ = d₆ = 0). [`solve`] checks that first.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fmt;

use nalgebra::Matrix3;

use crate::{DH_JOINTS, JointVector, SerialArm, Transform, six_joints};

/// Left or right arm (shoulder on one side or the other of the waist axis).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Arm {
    /// The toolbox's `l`.
    Left,
    /// The toolbox's `r`.
    Right,
}

/// Elbow above or below the line from shoulder to wrist.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Elbow {
    /// The toolbox's `u`.
    Up,
    /// The toolbox's `d`.
    Down,
}

/// The two wrist solutions, related by q₄ + π, −q₅, q₆ + π.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Wrist {
    /// The toolbox's `n` (q₅ ≤ 0).
    NoFlip,
    /// The toolbox's `f` (q₅ ≥ 0).
    Flip,
}

/// One of the eight arm configurations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ArmConfig {
    /// Left or right arm.
    pub arm: Arm,
    /// Elbow up or down.
    pub elbow: Elbow,
    /// Wrist flipped or not.
    pub wrist: Wrist,
}

impl ArmConfig {
    /// All eight, in the toolbox's order: lun, luf, ldn, ldf, run, ruf, rdn, rdf.
    pub const ALL: [ArmConfig; 8] = {
        use Arm::*;
        use Elbow::*;
        use Wrist::*;
        const fn c(arm: Arm, elbow: Elbow, wrist: Wrist) -> ArmConfig {
            ArmConfig { arm, elbow, wrist }
        }
        [
            c(Left, Up, NoFlip),
            c(Left, Up, Flip),
            c(Left, Down, NoFlip),
            c(Left, Down, Flip),
            c(Right, Up, NoFlip),
            c(Right, Up, Flip),
            c(Right, Down, NoFlip),
            c(Right, Down, Flip),
        ]
    };

    /// The toolbox's three-letter code, for example `"lun"`.
    pub fn code(&self) -> &'static str {
        let index = ArmConfig::ALL.iter().position(|c| c == self).unwrap_or(0);
        ["lun", "luf", "ldn", "ldf", "run", "ruf", "rdn", "rdf"][index]
    }

    /// Parses a toolbox code such as `"rdf"`.
    pub fn from_code(code: &str) -> Option<ArmConfig> {
        ArmConfig::ALL.into_iter().find(|c| c.code() == code)
    }
}

impl fmt::Display for ArmConfig {
    /// `left-up-noflip` and so on.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let arm = match self.arm {
            Arm::Left => "left",
            Arm::Right => "right",
        };
        let elbow = match self.elbow {
            Elbow::Up => "up",
            Elbow::Down => "down",
        };
        let wrist = match self.wrist {
            Wrist::NoFlip => "noflip",
            Wrist::Flip => "flip",
        };
        write!(f, "{arm}-{elbow}-{wrist}")
    }
}

/// One configuration's solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolution {
    /// Which of the eight.
    pub config: ArmConfig,
    /// The joint angles, each in [−π, π), or `None` when the pose is out of this configuration's reach.
    pub q: Option<JointVector>,
    /// Whether some shift of the angles by multiples of 2π puts every joint inside its limits.
    pub within_limits: bool,
}

/// The eight solutions for one pose, in [`ArmConfig::ALL`] order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkSolutions(pub [IkSolution; 8]);

/// The solution picked near a reference configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearestSolution {
    /// Its configuration.
    pub config: ArmConfig,
    /// The joint angles, shifted by 2π where that brings them nearer the reference inside the limits.
    pub q: JointVector,
}

/// Why inverse kinematics could not be attempted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum IkError {
    /// The arm's DH parameters are not of the PUMA's form, so the closed form does not apply.
    #[error("closed-form IK needs a PUMA-like arm (a1 = 0, spherical wrist at the tool origin); {0} is not")]
    UnsupportedGeometry(&'static str),
    /// The pose holds NaN or infinity.
    #[error("the pose to solve for is not finite")]
    NonFinitePose,
}

impl IkSolutions {
    /// The solutions as a slice.
    pub fn iter(&self) -> impl Iterator<Item = &IkSolution> {
        self.0.iter()
    }

    /// The solution for a configuration.
    pub fn get(&self, config: ArmConfig) -> &IkSolution {
        let index = ArmConfig::ALL.iter().position(|c| *c == config).unwrap_or(0);
        &self.0[index]
    }

    /// Of the solutions that can be put inside the joint limits, the one nearest `reference` (Euclidean
    /// distance in joint space), each angle shifted by 2π where that keeps it inside the limits and brings
    /// it nearer the reference. `None` when no solution fits the limits.
    pub fn nearest(&self, arm: &SerialArm, reference: &JointVector) -> Option<NearestSolution> {
        self.0
            .iter()
            .filter_map(|solution| {
                let q = shift_into_limits(arm, &solution.q?, reference)?;
                Some((NearestSolution { config: solution.config, q }, (q - reference).norm()))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(solution, _)| solution)
    }
}

/// Shifts each angle by a multiple of 2π to the value inside its joint's limits nearest the reference;
/// `None` when some joint has no such value.
pub fn shift_into_limits(arm: &SerialArm, q: &JointVector, reference: &JointVector) -> Option<JointVector> {
    let mut shifted = *q;
    for j in 0..arm.joint_count() {
        let limits = &arm.links[j].limits;
        let mut best: Option<f64> = None;
        for k in -3..=3 {
            let candidate = q[j] + TAU * f64::from(k);
            if limits.position_ok(candidate)
                && best.is_none_or(|b| (candidate - reference[j]).abs() < (b - reference[j]).abs())
            {
                best = Some(candidate);
            }
        }
        shifted[j] = best?;
    }
    Some(shifted)
}

fn is_puma_like(arm: &SerialArm) -> Result<(), IkError> {
    if arm.geometry != crate::Geometry::Dh {
        return Err(IkError::UnsupportedGeometry(arm.name));
    }
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    let alphas = [FRAC_PI_2, 0.0, -FRAC_PI_2, FRAC_PI_2, -FRAC_PI_2, 0.0];
    let dh = arm.dh_links().map(|l| l.dh);
    if !dh.iter().zip(alphas).all(|(d, alpha)| close(d.alpha(), alpha)) {
        return Err(IkError::UnsupportedGeometry(arm.name));
    }
    let wrist_offsets = [dh[0].a(), dh[3].a(), dh[4].a(), dh[5].a(), dh[4].d(), dh[5].d()];
    if !wrist_offsets.iter().all(|&v| close(v, 0.0)) || close(dh[1].a(), 0.0) {
        return Err(IkError::UnsupportedGeometry(arm.name));
    }
    Ok(())
}

/// Wraps an angle into [−π, π), as the toolbox's `angdiff` does.
fn wrap(angle: f64) -> f64 {
    (angle + PI).rem_euclid(TAU) - PI
}

/// All eight closed-form solutions for the tool pose `base_from_tool`.
pub fn solve(arm: &SerialArm, base_from_tool: &Transform) -> Result<IkSolutions, IkError> {
    is_puma_like(arm)?;
    let p = base_from_tool.translation.vector;
    let rotation = base_from_tool.rotation.matrix();
    if !(p.iter().all(|v| v.is_finite()) && rotation.iter().all(|v| v.is_finite())) {
        return Err(IkError::NonFinitePose);
    }
    let solutions = ArmConfig::ALL.map(|config| {
        let q = solve_one(arm, &p, rotation, config);
        let within_limits = q.is_some_and(|q| {
            let middle = JointVector::from_fn(|j, _| {
                let l = &arm.links[j].limits;
                0.5 * (l.position_min + l.position_max)
            });
            shift_into_limits(arm, &q, &middle).is_some()
        });
        IkSolution { config, q, within_limits }
    });
    Ok(IkSolutions(solutions))
}

fn solve_one(
    arm: &SerialArm,
    wrist_centre: &nalgebra::Vector3<f64>,
    base_from_tool: &Matrix3<f64>,
    config: ArmConfig,
) -> Option<JointVector> {
    let dh = arm.dh_links().map(|l| l.dh);
    let (a2, a3, d1, d3, d4) = (dh[1].a(), dh[2].a(), dh[0].d(), dh[2].d(), dh[3].d());
    let (px, py) = (wrist_centre.x, wrist_centre.y);
    let pz = wrist_centre.z - d1;

    // waist: the arm plane is offset by d3 from the waist axis
    let radius = px.hypot(py);
    if radius < d3.abs() || radius == 0.0 {
        return None;
    }
    let q1 = match config.arm {
        Arm::Right => py.atan2(px) + (d3 / radius).asin(),
        Arm::Left => py.atan2(px) + PI - (d3 / radius).asin(),
    };

    // shoulder and elbow in the arm plane
    let mut elbow_sign = match config.elbow {
        Elbow::Up => 1.0,
        Elbow::Down => -1.0,
    };
    if config.arm == Arm::Left {
        elbow_sign = -elbow_sign;
    }
    let (s1, c1) = q1.sin_cos();
    let reach = px * c1 + py * s1;
    let distance = reach.hypot(pz);
    let cos_psi = (a2 * a2 - d4 * d4 - a3 * a3 + reach * reach + pz * pz) / (2.0 * a2 * distance);
    if !(-1.0..=1.0).contains(&cos_psi) {
        return None;
    }
    let q2 = pz.atan2(reach) + elbow_sign * cos_psi.acos();
    let (s2, c2) = q2.sin_cos();
    let num = c2 * reach + s2 * pz - a2;
    let den = c2 * pz - s2 * reach;
    let q3 = a3.atan2(d4) - num.atan2(den);
    let mut q = six_joints([wrap(q1), wrap(q2), wrap(q3), 0.0, 0.0, 0.0]);

    // the wrist: link3_from_tool = Rz(q4) Ry(−q5) Rz(q6), ZYZ Euler angles with the middle one negated
    let frames = arm.frames(&q);
    let r = frames.rotations[2].transpose() * base_from_tool;
    let eps = 20.0 * f64::EPSILON;
    let (phi, theta, psi) = if r[(0, 2)].abs() < eps && r[(1, 2)].abs() < eps {
        // wrist singular: only q4 + q6 is defined; the toolbox takes q4 = 0
        (0.0, r[(0, 2)].atan2(r[(2, 2)]), r[(1, 0)].atan2(r[(1, 1)]))
    } else {
        let phi = match config.wrist {
            Wrist::NoFlip => r[(1, 2)].atan2(r[(0, 2)]),
            Wrist::Flip => (-r[(1, 2)]).atan2(-r[(0, 2)]),
        };
        let (sp, cp) = phi.sin_cos();
        let theta = (cp * r[(0, 2)] + sp * r[(1, 2)]).atan2(r[(2, 2)]);
        let psi = (-sp * r[(0, 0)] + cp * r[(1, 0)]).atan2(-sp * r[(0, 1)] + cp * r[(1, 1)]);
        (phi, theta, psi)
    };
    q[3] = phi;
    q[4] = -theta;
    q[5] = psi;
    for j in 0..DH_JOINTS {
        q[j] -= dh[j].offset();
    }
    q.iter().all(|v| v.is_finite()).then_some(q)
}

impl SerialArm {
    /// All eight closed-form IK solutions of `base_from_tool`; see [`solve`].
    pub fn inverse_kinematics(&self, base_from_tool: &Transform) -> Result<IkSolutions, IkError> {
        solve(self, base_from_tool)
    }
}
