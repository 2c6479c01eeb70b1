//! The paper's design and the delay-aware one, checked by their defining properties and against scipy
//! (fixtures made by `scripts/gen_dare_fixtures.py`).

use nalgebra::{DMatrix, Matrix2, Matrix6, Rotation3, SMatrix, Translation3, Vector3, Vector6};
use proptest::prelude::*;
use serde::Deserialize;
use vservo_control::analysis::{loop_eigenvalues, magnitudes, nominal_eigenvalues};
use vservo_control::dare;
use vservo_control::image_jacobian::extended_image_jacobian;
use vservo_control::lq::{delay_aware_gain, paper_gain};
use vservo_control::{ControlLaw, Gains, GainsSpec, InputUnits, InputWeight, ServoLaw, StateWeight};
use vservo_scene::{Board, CameraIntrinsics, FeatureVector, IsometryMatrix3};

fn desired_pose() -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(Translation3::new(0.0, 0.0, 0.5), Rotation3::identity())
}

fn paper_r() -> InputWeight {
    let r = Matrix6::from_diagonal(&Vector6::new(1.0, 1.0, 1.0, 6.0, 6.0, 6.0));
    InputWeight::new(r, InputUnits::MillimetreMilliradian).expect("valid")
}

fn spec(law: ControlLaw, delay_frames: usize) -> GainsSpec {
    let camera = CameraIntrinsics::paper();
    let (desired_features, desired_depths) =
        camera.project_marks_with_depths(&Board::paper(), &desired_pose()).expect("in front");
    GainsSpec {
        camera,
        desired_features,
        desired_depths,
        period_s: 0.085,
        delay_frames,
        q: StateWeight::scalar(300.0).expect("valid"),
        r: paper_r(),
        law,
        options: vservo_control::LawOptions::default(),
    }
}

#[derive(Deserialize)]
struct Fixtures {
    paper: PaperFixture,
    general: Vec<GeneralFixture>,
}

#[derive(Deserialize)]
struct PaperFixture {
    b: Vec<Vec<f64>>,
    singular_values: Vec<f64>,
    q_c: Vec<Vec<f64>>,
    p: Vec<Vec<f64>>,
    k_c: Vec<Vec<f64>>,
    k: Vec<Vec<f64>>,
    eig_abs: Vec<f64>,
    delay1_p: Vec<Vec<f64>>,
    delay1_k: Vec<Vec<f64>>,
}

#[derive(Deserialize)]
struct GeneralFixture {
    a: Vec<Vec<f64>>,
    b: Vec<Vec<f64>>,
    q: Vec<Vec<f64>>,
    r: Vec<Vec<f64>>,
    p: Vec<Vec<f64>>,
    k: Vec<Vec<f64>>,
}

fn fixtures() -> Fixtures {
    serde_json::from_str(include_str!("fixtures/dare_scipy.json")).expect("fixture parses")
}

fn dmatrix(rows: &[Vec<f64>]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
}

fn relative_difference(ours: &DMatrix<f64>, reference: &DMatrix<f64>) -> f64 {
    (ours - reference).norm() / reference.norm()
}

fn to_dynamic<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

