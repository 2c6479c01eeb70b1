//! Speed of the arm model's per-tick functions: `cargo bench -p vservo-arm`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use vservo_arm::{puma560, six_joints};

fn arm_model(c: &mut Criterion) {
    let arm = puma560::puma560();
    let q = six_joints([0.3, 0.9, -2.6, 0.4, 0.7, -0.2]);
    let qd = six_joints([0.5, -0.4, 0.3, 1.0, -0.8, 0.6]);
    let qdd = six_joints([1.0, 2.0, -1.5, 3.0, 0.5, -2.0]);
    let tau = arm.rne(&q, &qd, &qdd);
    let pose = arm.base_from_tool(&q);

    c.bench_function("fkine", |b| b.iter(|| arm.base_from_tool(black_box(&q))));
    c.bench_function("jacob0", |b| b.iter(|| arm.jacobian_base(black_box(&q))));
    c.bench_function("rne", |b| b.iter(|| arm.rne(black_box(&q), black_box(&qd), black_box(&qdd))));
    c.bench_function("mass_matrix", |b| b.iter(|| arm.mass_matrix(black_box(&q))));
    c.bench_function("forward_dynamics", |b| {
        b.iter(|| arm.forward_dynamics(black_box(&q), black_box(&qd), black_box(&tau)))
    });
    c.bench_function("ik_all_8", |b| b.iter(|| arm.inverse_kinematics(black_box(&pose))));
}

criterion_group!(benches, arm_model);
criterion_main!(benches);
