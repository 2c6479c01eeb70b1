//! `vservoctl model`: the PUMA 560 model evaluated at one joint state.

use anyhow::Result;
use clap::Args;
use serde_json::json;
use vservo_arm::{JointVector, SerialArm, puma560};

use crate::UsageError;
use crate::joint_args::parse_joint_vector;
use crate::output::{matrix_json, matrix_text, print_stdout, vector_json, vector_text};

/// Arguments of `vservoctl model`.
#[derive(Args)]
pub struct ModelArgs {
    /// Joint angles q1,…,q6 in radians, or a named pose: qz, qr, qs, qn.
    #[arg(long, allow_hyphen_values = true)]
    q: String,
    /// Joint velocities q̇1,…,q̇6 in rad/s (default zero).
    #[arg(long, allow_hyphen_values = true)]
    qd: Option<String>,
    /// Joint accelerations q̈1,…,q̈6 in rad/s² (default zero).
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
    rigid: SerialArm,
}

/// Runs the command.
pub fn run(args: &ModelArgs) -> Result<()> {
    let arm = puma560::puma560();
    let q = parse_joint_vector("--q", &args.q, true)?;
    let qd = args.qd.as_deref().map(|t| parse_joint_vector("--qd", t, false)).transpose()?;
    let qdd = args.qdd.as_deref().map(|t| parse_joint_vector("--qdd", t, false)).transpose()?;
    let (qd, qdd) = (qd.unwrap_or_default(), qdd.unwrap_or_default());
    arm.check_positions(&q).map_err(|v| UsageError(format!("--q: {v} (the PUMA 560's range)")))?;
    arm.check_velocities(&qd).map_err(|v| UsageError(format!("--qd: {v} (the PUMA 560's speed limit)")))?;
    let report = Report { q, qd, qdd, arm, rigid: puma560::puma560_rigid() };
    if args.json {
        print_stdout(&format!("{}\n", report.json()?))?;
    } else {
        print_stdout(&report.text()?)?;
    }
    Ok(())
}

impl Report {
    fn ik(&self) -> Result<vservo_arm::IkSolutions> {
        Ok(self.arm.inverse_kinematics(&self.arm.base_from_tool(&self.q))?)
    }

    fn json(&self) -> Result<serde_json::Value> {
        let (arm, rigid, q, qd, qdd) = (&self.arm, &self.rigid, &self.q, &self.qd, &self.qdd);
        let ik: Vec<_> = self
            .ik()?
            .iter()
            .map(|s| {
                json!({
                    "config": s.config.to_string(),
                    "code": s.config.code(),
                    "q": s.q.as_ref().map(vector_json),
                    "within_limits": s.within_limits,
                })
            })
            .collect();
        Ok(json!({
            "robot": arm.name,
            "q": vector_json(q),
            "qd": vector_json(qd),
            "qdd": vector_json(qdd),
            "fkine": matrix_json(&arm.base_from_tool(q).to_homogeneous()),
            "jacob0": matrix_json(&arm.jacobian_base(q)),
            "jacobe": matrix_json(&arm.jacobian_tool(q)),
            "manipulability": arm.manipulability(q),
            "rigid": {
                "inertia": matrix_json(&rigid.mass_matrix_rigid(q)),
                "gravload": vector_json(&rigid.gravity_torque(q)),
                "coriolis": matrix_json(&rigid.coriolis_matrix(q, qd)),
                "rne": vector_json(&rigid.rne_rigid(q, qd, qdd)),
            },
            "full": {
                "inertia": matrix_json(&arm.mass_matrix(q)),
                "rne": vector_json(&arm.rne(q, qd, qdd)),
            },
            "ik": ik,
        }))
    }

    fn text(&self) -> Result<String> {
        let (arm, rigid, q, qd, qdd) = (&self.arm, &self.rigid, &self.q, &self.qd, &self.qdd);
        let mut out = format!("{} — SI units (m, rad, s, kg, N·m)\n", arm.name);
        out += &vector_text("q", q);
        out += &vector_text("qd", qd);
        out += &vector_text("qdd", qdd);
        out += &matrix_text("fkine (base_from_tool)", &arm.base_from_tool(q).to_homogeneous());
        out += &matrix_text("jacob0 (base frame, rows [v; w])", &arm.jacobian_base(q));
        out += &matrix_text("jacobe (tool frame, rows [v; w])", &arm.jacobian_tool(q));
        out += &format!("manipulability: {:.6}\n", arm.manipulability(q));
        out += "rigid body (no armature, no friction):\n";
        out += &matrix_text("  inertia", &rigid.mass_matrix_rigid(q));
        out += &vector_text("  gravload", &rigid.gravity_torque(q));
        out += &matrix_text("  coriolis", &rigid.coriolis_matrix(q, qd));
        out += &vector_text("  rne", &rigid.rne_rigid(q, qd, qdd));
        out += "full model (with motor armature G²Jm and friction):\n";
        out += &matrix_text("  inertia", &arm.mass_matrix(q));
        out += &vector_text("  rne", &arm.rne(q, qd, qdd));
        out += "inverse kinematics of fkine (all 8 configurations):\n";
        for s in self.ik()?.iter() {
            let limits = if s.within_limits { "" } else { "  (outside the joint limits)" };
            match &s.q {
                Some(q) => {
                    out += &vector_text(&format!("  {} {:<15}", s.config.code(), s.config), q);
                    out.pop();
                    out += limits;
                    out.push('\n');
                }
                None => out += &format!("  {} {:<15}: out of reach\n", s.config.code(), s.config),
            }
        }
        Ok(out)
    }
}
