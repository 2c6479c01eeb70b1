//! The jerk-limited reference: whatever twists, joint moves and stops come, on arms with published jerk limits
//! (config/arms/fr3.toml, seven joints; config/arms/ur5e.toml, six), and at their singularities, the joint
//! reference's velocity, acceleration and jerk, measured as a robot controller measures them (differences of the
//! commanded velocities, tick by tick), stay within each joint's limits.

use proptest::prelude::*;
use vservo_arm::JointVector;
use vservo_config::Config;
use vservo_control::Twist;
use vservo_sim::interpolator::Interpolator;

/// How far past a limit rounding may put a measured value (relative).
const ROUNDING: f64 = 1e-6;

fn config(arm: &str) -> Config {
    let path = format!("{}/../../config/arms/{arm}.toml", env!("CARGO_MANIFEST_DIR"));
    Config::load(&path).expect("the arm's configuration loads")
}

/// What a controller sees of the commanded velocities: the largest speed, acceleration and jerk per joint.
#[derive(Debug, Default)]
struct Measured {
    velocity: JointVector,
    acceleration: JointVector,
    jerk: JointVector,
    last_qd: JointVector,
    last_qdd: JointVector,
}

impl Measured {
    fn take(&mut self, qd: &JointVector, dt: f64) {
        let qdd = (qd - self.last_qd) / dt;
        let jerk = (qdd - self.last_qdd) / dt;
        for j in 0..qd.len() {
            self.velocity[j] = self.velocity[j].max(qd[j].abs());
            self.acceleration[j] = self.acceleration[j].max(qdd[j].abs());
            self.jerk[j] = self.jerk[j].max(jerk[j].abs());
        }
        self.last_qd = *qd;
        self.last_qdd = qdd;
    }

    /// Each joint within the limits of `config`'s arm (the reference's own, not a tolerance of the test's).
    fn assert_within(&self, config: &Config, what: &str) {
        self.assert_within_share(config, 1.0, what);
    }

    /// Each joint within `share` of the limits of `config`'s arm.
    fn assert_within_share(&self, config: &Config, share: f64, what: &str) {
        let i = &config.cell.interpolator;
        let jerk = i.jerk_limit.expect("the arm has jerk limits");
        for (j, limits) in config.cell.arm.limits().enumerate() {
            let over = |value: f64, limit: f64| value > share * limit * (1.0 + ROUNDING);
            assert!(!over(self.velocity[j], limits.velocity_max), "{what}: joint {} speed {self:?}", j + 1);
            assert!(
                !over(self.acceleration[j], i.acceleration_limit[j]),
                "{what}: joint {} accel {self:?}",
                j + 1
            );
            assert!(!over(self.jerk[j], jerk[j]), "{what}: joint {} jerk {self:?}", j + 1);
        }
    }
}

/// What the cell asks of the interpolator during one vision period.
#[derive(Debug, Clone)]
enum Ask {
    /// A camera twist (m/s, rad/s).
    Twist([f64; 6]),
    /// Nothing new: the last twist is held, then goes stale and the reference ramps to rest.
    Nothing,
    /// A joint move by these offsets from the desired pose, at this share of the speed limits.
    Move([f64; 7], f64),
    /// The joint move ends; twists again.
    EndMove,
}

fn ask() -> impl Strategy<Value = Ask> {
    prop_oneof![
        4 => prop::array::uniform6(-1.0..1.0f64).prop_map(|v| Ask::Twist([v[0], v[1], v[2], 3.0 * v[3], 3.0 * v[4], 3.0 * v[5]])),
        2 => Just(Ask::Nothing),
        1 => (prop::array::uniform7(-0.3..0.3f64), 0.05..1.0f64).prop_map(|(d, s)| Ask::Move(d, s)),
        1 => Just(Ask::EndMove),
    ]
}