#[test]
fn paper_design_agrees_with_scipy() {
    let f = fixtures().paper;
    let gains = Gains::design(&spec(ControlLaw::Paper, 1)).expect("designable");
    assert!(relative_difference(&to_dynamic(&gains.b), &dmatrix(&f.b)) < 1e-14);
    for (ours, theirs) in gains.decomposition.singular_values.iter().zip(&f.singular_values) {
        assert!((ours - theirs).abs() < 1e-10 * theirs, "σ {ours} vs {theirs}");
    }
    // the SVD's signs are arbitrary, so Q_c, P and K_c depend on them; K does not (Theorem 2)
    let k = to_dynamic(&gains.paper.k);
    let difference = relative_difference(&k, &dmatrix(&f.k));
    assert!(difference < 1e-9, "K differs from scipy's by {difference:e}");
    // Q_c, P, K_c agree once both are expressed in the same basis: compare the invariants
    let ours_q_c = gains.paper.q_c.symmetric_eigenvalues();
    let theirs_q_c = dmatrix(&f.q_c).symmetric_eigenvalues();
    let mut a: Vec<f64> = ours_q_c.iter().copied().collect();
    let mut b: Vec<f64> = theirs_q_c.iter().copied().collect();
    a.sort_by(f64::total_cmp);
    b.sort_by(f64::total_cmp);
    assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9 * y.abs().max(1.0)));
    let p_trace_ours = gains.paper.p.trace();
    let p_trace_theirs = dmatrix(&f.p).trace();
    assert!((p_trace_ours - p_trace_theirs).abs() < 1e-9 * p_trace_theirs);
    let kc_norm = (gains.paper.k_c.norm() - dmatrix(&f.k_c).norm()).abs();
    assert!(kc_norm < 1e-9 * gains.paper.k_c.norm());
    let eig = magnitudes(&nominal_eigenvalues(&gains.b, &gains.paper.k));
    for (ours, theirs) in eig.iter().zip(&f.eig_abs) {
        assert!((ours - theirs).abs() < 1e-9, "|λ| {ours} vs {theirs}");
    }
}

#[test]
fn delay_augmented_design_agrees_with_scipy_and_is_the_paper_gain_on_a_predicted_state() {
    let f = fixtures().paper;
    let s = spec(ControlLaw::DelayAware, 1);
    let gains = Gains::design(&s).expect("designable");
    let decomposition = gains.decomposition;
    let delayed =
        delay_aware_gain(&decomposition, &s.q, &s.r.si(), 1).expect("the augmented DARE is solvable");
    // scipy's P and K are in scipy's SVD basis: compare the basis-free products
    let k_theirs = dmatrix(&f.delay1_k);
    let p_theirs = dmatrix(&f.delay1_p);
    assert!((delayed.p.trace() - p_theirs.trace()).abs() < 1e-9 * p_theirs.trace());
    let past_theirs = k_theirs.view((0, 6), (6, 6)).into_owned();
    let past_ours = to_dynamic(&delayed.past_input_gains[0]);
    assert!(relative_difference(&past_ours, &past_theirs) < 1e-9, "K on u(k-1)");
    // the optimal law for a pure input delay: u(k) = −K (ξ̄(k−1) + B u(k−1)), K the paper's gain
    let paper = gains.paper;
    assert!(relative_difference(&to_dynamic(&delayed.feature_gain), &to_dynamic(&paper.k)) < 1e-9);
    let predicted = paper.k * gains.b;
    assert!(relative_difference(&past_ours, &to_dynamic(&predicted)) < 1e-9);
    // two frames: K_j = K B for each j
    let two = delay_aware_gain(&decomposition, &s.q, &s.r.si(), 2).expect("solvable");
    for k_j in &two.past_input_gains {
        assert!(relative_difference(&to_dynamic(k_j), &to_dynamic(&predicted)) < 1e-9);
    }
}

#[test]
fn general_solver_agrees_with_scipy_on_problems_with_a_not_identity() {
    for (index, case) in fixtures().general.iter().enumerate() {
        let (a, b, q, r) = (dmatrix(&case.a), dmatrix(&case.b), dmatrix(&case.q), dmatrix(&case.r));
        let (p, k) = dare::solve(&a, &b, &q, &r).expect("scipy solved it");
        assert!(relative_difference(&p, &dmatrix(&case.p)) < 1e-9, "case {index}: P");
        assert!(relative_difference(&k, &dmatrix(&case.k)) < 1e-9, "case {index}: K");
        let residual = dare::relative_residual(&a, &b, &q, &r, &p);
        assert!(residual < 1e-9, "case {index}: residual {residual:e}");
    }
}

