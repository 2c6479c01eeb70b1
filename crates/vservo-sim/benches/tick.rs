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
        Interpolator::new(settings, arm.clone(), config.tool_from_camera, config.desired.joints);
    interpolator.set_twist(Twist::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.01), 0.0);
    let (law, kp, kv) = (config.joint_servo.law, config.joint_servo.kp, config.joint_servo.kv);
    let servo = JointServo::new(arm, law, kp, kv);
    let (q, qd) = (config.desired.joints, vservo_arm::JointVector::from_element(0.01));
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

criterion_group!(benches, tick);
criterion_main!(benches);
