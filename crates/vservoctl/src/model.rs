//! `vservoctl model`: the configured arm's model evaluated at one joint state (the PUMA 560 of the default
//! configuration, or any arm a configuration gives: a DH table or a URDF). Every arm: its joints and limits,
//! forward kinematics (the tool and every link), the Jacobians and the manipulability; the PUMA 560 also its
//! dynamics and its closed-form inverse kinematics.

use anyhow::Result;
use clap::Args;
use serde_json::{Value, json};
use vservo_arm::{Geometry, JointVector, SerialArm, puma560};

use crate::UsageError;
use crate::config_arg::ConfigArg;
use crate::joint_args::parse_joint_vector;
use crate::output::{matrix_json, matrix_text, print_stdout, vector_json, vector_text};

/// Arguments of `vservoctl model`.
#[derive(Args)]
pub struct ModelArgs {
    /// The configuration whose arm to describe (default: the built-in PUMA 560).
    #[arg(long, value_name = "FILE")]
    config: Option<std::path::PathBuf>,
    /// Joint angles q1,…,qn in radians, one per joint of the arm, or (the PUMA 560) a named pose: qz, qr, qs, qn.
    #[arg(long, allow_hyphen_values = true)]
    q: String,
    /// Joint velocities q̇1,…,q̇n in rad/s (default zero).
    #[arg(long, allow_hyphen_values = true)]
    qd: Option<String>,
    /// Joint accelerations q̈1,…,q̈n in rad/s² (default zero).
    #[arg(long, allow_hyphen_values = true)]
    qdd: Option<String>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Everything the command reports, computed once for both output formats.
struct Report {
    q: JointVector,
    qd: JointVector,
    qdd: JointVector,
    arm: SerialArm,
    /// The PUMA 560 without armature and friction: its rigid-body dynamics (no other arm has dynamics).
    rigid: Option<SerialArm>,
}

/// Runs the command.
pub fn run(args: &ModelArgs) -> Result<()> {
    let arm = match &args.config {
        Some(file) => ConfigArg { config: file.clone() }.load()?.cell.arm,
        None => puma560::puma560(),
    };
    let is_puma = arm == puma560::puma560();
    let n = arm.joint_count();
    let q = parse_joint_vector("--q", &args.q, is_puma, n)?;
    let qd = args.qd.as_deref().map(|t| parse_joint_vector("--qd", t, false, n)).transpose()?;
    let qdd = args.qdd.as_deref().map(|t| parse_joint_vector("--qdd", t, false, n)).transpose()?;
    let (qd, qdd) = (qd.unwrap_or_default(), qdd.unwrap_or_default());
    arm.check_positions(&q).map_err(|v| UsageError(format!("--q: {v} (the {}'s range)", arm.name)))?;
    arm.check_velocities(&qd)
        .map_err(|v| UsageError(format!("--qd: {v} (the {}'s speed limit)", arm.name)))?;
    let report = Report { q, qd, qdd, rigid: is_puma.then(puma560::puma560_rigid), arm };
    if args.json {
        print_stdout(&format!("{}\n", report.json()?))?;
    } else {
        print_stdout(&report.text()?)?;
    }
    Ok(())
}

impl Report {
    /// The closed-form IK's solutions, for an arm that has one.
    fn ik(&self) -> Option<vservo_arm::IkSolutions> {
        self.arm.inverse_kinematics(&self.arm.base_from_tool(&self.q)).ok()
    }

    /// Each joint: its name (a URDF's, else "joint k"), range and speed limit.
    fn joints(&self) -> Vec<(String, vservo_arm::JointLimits)> {
        let names: Vec<String> = match &self.arm.geometry {
            Geometry::Chain(chain) => chain.joints.iter().map(|j| j.name.clone()).collect(),
            Geometry::Dh => (1..=self.arm.joint_count()).map(|k| format!("joint {k}")).collect(),
        };
        names.into_iter().zip(self.arm.limits()).collect()
    }

    /// The arm's joints of a joint vector (its slots past them left out of what is shown).
    fn arms_joints(&self, v: &JointVector) -> nalgebra::DVector<f64> {
        v.rows(0, self.arm.joint_count()).into_owned()
    }