#[test]
fn closed_form_equals_the_general_solver_and_solves_the_equation() {
    let gains = Gains::design(&spec(ControlLaw::Paper, 1)).expect("designable");
    let s = spec(ControlLaw::Paper, 1);
    let b_c = to_dynamic(&gains.decomposition.b_c);
    let q_c = to_dynamic(&gains.paper.q_c);
    let r = to_dynamic(&s.r.si());
    let identity = DMatrix::identity(6, 6);
    let residual = dare::relative_residual(&identity, &b_c, &q_c, &r, &to_dynamic(&gains.paper.p));
    assert!(residual < 1e-9, "closed form residual {residual:e}");
    let (p, k) = dare::solve(&identity, &b_c, &q_c, &r).expect("doubling converges");
    assert!(relative_difference(&p, &to_dynamic(&gains.paper.p)) < 1e-9);
    assert!(relative_difference(&k, &to_dynamic(&gains.paper.k_c)) < 1e-9);
}

#[test]
fn i_minus_bk_has_two_unit_eigenvalues_and_six_inside_the_unit_circle() {
    for units in [InputUnits::Si, InputUnits::MillimetreMilliradian] {
        let mut s = spec(ControlLaw::Paper, 1);
        s.r = InputWeight::new(*paper_r().as_written(), units).expect("valid");
        let gains = Gains::design(&s).expect("designable");
        let eigenvalues = nominal_eigenvalues(&gains.b, &gains.paper.k);
        let unit =
            eigenvalues.iter().filter(|l| (*l - nalgebra::Complex::new(1.0, 0.0)).norm() < 1e-9).count();
        assert_eq!(unit, 2, "2N − 6 = 2 unit eigenvalues: {eigenvalues:?}");
        let inside = eigenvalues.iter().filter(|l| l.norm() < 1.0 - 1e-9).count();
        assert_eq!(inside, 6, "{eigenvalues:?}");
        // they are the eigenvalues of the reduced loop without delay
        let reduced = magnitudes(&loop_eigenvalues(&gains.b, &gains.paper.k, &[], 0));
        let full = magnitudes(&eigenvalues);
        for (r, f) in reduced.iter().zip(&full[2..]) {
            assert!((r - f).abs() < 1e-9, "{reduced:?} vs {full:?}");
        }
    }
}

#[test]
fn reduced_delayed_loop_has_the_eigenvalues_of_the_full_delayed_loop() {
    let gains = Gains::design(&spec(ControlLaw::Paper, 1)).expect("designable");
    // full loop on [ξ̄(k); ξ̄(k−1)]: ξ̄(k+1) = ξ̄(k) − BK ξ̄(k−1)
    let mut full = DMatrix::<f64>::zeros(16, 16);
    full.view_mut((0, 0), (8, 8)).copy_from(&DMatrix::identity(8, 8));
    full.view_mut((0, 8), (8, 8)).copy_from(&to_dynamic(&(-(gains.b * gains.paper.k))));
    full.view_mut((8, 0), (8, 8)).copy_from(&DMatrix::identity(8, 8));
    let full_magnitudes = magnitudes(&vservo_control::analysis::eigenvalues(&full).expect("converges"));
    let reduced = magnitudes(&loop_eigenvalues(&gains.b, &gains.paper.k, &[], 1));
    // full = reduced ∪ {1, 1, 0, 0}
    let mut expected = reduced.clone();
    expected.extend([1.0, 1.0, 0.0, 0.0]);
    expected.sort_by(|a, b| b.total_cmp(a));
    for (a, b) in full_magnitudes.iter().zip(&expected) {
        assert!((a - b).abs() < 1e-6, "{full_magnitudes:?} vs {expected:?}");
    }
}

/// A random orthogonal matrix from the QR decomposition of a random one.
fn orthogonal6(entries: Vec<f64>) -> Matrix6<f64> {
    let m = Matrix6::from_column_slice(&entries) + Matrix6::identity() * 0.1;
    m.qr().q()
}