/// Runs `asks` one vision period each from `q`, measuring every tick's reference.
fn run(config: &Config, q: JointVector, asks: &[Ask]) -> (Measured, Interpolator) {
    let settings = config.cell.interpolator;
    let dt = settings.control_period_s;
    let ticks_per_frame = (settings.vision_period_s / dt).round() as u64;
    let mut interpolator = Interpolator::new(settings, config.cell.arm.clone(), config.cell.mount(), q);
    let mut measured = Measured::default();
    let mut tick = 0u64;
    for ask in asks {
        let now_s = tick as f64 * dt;
        match ask {
            Ask::Twist(v) => interpolator.set_twist(Twist::from_row_slice(v), now_s),
            Ask::Nothing => {}
            Ask::Move(offset, share) => {
                let joints = config.cell.arm.joint_count();
                let goal = JointVector::from_fn(|j, _| {
                    if j >= joints {
                        return 0.0;
                    }
                    let limits = config.cell.arm.links[j].limits;
                    (config.cell.desired.joints[j] + offset[j])
                        .clamp(limits.position_min + 0.02, limits.position_max - 0.02)
                });
                interpolator.move_joints_to(goal, *share);
            }
            Ask::EndMove => interpolator.end_joint_move(),
        }
        for _ in 0..ticks_per_frame {
            tick += 1;
            let reference = *interpolator.step(tick as f64 * dt);
            assert!(reference.q.iter().chain(reference.qd.iter()).all(|v| v.is_finite()), "{reference:?}");
            measured.take(&reference.qd, dt);
        }
    }
    // and to rest
    interpolator.end_joint_move();
    interpolator.set_twist(Twist::zeros(), tick as f64 * dt);
    for _ in 0..2000 {
        tick += 1;
        measured.take(&interpolator.step(tick as f64 * dt).qd, dt);
    }
    assert_eq!(interpolator.reference().qd, JointVector::zeros(), "at rest, exactly");
    (measured, interpolator)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn the_fr3_reference_keeps_its_limits_whatever_is_asked(asks in prop::collection::vec(ask(), 1..24)) {
        let config = config("fr3");
        let (measured, interpolator) = run(&config, config.cell.desired.joints, &asks);
        measured.assert_within(&config, "FR3");
        prop_assert_eq!(interpolator.motion_refusals(), 0);
    }

    #[test]
    fn the_ur5e_reference_keeps_its_limits_whatever_is_asked(asks in prop::collection::vec(ask(), 1..24)) {
        let config = config("ur5e");
        let (measured, interpolator) = run(&config, config.cell.desired.joints, &asks);
        measured.assert_within(&config, "UR5e");
        prop_assert_eq!(interpolator.motion_refusals(), 0);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, .. ProptestConfig::default() })]

    /// `[robot] speed_scale` = 0.25: whatever is asked, every joint keeps a quarter of its speed, acceleration
    /// and jerk limits.
    #[test]
    fn at_a_speed_scale_of_a_quarter_the_reference_keeps_a_quarter_of_the_limits(
        asks in prop::collection::vec(ask(), 1..16)
    ) {
        for arm in ["fr3", "ur5e"] {
            let mut config = config(arm);
            config.cell.interpolator.speed_scale = 0.25;
            let (measured, interpolator) = run(&config, config.cell.desired.joints, &asks);
            measured.assert_within_share(&config, 0.25, arm);
            prop_assert_eq!(interpolator.motion_refusals(), 0);
        }
    }
}

/// The scale lowered live while the arm moves fast: the reference slows within the arm's limits, and from then
/// on keeps the new share of them; raised again, it uses the whole.
#[test]
fn a_speed_scale_lowered_while_moving_slows_the_reference_within_the_limits() {
    let fr3 = config("fr3");
    let settings = fr3.cell.interpolator;
    let dt = settings.control_period_s;
    let mut interpolator =
        Interpolator::new(settings, fr3.cell.arm.clone(), fr3.cell.mount(), fr3.cell.desired.joints);
    let fast = Twist::new(0.2, -0.1, 0.1, 0.6, -0.4, 0.5);
    let (mut full, mut quarter) = (Measured::default(), Measured::default());
    let mut tick = 0u64;
    let mut steps = |interpolator: &mut Interpolator, ticks: u64, measured: &mut Measured| {
        for _ in 0..ticks {
            tick += 1;
            if tick.is_multiple_of(85) {
                interpolator.set_twist(fast, tick as f64 * dt);
            }
            measured.take(&interpolator.step(tick as f64 * dt).qd, dt);
        }
    };
    steps(&mut interpolator, 1000, &mut full);
    let fastest_before = full.velocity.amax();
    interpolator.set_speed_scale(0.25);
    assert_eq!(interpolator.speed_scale(), 0.25);
    // the slowing down, within the arm's limits (the generator brings the reference within the new ones)
    steps(&mut interpolator, 2000, &mut full);
    full.assert_within(&fr3, "slowing down");
    // from then on: a quarter (the measurement starts from the reference's state, not from rest)
    quarter.last_qd = full.last_qd;
    quarter.last_qdd = full.last_qdd;
    steps(&mut interpolator, 3000, &mut quarter);
    quarter.assert_within_share(&fr3, 0.25, "at a quarter");
    assert!(fastest_before > 0.3, "it moved fast before: {fastest_before} rad/s");
    assert!(quarter.velocity.amax() > 0.05, "and still moves: {quarter:?}");
    // out-of-range values are ignored
    interpolator.set_speed_scale(0.0);
    interpolator.set_speed_scale(f64::NAN);
    interpolator.set_speed_scale(1.5);
    assert_eq!(interpolator.speed_scale(), 0.25);
    interpolator.set_speed_scale(1.0);
    assert_eq!(interpolator.speed_scale(), 1.0);
}