    fn json(&self) -> Result<Value> {
        let (arm, q, qd, qdd) = (&self.arm, &self.q, &self.qd, &self.qdd);
        let (n, head) = (arm.joint_count(), |v: &JointVector| self.arms_joints(v));
        let joints: Vec<Value> = self
            .joints()
            .iter()
            .map(|(name, l)| {
                json!({"name": name, "range_rad": [l.position_min, l.position_max], "velocity_max_rad_s": l.velocity_max})
            })
            .collect();
        let links: Vec<Value> =
            arm.link_frames(q).iter().take(n).map(|frame| matrix_json(&frame.to_homogeneous())).collect();
        let ik: Option<Vec<Value>> = self.ik().map(|solutions| {
            solutions
                .iter()
                .map(|s| {
                    json!({
                        "config": s.config.to_string(),
                        "code": s.config.code(),
                        "q": s.q.as_ref().map(|q| vector_json(&head(q))),
                        "within_limits": s.within_limits,
                    })
                })
                .collect()
        });
        let (rigid, full) = match &self.rigid {
            Some(rigid) => (
                json!({
                    "inertia": matrix_json(&rigid.mass_matrix_rigid(q)),
                    "gravload": vector_json(&head(&rigid.gravity_torque(q))),
                    "coriolis": matrix_json(&rigid.coriolis_matrix(q, qd)),
                    "rne": vector_json(&head(&rigid.rne_rigid(q, qd, qdd))),
                }),
                json!({
                    "inertia": matrix_json(&arm.mass_matrix(q)),
                    "rne": vector_json(&head(&arm.rne(q, qd, qdd))),
                }),
            ),
            None => (Value::Null, Value::Null),
        };
        Ok(json!({
            "robot": arm.name,
            "joints": joints,
            "links": links,
            "q": vector_json(&head(q)),
            "qd": vector_json(&head(qd)),
            "qdd": vector_json(&head(qdd)),
            "fkine": matrix_json(&arm.base_from_tool(q).to_homogeneous()),
            "jacob0": matrix_json(&arm.jacobian_base(q).columns(0, n)),
            "jacobe": matrix_json(&arm.jacobian_tool(q).columns(0, n)),
            "manipulability": arm.manipulability(q),
            "rigid": rigid,
            "full": full,
            "ik": ik,
        }))
    }

    fn text(&self) -> Result<String> {
        let (arm, q, qd, qdd) = (&self.arm, &self.q, &self.qd, &self.qdd);
        let (n, head) = (arm.joint_count(), |v: &JointVector| self.arms_joints(v));
        let mut out = format!("{} — SI units (m, rad, s, kg, N·m)\n", arm.name);
        out += "joints (range, speed limit):\n";
        for (name, l) in self.joints() {
            out += &format!(
                "  {name:<16} [{:>9.4}, {:>9.4}] rad  {:.3} rad/s\n",
                l.position_min, l.position_max, l.velocity_max
            );
        }
        out += &vector_text("q", &head(q));
        out += &vector_text("qd", &head(qd));
        out += &vector_text("qdd", &head(qdd));
        out += &matrix_text("fkine (base_from_tool)", &arm.base_from_tool(q).to_homogeneous());
        out += "link origins (base frame, m; the last is the tool):\n";
        for (k, frame) in arm.link_frames(q).iter().take(n).enumerate() {
            let p = frame.translation.vector;
            out += &format!("  link {}: [{:>9.4}, {:>9.4}, {:>9.4}]\n", k + 1, p.x, p.y, p.z);
        }
        out += &matrix_text("jacob0 (base frame, rows [v; w])", &arm.jacobian_base(q).columns(0, n));
        out += &matrix_text("jacobe (tool frame, rows [v; w])", &arm.jacobian_tool(q).columns(0, n));
        out += &format!("manipulability: {:.6}\n", arm.manipulability(q));
        match &self.rigid {
            Some(rigid) => {
                out += "rigid body (no armature, no friction):\n";
                out += &matrix_text("  inertia", &rigid.mass_matrix_rigid(q));
                out += &vector_text("  gravload", &head(&rigid.gravity_torque(q)));
                out += &matrix_text("  coriolis", &rigid.coriolis_matrix(q, qd));
                out += &vector_text("  rne", &head(&rigid.rne_rigid(q, qd, qdd)));
                out += "full model (with motor armature G²Jm and friction):\n";
                out += &matrix_text("  inertia", &arm.mass_matrix(q));
                out += &vector_text("  rne", &head(&arm.rne(q, qd, qdd)));
            }
            None => out += "dynamics: none (a kinematic model, for a velocity- or position-commanded arm)\n",
        }
        match self.ik() {
            Some(solutions) => {
                out += "inverse kinematics of fkine (all 8 configurations):\n";
                for s in solutions.iter() {
                    let limits = if s.within_limits { "" } else { "  (outside the joint limits)" };
                    match &s.q {
                        Some(q) => {
                            out += &vector_text(&format!("  {} {:<15}", s.config.code(), s.config), &head(q));
                            out.pop();
                            out += limits;
                            out.push('\n');
                        }
                        None => out += &format!("  {} {:<15}: out of reach\n", s.config.code(), s.config),
                    }
                }
            }
            None => out += "inverse kinematics: numerical only (no closed form for this geometry)\n",
        }
        Ok(out)
    }
}