/// A rotation (or, with `reflect`, a reflection) of the plane.
fn orthogonal2(angle: f64, reflect: bool) -> Matrix2<f64> {
    let (s, c) = angle.sin_cos();
    let sign = if reflect { -1.0 } else { 1.0 };
    Matrix2::new(c, -s * sign, s, c * sign)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Theorem 2: K is the same for S = blockdiag(T₁, T₂)·Uᵀ with any orthogonal T₁, T₂.
    #[test]
    fn gain_does_not_depend_on_the_choice_of_s(
        t1 in proptest::collection::vec(-1.0..1.0f64, 36),
        t2_angle in -3.2..3.2f64,
        t2_reflect in any::<bool>(),
        q_scale in 1.0..1000.0f64,
        r_diagonal in proptest::array::uniform6(0.1..10.0f64),
    ) {
        let s = spec(ControlLaw::Paper, 1);
        let gains = Gains::design(&s).expect("designable");
        let q = StateWeight::scalar(q_scale).expect("valid");
        let r = Matrix6::from_diagonal(&Vector6::from(r_diagonal)) * 1e6;
        let reference = paper_gain(&gains.decomposition, &q, &r).expect("designable");
        let (t1, t2) = (orthogonal6(t1), orthogonal2(t2_angle, t2_reflect));
        let other = gains.decomposition.transformed(&t1, &t2);
        // still a valid decomposition: S orthogonal and S B = [B_c; 0]
        let s_matrix = other.s();
        prop_assert!((s_matrix * s_matrix.transpose() - SMatrix::<f64, 8, 8>::identity()).amax() < 1e-12);
        let sb = s_matrix * gains.b;
        prop_assert!(sb.fixed_view::<2, 6>(6, 0).amax() < 1e-9 * gains.b.amax());
        let k = paper_gain(&other, &q, &r).expect("designable").k;
        prop_assert!((k - reference.k).norm() < 1e-9 * reference.k.norm());
    }

    /// The image Jacobian is the derivative of the projection under a camera twist (eq. 2).
    #[test]
    fn image_jacobian_matches_finite_differences_of_the_projection(
        position in proptest::array::uniform3(-0.2..0.2f64),
        depth in 0.3..2.0f64,
        tilt in proptest::array::uniform3(-0.3..0.3f64),
        twist in proptest::array::uniform6(-1.0..1.0f64),
    ) {
        let camera = CameraIntrinsics::paper();
        let board = Board::paper();
        let camera_from_board = IsometryMatrix3::from_parts(
            Translation3::new(position[0], position[1], depth),
            Rotation3::from_scaled_axis(Vector3::from(tilt)),
        );
        let (features, depths) = camera.project_marks_with_depths(&board, &camera_from_board).expect("in front");
        let jacobian = extended_image_jacobian(&camera, &features, &depths);
        let (v, w) = (Vector3::new(twist[0], twist[1], twist[2]), Vector3::new(twist[3], twist[4], twist[5]));
        // the camera moves by the twist for ±h: old_camera_from_new = (h v, h ω)
        let moved = |h: f64| -> FeatureVector {
            let old_from_new = IsometryMatrix3::from_parts(Translation3::from(v * h), Rotation3::from_scaled_axis(w * h));
            camera.project_marks(&board, &(old_from_new.inverse() * camera_from_board)).expect("in front")
        };
        let h = 1e-6;
        let numeric = (moved(h) - moved(-h)) / (2.0 * h);
        let analytic = jacobian * Vector6::from(twist);
        prop_assert!((numeric - analytic).amax() < 1e-4 * analytic.amax().max(1.0), "{numeric} vs {analytic}");
    }
}

