//! Speed of the whole gain synthesis (Jacobian, SVD, DARE, K) for the paper's four points:
//! `cargo bench -p vservo-control`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix6, Translation3};
use vservo_control::{ControlLaw, Gains, GainsSpec, InputUnits, InputWeight, ServoLaw, StateWeight};
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
    }
}

fn synthesis(c: &mut Criterion) {
    let paper = paper_spec(ControlLaw::Paper);
    c.bench_function("gain_synthesis_paper", |b| b.iter(|| Gains::design(black_box(&paper))));
    let delay_aware = paper_spec(ControlLaw::DelayAware);
    c.bench_function("gain_synthesis_delay_aware", |b| b.iter(|| Gains::design(black_box(&delay_aware))));
    let gains = Gains::design(&delay_aware).expect("designable");
    let mut law = ServoLaw::new(&gains);
    let measured = gains.desired_features.add_scalar(3.0);
    c.bench_function("servo_law_step", |b| b.iter(|| law.command(black_box(&measured))));
}

criterion_group!(benches, synthesis);
criterion_main!(benches);
