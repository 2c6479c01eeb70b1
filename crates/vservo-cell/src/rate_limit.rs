//! What the arm of a cell follows of the servo's twist ([`vservo_control::twist_rate`]): the rate limit from its
//! Jacobian at the desired joints and the limits the rmrc keeps, and the lag the law predicts its motion
//! through.

use nalgebra::Vector6;
use vservo_arm::{MAX_JOINTS, SerialArm};
use vservo_config::CellConfig;
use vservo_control::twist_rate::{JointRatesPerTwist, MAX_LIMITED_JOINTS};
use vservo_control::{ArmResponse, JointDynamics, TwistRateLimit};
use vservo_sim::interpolator::LIMIT_MARGIN;

const _: () = assert!(MAX_JOINTS <= MAX_LIMITED_JOINTS, "every joint of an arm must be limited");

/// The arm's response for a cell whose reference keeps jerk limits:
/// - the rate limit: the interpolator's acceleration and jerk limits as the jerk-limited generator keeps them
///   ([`LIMIT_MARGIN`] inside), the ramp to complete within a vision period, at the configured speed scale;
/// - the lag: the arm's drives' (`plant.kinematic_lag_s`, which the arm files give as their arm's) and a quarter
///   of the vision period for the reference's ramp (a change the arm follows within the frame ramps over up to
///   all of it, the camera's displacement falling behind by up to half of it).
///
/// `None` when the arm's Jacobian at the desired joints has no inverse (a desired pose in a singularity: the
/// rmrc damps there) or a limit is not positive.
pub fn arm_response(config: &CellConfig, arm: &SerialArm) -> Option<ArmResponse> {
    let settings = &config.interpolator;
    let joint_rates = joint_rates_per_twist(config, arm)?;
    let kept = LIMIT_MARGIN;
    let dynamics: Vec<JointDynamics> = (0..arm.joint_count())
        .map(|j| JointDynamics {
            acceleration_rad_s2: settings.acceleration_limit[j] * kept * kept,
            jerk_rad_s3: settings.jerk_limit.map_or(f64::INFINITY, |jerk| jerk[j] * kept * kept * kept),
        })
        .collect();
    let period_s = settings.vision_period_s;
    let rate_limit = TwistRateLimit::new(&joint_rates, &dynamics, period_s).ok()?;
    Some(ArmResponse {
        rate_limit: rate_limit.at_speed_scale(settings.speed_scale),
        lag_s: config.plant.kinematic.lag_s + period_s / 4.0,
    })
}

/// The joints' speeds per camera twist at the desired joints: the camera's twist as the tool's (the mount),
/// through the least-squares inverse of the arm's Jacobian.
fn joint_rates_per_twist(config: &CellConfig, arm: &SerialArm) -> Option<JointRatesPerTwist> {
    let (base_from_tool, jacobian) = arm.base_from_tool_and_jacobian(&config.desired.joints);
    let inverse = jacobian.pseudo_inverse(1e-9).ok()?;
    let mount = config.mount();
    let mut rates = JointRatesPerTwist::zeros();
    for axis in 0..6 {
        let unit = Vector6::from_fn(|i, _| if i == axis { 1.0 } else { 0.0 });
        let joint_speeds = inverse * mount.tool_twist(&base_from_tool, &unit);
        for j in 0..arm.joint_count() {
            rates[(j, axis)] = joint_speeds[j];
        }
    }
    rates.iter().all(|r| r.is_finite()).then_some(rates)
}