/// A kinematic loop on the linear model with the pipeline delay: the delay-aware law converges much faster.
#[test]
fn delay_aware_law_beats_the_paper_law_on_the_delayed_linear_loop() {
    let run = |law: ControlLaw| -> f64 {
        let gains = Gains::design(&spec(law, 1)).expect("designable");
        let mut servo = ServoLaw::new(
            vservo_control::LawGeometry {
                camera: CameraIntrinsics::paper(),
                board: Board::paper(),
                period_s: 0.085,
                delay_frames: 1,
            },
            &gains,
        );
        // a translational step: what the camera would see displaced by (6, −30, 1) mm
        let displaced = Translation3::new(-0.006, 0.030, -0.001) * desired_pose();
        let start = CameraIntrinsics::paper().project_marks(&Board::paper(), &displaced).expect("in front");
        let mut error = start - gains.desired_features;
        let mut seen = error; // one frame of pipeline delay
        let mut worst_late = 0.0_f64;
        for frame in 0..60 {
            let u = servo.command(&(gains.desired_features + seen));
            seen = error;
            error += gains.b * u;
            if frame >= 20 {
                worst_late = worst_late.max(error.amax());
            }
        }
        worst_late
    };
    let paper = run(ControlLaw::Paper);
    let aware = run(ControlLaw::DelayAware);
    assert!(aware < 0.05, "delay-aware error after 20 frames: {aware} px");
    assert!(aware * 5.0 < paper, "delay-aware {aware} px vs paper {paper} px after 20 frames");
}

#[test]
fn bad_designs_are_errors() {
    let mut s = spec(ControlLaw::Paper, 1);
    s.period_s = 0.0;
    assert!(Gains::design(&s).is_err());
    let mut s = spec(ControlLaw::Paper, 1);
    s.desired_depths[2] = -0.1;
    assert!(Gains::design(&s).expect_err("refused").to_string().contains("mark 3"));
    // all four marks on one point: B loses rank
    let mut s = spec(ControlLaw::Paper, 1);
    s.desired_features = FeatureVector::from_element(256.0);
    assert!(Gains::design(&s).expect_err("refused").to_string().contains("degenerate"));
    let mut s = spec(ControlLaw::DelayAware, 1);
    s.delay_frames = 9;
    assert!(Gains::design(&s).is_err());
}

#[test]
fn a_stability_margin_is_stable_just_inside_and_unstable_just_outside() {
    use vservo_control::analysis::{Bound, LoopUnderTest};
    let s = spec(ControlLaw::Paper, 1);
    let gains = Gains::design(&s).expect("designable");
    let (camera, board, desired) = (CameraIntrinsics::paper(), Board::paper(), desired_pose());
    for delay_frames in [0, 1] {
        let under_test = LoopUnderTest {
            camera: &camera,
            board: &board,
            camera_from_board_desired: &desired,
            period_s: s.period_s,
            feature_gain: &gains.paper.k,
            past_input_gains: &[],
            delay_frames,
        };
        for axis in 0..3 {
            let margin = under_test.translation_margin(axis);
            assert!(margin.magnitude > 0.01, "delay {delay_frames}, axis {axis}: {margin:?}");
            let inside = 0.999 * margin.magnitude;
            assert!(under_test.check(&under_test.translated(axis, inside)).is_ok());
            assert!(under_test.check(&under_test.translated(axis, -inside)).is_ok());
            if margin.bounded_by == Bound::Instability {
                let outside = 1.001 * margin.magnitude;
                let either = under_test.check(&under_test.translated(axis, outside)).is_err()
                    || under_test.check(&under_test.translated(axis, -outside)).is_err();
                assert!(either, "delay {delay_frames}, axis {axis}: still stable past {margin:?}");
            }
        }
        let rotation = under_test.rotation_margin(2);
        assert!(
            rotation.magnitude > 10f64.to_radians(),
            "the paper's 10° rotation step is stable: {rotation:?}"
        );
    }
}