/// At a singularity the damped inverse asks for large joint rates; the reference still keeps every limit: a UR5e
/// with its wrist straight (wrist 2 at zero: wrists 1 and 3 aligned) and an FR3 with its elbow stretched out.
#[test]
fn at_a_wrist_or_elbow_singularity_the_reference_keeps_its_limits() {
    let fast = Ask::Twist([0.2, -0.2, 0.1, 1.0, -1.0, 0.5]);
    let ur5e = config("ur5e");
    let mut wrist_straight = ur5e.cell.desired.joints;
    wrist_straight[4] = 0.0;
    let (measured, _) = run(&ur5e, wrist_straight, &[fast.clone(), fast.clone(), Ask::Nothing, fast.clone()]);
    measured.assert_within(&ur5e, "UR5e at its wrist singularity");
    assert!(measured.velocity.amax() > 0.1, "it moved: {measured:?}");
    let fr3 = config("fr3");
    let mut stretched = fr3.cell.desired.joints;
    stretched[3] = -0.16;
    let (measured, _) = run(&fr3, stretched, &[fast.clone(), fast, Ask::Nothing]);
    measured.assert_within(&fr3, "FR3 with its elbow stretched");
    assert!(measured.velocity.amax() > 0.1, "it moved: {measured:?}");
}

/// The limits are not met by standing still: a large step of the twist uses the jerk the arm allows, and the
/// tool's speed is held to the configured cap.
#[test]
fn a_step_uses_the_jerk_limit_and_the_tool_speed_is_capped() {
    let fr3 = config("fr3");
    let step = Ask::Twist([0.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let (measured, _) = run(&fr3, fr3.cell.desired.joints, &[step.clone(), step]);
    let jerk = fr3.cell.interpolator.jerk_limit.expect("jerk limits");
    let used = (0..7).map(|j| measured.jerk[j] / jerk[j]).fold(0.0, f64::max);
    assert!(used > 0.5, "the step ramps at the jerk limit: {used} of it");
    // the tool held to 0.25 m/s (the first motion's cap) though 0.5 m/s was asked
    let settings = fr3.cell.interpolator;
    let mut interpolator =
        Interpolator::new(settings, fr3.cell.arm.clone(), fr3.cell.mount(), fr3.cell.desired.joints);
    interpolator.set_twist(Twist::new(0.5, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
    let mut q = fr3.cell.desired.joints;
    for tick in 1..=60 {
        q = interpolator.step(tick as f64 * settings.control_period_s).q;
    }
    let before = fr3.cell.arm.base_from_tool(&q).translation.vector;
    for tick in 61..=70 {
        q = interpolator.step(tick as f64 * settings.control_period_s).q;
    }
    let speed = (fr3.cell.arm.base_from_tool(&q).translation.vector - before).norm()
        / (10.0 * settings.control_period_s);
    assert!(speed > 0.2 && speed <= 0.25 * 1.001, "the tool at {speed} m/s");
}

/// A joint move reaches its goal whatever the arm's jerk limit (a limit so high that the acceleration steps within
/// a tick, rounding included, does not make the move take its own reference for a faster motion to brake).
#[test]
fn a_joint_move_arrives_with_any_jerk_limit() {
    for jerk in [5000.0, 1e6] {
        let mut fr3 = config("fr3");
        fr3.cell.interpolator.jerk_limit = Some(JointVector::repeat(jerk));
        let settings = fr3.cell.interpolator;
        let start = JointVector::from([0.0, 0.0, 0.0, -1.57, 0.0, 1.57, 0.785]);
        let mut interpolator = Interpolator::new(settings, fr3.cell.arm.clone(), fr3.cell.mount(), start);
        interpolator.move_joints_to(fr3.cell.desired.joints, 0.3);
        let arrived = (1..=20_000).find(|tick| {
            interpolator.step(*tick as f64 * settings.control_period_s);
            interpolator.joint_move_arrived()
        });
        assert!(arrived.is_some_and(|tick| tick < 5000), "jerk {jerk}: arrived at {arrived:?}");
    }
}
