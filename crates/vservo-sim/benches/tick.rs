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

/// The 1 ms path's kinematics for arms from a URDF (PyBullet's pybullet_data, linked by scripts/setup.sh):
/// the xArm6 through the same interpolator as the PUMA, and the Panda's seven joints through forward
/// kinematics, the Jacobian and the redundancy resolution (the part of its tick that differs).
fn urdf_arms(c: &mut Criterion) {
    use vservo_arm::JointVector;
    use vservo_sim::redundancy::{Damping, NullSpaceTask, resolve};
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/pybullet_data");
    let config =
        Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/arms/xarm6.toml")).expect("valid");
    let settings = InterpolatorSettings::new(0.085, 0.001);
    let mut interpolator =
        Interpolator::new(settings, config.arm.clone(), config.tool_from_camera, config.desired.joints);
    let twist = Twist::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.01);
    interpolator.set_twist(twist, 0.0);
    let mut t = 0.0;
    c.bench_function("interpolator_tick_xarm6_urdf", |b| {
        b.iter(|| {
            t += 0.001;
            if t > 0.15 {
                t = 0.0;
                interpolator.set_twist(twist, 0.0);
            }
            *interpolator.step(t)
        })
    });

    let panda = vservo_arm::urdf::read(
        std::path::Path::new(&format!("{data}/franka_panda/panda.urdf")),
        None,
        Some("panda_link8"),
    )
    .expect("the Panda");
    let limits: Vec<vservo_arm::JointLimits> = panda
        .position_limits
        .iter()
        .zip(&panda.velocity_limits)
        .map(|(range, speed)| {
            let [low, high] = range.expect("ranges");
            vservo_arm::JointLimits {
                position_min: low,
                position_max: high,
                velocity_max: speed.expect("speed"),
                torque_max: 1.0,
            }
        })
        .collect();
    let q = JointVector::from_column_slice(&[2.9, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]);
    let damping = Damping { manipulability_threshold: 0.01, max_damping: 0.05 };
    let task = NullSpaceTask::default();
    let tool_twist = nalgebra::Vector6::new(0.01, -0.02, 0.005, 0.01, 0.0, -0.01);
    c.bench_function("redundant_rates_panda_7_joints", |b| {
        b.iter(|| {
            let frames = panda.chain.frames(black_box(q.as_slice()));
            resolve(&frames.jacobian_base(), &q, &limits, black_box(&tool_twist), &damping, &task)
        })
    });
}

criterion_group!(benches, tick, urdf_arms);
criterion_main!(benches);