/// The law says what it did beyond its design: the barrier's cut, and the target's motion fed forward.
#[test]
fn the_law_flags_the_barrier_cutting_its_twist_and_the_target_motion_fed_forward() {
    let mut s = spec(ControlLaw::DelayAware, 1);
    s.q = StateWeight::scalar(1000.0).expect("valid");
    let geometry = vservo_control::LawGeometry {
        camera: CameraIntrinsics::paper(),
        board: Board::paper(),
        period_s: 0.085,
        delay_frames: 1,
    };
    // the mark nearest the top at ξ_d; the image seen 20 px lower, so that the law moves it up
    let desired = s.desired_features;
    let top = (0..4).min_by(|&a, &b| desired[2 * a + 1].total_cmp(&desired[2 * b + 1])).expect("marks");
    let mut measured = desired;
    for mark in 0..4 {
        measured[2 * mark + 1] += 20.0;
    }
    let pose = IsometryMatrix3::identity();
    let design = |options: vservo_control::LawOptions| {
        let mut with = s;
        with.options = options;
        Gains::design(&with).expect("designable")
    };
    let rise_px = |twist: &vservo_control::Twist, gains: &Gains| -(gains.b * twist)[2 * top + 1];

    // the plain law: no flags, and it moves the top mark up by more than a barrier 10 px away allows
    let plain = design(vservo_control::LawOptions::default());
    let mut law = ServoLaw::new(geometry, &plain);
    let twist = law.step(1, &measured, Some(&pose)).expect("four marks");
    assert_eq!(law.flags(), vservo_control::LawFlags::default());
    let margin_px = desired[2 * top + 1] + 10.0;
    let allowed_px = 0.5 * (measured[2 * top + 1] - margin_px);
    assert!(rise_px(&twist, &plain) > allowed_px, "premise: {} px", rise_px(&twist, &plain));

    // with the barrier there: the twist is cut, and the law says so
    let fenced = design(vservo_control::LawOptions { border_margin_px: margin_px, ..Default::default() });
    let mut law = ServoLaw::new(geometry, &fenced);
    let twist = law.step(1, &measured, Some(&pose)).expect("four marks");
    assert!(law.flags().barrier && !law.flags().feedforward, "{:?}", law.flags());
    assert!(rise_px(&twist, &fenced) <= allowed_px + 1e-9, "{} px", rise_px(&twist, &fenced));
    // a barrier 20 px in, and the marks near where they are wanted: nothing to cut
    let fenced = design(vservo_control::LawOptions { border_margin_px: 20.0, ..Default::default() });
    let mut calm = ServoLaw::new(geometry, &fenced);
    calm.step(1, &(desired + FeatureVector::from_element(0.5)), Some(&pose));
    assert!(!calm.flags().barrier, "{:?}", calm.flags());

    // feed-forward: flagged once the estimate has settled on consecutive frames, not before
    let ahead = design(vservo_control::LawOptions { feedforward: true, ..Default::default() });
    let mut law = ServoLaw::new(geometry, &ahead);
    let flagged: Vec<bool> = (1..=8)
        .map(|frame| {
            law.step(frame, &measured, Some(&pose));
            law.flags().feedforward
        })
        .collect();
    // the estimate is made from frame 2 on and used once it has 4 frames behind it (target_motion)
    assert_eq!(flagged, [false, false, false, false, true, true, true, true]);
    // a frame without the camera's pose restarts the estimate
    law.step(9, &measured, None);
    assert!(!law.flags().feedforward);

    // the gain scheduled on the current features cannot be designed when the four marks image as one
    // point (B loses rank): the fixed gain for the marks is used, and the law says so
    let current = design(vservo_control::LawOptions {
        interaction: vservo_control::Interaction::Current,
        ..Default::default()
    });
    let mut law = ServoLaw::new(geometry, &current);
    law.step(1, &measured, Some(&pose)).expect("four marks");
    assert!(!law.flags().fixed_gain_fallback, "{:?}", law.flags());
    let one_point = FeatureVector::from_fn(|row, _| if row % 2 == 0 { 250.0 } else { 240.0 });
    law.step(2, &one_point, Some(&pose)).expect("the fixed gain");
    assert!(law.flags().fixed_gain_fallback, "{:?}", law.flags());
}
