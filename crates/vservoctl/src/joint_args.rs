//! Parsing joint vectors from the command line: a comma-separated number per joint, or a named pose.

use vservo_arm::{JointVector, puma560};

use crate::UsageError;

/// Parses `q1,…,qn` (radians or rad/s…) for an arm of `joint_count` joints, or one of the PUMA 560's named
/// poses when `allow_named`.
pub fn parse_joint_vector(
    option: &str,
    text: &str,
    allow_named: bool,
    joint_count: usize,
) -> Result<JointVector, UsageError> {
    if let Some(q) = puma560::named_pose(text.trim()).filter(|_| allow_named) {
        return Ok(q);
    }
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != joint_count || joint_count > vservo_arm::MAX_JOINTS {
        let named = if allow_named { " or a named pose (qz, qr, qs, qn)" } else { "" };
        return Err(UsageError(format!(
            "{option}: expected {joint_count} comma-separated numbers{named}, got {} value(s) in {text:?}",
            parts.len()
        )));
    }
    let mut q = JointVector::zeros();
    for (i, part) in parts.iter().enumerate() {
        let value: f64 = part
            .parse()
            .map_err(|_| UsageError(format!("{option}: value {} ({part:?}) is not a number", i + 1)))?;
        if !value.is_finite() {
            return Err(UsageError(format!("{option}: value {} ({part:?}) is not finite", i + 1)));
        }
        q[i] = value;
    }
    Ok(q)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_six_numbers_and_named_poses() {
        let q = parse_joint_vector("--q", "0, 0.785, -3.5, 0, 0.785, 0", true, 6).expect("valid");
        assert_eq!(q[2], -3.5);
        assert_eq!(parse_joint_vector("--q", "qn", true, 6).expect("named"), puma560::QN);
    }

    #[test]
    fn refuses_wrong_count_words_and_nan_naming_the_option_and_value() {
        let e = parse_joint_vector("--qd", "1,2,3", false, 6).expect_err("count");
        assert!(e.0.contains("--qd") && e.0.contains("got 3"), "{e}");
        let e = parse_joint_vector("--q", "1,2,x,4,5,6", true, 6).expect_err("word");
        assert!(e.0.contains("value 3") && e.0.contains("\"x\""), "{e}");
        let e = parse_joint_vector("--q", "1,2,NaN,4,5,6", true, 6).expect_err("nan");
        assert!(e.0.contains("not finite"), "{e}");
        assert!(parse_joint_vector("--qd", "qn", false, 6).is_err());
        let seven = parse_joint_vector("--q", "1,2,3,4,5,6,7", false, 7).expect("a seven-joint arm's");
        assert_eq!(seven[6], 7.0);
        assert!(parse_joint_vector("--q", "1,2,3,4,5,6,7", false, 6).is_err());
    }
}
