//! The collision model's and the guard's cost: `cargo bench -p vservo-collision` (docs/BENCHMARKS.md, "The
//! collision guard"). The Panda of pybullet_data (its OBJ collision meshes as convex hulls; linked to
//! target/pybullet_data by scripts/setup.sh) with a scene of 10 obstacles around it.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Rotation3, Translation3};
use vservo_arm::{JointVector, Transform};
use vservo_collision::{
    BodyKind, BodySpec, BrakingLimits, CollisionModel, Guard, GuardSettings, Solid, arm_bodies,
    shape::shape_of,
};

const PANDA: &str =
    concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/pybullet_data/franka_panda/panda.urdf");

/// Ten obstacles around the Panda: a table under it, a wall, posts, a shelf and boxes, 5–40 cm from its
/// links at the bench's joint vector.
fn scene() -> Vec<BodySpec> {
    let solids: [(&str, Solid, [f64; 3]); 10] = [
        ("table", Solid::Box { size_m: [1.2, 1.2, 0.04] }, [0.3, 0.0, -0.03]),
        ("wall", Solid::Box { size_m: [0.05, 1.5, 1.2] }, [-0.45, 0.0, 0.6]),
        ("post left", Solid::Cylinder { radius_m: 0.04, length_m: 1.0 }, [0.4, 0.45, 0.5]),
        ("post right", Solid::Cylinder { radius_m: 0.04, length_m: 1.0 }, [0.4, -0.45, 0.5]),
        ("shelf", Solid::Box { size_m: [0.3, 0.6, 0.02] }, [0.75, 0.0, 0.8]),
        ("bin", Solid::Box { size_m: [0.2, 0.3, 0.15] }, [0.55, 0.25, 0.08]),
        ("fixture", Solid::Box { size_m: [0.1, 0.1, 0.2] }, [0.5, -0.2, 0.1]),
        ("lamp", Solid::Sphere { radius_m: 0.08 }, [0.2, 0.3, 1.1]),
        ("cable", Solid::Capsule { radius_m: 0.02, length_m: 0.6 }, [0.0, -0.35, 0.3]),
        ("floor", Solid::HalfSpace, [0.0, 0.0, -0.05]),
    ];
    solids
        .into_iter()
        .map(|(name, solid, at)| {
            let (shape, solid_from_shape) = shape_of(&solid).expect("a solid");
            BodySpec {
                name: name.to_string(),
                kind: BodyKind::Obstacle,
                carrier: 0,
                carrier_from_body: Transform::from_parts(
                    Translation3::new(at[0], at[1], at[2]),
                    Rotation3::identity(),
                ),
                shapes: vec![(shape, solid_from_shape)],
            }
        })
        .collect()
}

fn guard(c: &mut Criterion) {
    let read = vservo_arm::urdf::read(Path::new(PANDA), None, Some("panda_link8")).expect("the Panda");
    let mut bodies = arm_bodies(Path::new(PANDA), &read.chain).expect("its meshes");
    bodies.extend(scene());
    let disabled = [
        ["panda_link5".to_string(), "panda_link7".to_string()],
        ["panda_link5".to_string(), "panda_hand".to_string()],
    ];
    let model = CollisionModel::new(bodies, &disabled).expect("the model");
    println!("the Panda with 10 obstacles: {} pairs checked", model.pair_count());
    // the arm's kinematics only: the guard reads the placement of its links
    let any = vservo_arm::JointLimits {
        position_min: -3.0,
        position_max: 3.8,
        velocity_max: 2.6,
        torque_max: 87.0,
    };
    let arm = vservo_arm::SerialArm::from_chain("Panda", read.chain.clone(), &[any; 7]).expect("an arm");
    let q = vservo_arm::joint_vector(&[0.0, -0.5, 0.0, -2.4, 0.0, 2.0, 0.785]).expect("seven");
    let placement = arm.placement(&q);
    let carriers = &placement.carriers[..=placement.joint_count];

    let mut measured = model.clone();
    c.bench_function("collision_nearest_every_pair_panda_10_obstacles", |b| {
        b.iter(|| {
            measured.place(black_box(carriers));
            measured.nearest(f64::INFINITY)
        })
    });
    let settings = GuardSettings { slowdown_distance_m: 0.10, stop_distance_m: 0.03 };
    let mut guard = Guard::new(model, settings, None, Vec::new());
    let qd = JointVector::from_row_slice(&[0.3, -0.2, 0.1, 0.4, -0.3, 0.5, 0.2]);
    let qdd = JointVector::from_element(1.0);
    let acceleration = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0];
    let jerk = [7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0];
    let braking = BrakingLimits {
        acceleration: &acceleration,
        jerk: Some(&jerk),
        period_s: 0.001,
        tool_speed_m_s: 1.7,
    };
    let near = guard.nearest(&placement, f64::INFINITY).expect("a pair");
    println!("at the bench's joints the nearest pair is {:?} at {:.3} m", guard.names(near.0), near.1);
    c.bench_function("collision_guard_tick_panda_10_obstacles", |b| {
        b.iter(|| {
            let placement = arm.placement(black_box(&q));
            guard.assess(&placement, (&qd, &qdd), &qd, &braking)
        })
    });
}

criterion_group!(benches, guard);
criterion_main!(benches);
