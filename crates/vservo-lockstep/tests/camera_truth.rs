//! `[camera.truth]`: the simulated camera as it really is, apart from what the cell believes (the known answer a
//! calibration of the simulated cell is checked against). The camera renders from the true mount with the true
//! intrinsics; everything else works with the believed ones. Written equal to the belief, it changes nothing,
//! bit for bit; off by 5 mm, 2° and 2 % in the focal lengths, the image is the real camera's and the robust law
//! still brings the marks to ξ_d.

use nalgebra::{Translation3, UnitQuaternion, Vector3};
use vservo_config::{CameraTruth, Config};
use vservo_lockstep::summary::summarize;
use vservo_lockstep::{Lockstep, Trace};
use vservo_scene::CameraIntrinsics;

fn robust() -> Config {
    let mut config = Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-robust.toml"))
        .expect("config/vservo-robust.toml is valid");
    config.cell.scenario.duration_s = 6.0;
    config
}

fn run(config: &Config) -> Trace {
    Lockstep::new(config).expect("reachable").run(|_| {})
}

/// The camera 5 mm along its x and 2° about its optical axis off the believed mount, fx and fy 2 % longer.
fn off(config: &Config) -> CameraTruth {
    let believed = &config.cell.camera;
    let moved = nalgebra::IsometryMatrix3::from_parts(
        Translation3::new(0.005, 0.0, 0.0),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 2f64.to_radians()).to_rotation_matrix(),
    );
    CameraTruth {
        intrinsics: CameraIntrinsics::with_lens(
            [believed.fx_px() * 1.02, believed.fy_px() * 1.02],
            believed.principal_point_px(),
            believed.width_px(),
            believed.height_px(),
            *believed.distortion(),
        )
        .expect("valid intrinsics"),
        tool_from_camera: config.cell.tool_from_camera * moved,
        base_from_camera: None,
    }
}

#[test]
fn a_truth_equal_to_the_belief_changes_nothing() {
    let config = robust();
    // the file with its bases merged in, and the truth written as the very values believed
    let text =
        vservo_config::resolve(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo-robust.toml"))
            .expect("readable");
    let written = format!(
        "{text}\n[camera.truth]\nfx_px = {:?}\nfy_px = {:?}\n",
        config.cell.camera.fx_px(),
        config.cell.camera.fy_px()
    );
    let loaded = Config::from_toml(&written, "robust-with-truth");
    let mut with_truth = loaded.expect("the truth section loads");
    with_truth.cell.scenario.duration_s = config.cell.scenario.duration_s;
    assert!(with_truth.cell.camera_truth.is_some(), "written");
    assert_eq!(with_truth.cell.true_camera().intrinsics, config.cell.camera);
    assert_eq!(with_truth.cell.true_camera().tool_from_camera, config.cell.tool_from_camera);
    let (a, b) = (run(&config), run(&with_truth));
    assert_eq!(a.frames.len(), b.frames.len());
    for (x, y) in a.frames.iter().zip(&b.frames) {
        assert_eq!(x.measured, y.measured);
    }
}

#[test]
fn the_camera_renders_as_it_really_is_and_the_robust_law_still_converges() {
    let believed = robust();
    let mut config = robust();
    config.cell.camera_truth = Some(off(&config));
    let (as_believed, as_it_is) = (run(&believed), run(&config));
    let (first_believed, first) = (&as_believed.frames[0], &as_it_is.frames[0]);
    // the same joints, another camera: the marks are elsewhere in the image…
    let shift = (first.measured - first_believed.measured).amax();
    assert!(shift > 2.0, "the real camera's image differs from the believed one's: {shift} px");
    // …where the real camera projects them (no lens here: measured is the real camera's pinhole image)
    let to_truth = (first.measured - first.truth).amax();
    assert!(to_truth < 0.2, "the image is the real camera's: {to_truth} px from its projection");
    let summary = summarize(&as_it_is, &config.cell.scenario.object);
    assert!(summary.final_error_px < 1.0, "the robust law converges: {summary:?}");
    eprintln!(
        "first frame {shift:.2} px from the believed camera's; final error {:.3} px",
        summary.final_error_px
    );
}
