//! Speed of the whole gain synthesis (Jacobian, SVD, DARE, K) for the paper's four points, and of the
//! servo's per-frame work with each law: `cargo bench -p vservo-control`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix6, Translation3};
use vservo_control::{
    ControlLaw, Gains, GainsSpec, InputUnits, InputWeight, Interaction, LawGeometry, LawOptions, ServoLaw,
    StateWeight,
};
use vservo_scene::{Board, CameraIntrinsics, IsometryMatrix3};

fn paper_spec(law: ControlLaw) -> GainsSpec {
    let camera = CameraIntrinsics::paper();
    let pose = IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Default::default());
    let (desired_features, desired_depths) =
        camera.project_marks_with_depths(&Board::paper(), &pose).expect("in front");
    let r = Matrix6::from_diagonal(&nalgebra::Vector6::new(1.0, 1.0, 1.0, 6.0, 6.0, 6.0));
    GainsSpec {
        camera,
        desired_features,
        desired_depths,
        period_s: 0.085,
        delay_frames: 1,
        q: StateWeight::scalar(300.0).expect("valid"),
        r: InputWeight::new(r, InputUnits::MillimetreMilliradian).expect("valid"),
        law,
        options: LawOptions::default(),
    }
}

fn geometry() -> LawGeometry {
    LawGeometry { camera: CameraIntrinsics::paper(), board: Board::paper(), period_s: 0.085, delay_frames: 1 }
}

fn synthesis(c: &mut Criterion) {
    let paper = paper_spec(ControlLaw::Paper);
    c.bench_function("gain_synthesis_paper", |b| b.iter(|| Gains::design(black_box(&paper))));
    let delay_aware = paper_spec(ControlLaw::DelayAware);
    c.bench_function("gain_synthesis_delay_aware", |b| b.iter(|| Gains::design(black_box(&delay_aware))));
    let gains = Gains::design(&delay_aware).expect("designable");
    let mut law = ServoLaw::new(geometry(), &gains);
    let measured = gains.desired_features.add_scalar(3.0);
    c.bench_function("servo_law_step", |b| b.iter(|| law.command(black_box(&measured))));
    // the robust settings: a gain designed on every frame from B at the mean of ξ_d's and the current
    // features (the depths from the board pose they give), the target's motion fed forward, the barrier
    let mut robust_spec = delay_aware;
    robust_spec.options = LawOptions {
        interaction: Interaction::Mean,
        border_margin_px: 20.0,
        feedforward: true,
        ..Default::default()
    };
    let robust = Gains::design(&robust_spec).expect("designable");
    let mut law = ServoLaw::new(geometry(), &robust);
    let pose = IsometryMatrix3::identity();
    let mut frame = 0u64;
    c.bench_function("servo_law_step_robust", |b| {
        b.iter(|| {
            frame += 1;
            law.step(frame, black_box(&measured), Some(&pose))
        })
    });
    let mut three = measured;
    three[2] = f64::NAN;
    three[3] = f64::NAN;
    c.bench_function("servo_law_step_robust_three_marks", |b| {
        b.iter(|| {
            frame += 1;
            law.step(frame, black_box(&three), Some(&pose))
        })
    });
}

criterion_group!(benches, synthesis);
criterion_main!(benches);
