//! Speed of the 1 ms path, interpolator plus joint servo: `cargo bench -p vservo-sim`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use vservo_arm::puma560;
use vservo_config::Config;
use vservo_control::Twist;
use vservo_sim::interpolator::{Interpolator, InterpolatorSettings};
use vservo_sim::joint_servo::JointServo;

fn tick(c: &mut Criterion) {
    let config =
        Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml").expect("valid");
    let arm = puma560::puma560();
    let settings = InterpolatorSettings::new(0.085, 0.001);
    let mut interpolator =
        Interpolator::new(settings, arm.clone(), config.cell.mount(), config.cell.desired.joints);
    interpolator.set_twist(Twist::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.01), 0.0);
    let (law, kp, kv) = (config.cell.joint_servo.law, config.cell.joint_servo.kp, config.cell.joint_servo.kv);
    let servo = JointServo::new(arm, law, kp, kv);
    let (q, qd) = (config.cell.desired.joints, vservo_arm::JointVector::from_element(0.01));
    let mut t = 0.0;
    c.bench_function("interpolator_and_joint_servo_tick", |b| {
        b.iter(|| {
            t += 0.001;
            if t > 0.15 {
                t = 0.0;
                interpolator.set_twist(Twist::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.01), 0.0);
            }
            let reference = *interpolator.step(t);
            servo.torque(black_box(&q), black_box(&qd), &reference)
        })
    });
}

/// The interpolator's tick alone (the rmrc's part that depends on the arm) for the PUMA 560 and for arms from
/// a URDF (PyBullet's pybullet_data, linked by scripts/setup.sh): the xArm6 (six joints, the same 6×6 path
/// as the PUMA) and the Panda (seven joints: the redundancy resolution with its null-space task), each on its
/// configuration's interpolator settings (their jerk limits among them: the jerk-limited reference); the UR5e and
/// the FR3 with and without their jerk limits (the cost of the trajectory generator).
fn interpolator_ticks(c: &mut Criterion) {
    for (name, file) in [
        ("interpolator_tick_puma560", "config/vservo.toml"),
        ("interpolator_tick_xarm6_urdf", "config/arms/xarm6.toml"),
        ("interpolator_tick_panda_urdf_7_joints", "config/arms/panda.toml"),
        ("interpolator_tick_ur5e_6_joints_jerk_limited", "config/arms/ur5e.toml"),
        ("interpolator_tick_fr3_7_joints_jerk_limited", "config/arms/fr3.toml"),
        ("interpolator_tick_ur5e_6_joints_acceleration_only", "config/arms/ur5e.toml"),
        ("interpolator_tick_fr3_7_joints_acceleration_only", "config/arms/fr3.toml"),
    ] {
        let mut config = Config::load(format!("{}/../../{file}", env!("CARGO_MANIFEST_DIR")))
            .expect("a valid configuration");
        // the same arm without its jerk limits: the acceleration-limited reference, for comparison
        if name.ends_with("acceleration_only") {
            config.cell.interpolator.jerk_limit = None;
        }
        let mut interpolator = Interpolator::new(
            config.cell.interpolator,
            config.cell.arm.clone(),
            config.cell.mount(),
            config.cell.desired.joints,
        );
        let twist = Twist::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.01);
        interpolator.set_twist(twist, 0.0);
        let dt = config.cell.timing.control_period_s;
        let mut t = 0.0;
        c.bench_function(name, |b| {
            b.iter(|| {
                t += dt;
                if t > 0.15 {
                    t = 0.0;
                    interpolator.set_twist(twist, 0.0);
                }
                *interpolator.step(t)
            })
        });
    }
}

criterion_group!(benches, tick, interpolator_ticks);
criterion_main!(benches);
