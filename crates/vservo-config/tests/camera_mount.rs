//! `[camera] mount`: a camera on the hand (`tool_from_camera`, the default) or fixed in the world
//! (`base_from_camera`, the board on the tool where `[desired]` puts it). Each mount's pose is refused with the
//! other, a missing one is named, a board out of the hand's reach and a scenario that moves the board on its own
//! are refused, and a fixed camera's file over a hand camera's base drops the base's `tool_from_camera`.

mod common;

use std::path::PathBuf;

use common::{DEFAULT, refused, with};
use vservo_config::Config;
use vservo_scene::CameraMount;

const HAND_MOUNT: &str =
    "[camera.tool_from_camera]\ntranslation_m = [0.0, 0.0, 0.08]\nrotation_rpy_deg = [0.0, 0.0, -90.0]\n";
const FIXED_MOUNT: &str = "mount = \"world\"\n\n[camera.base_from_camera]\ntranslation_m = [1.13, -0.15, 0.66]\nrotation_rpy_deg = [0.0, 90.0, -180.0]\n";

fn config_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

/// The default with its hand mount replaced by `mount` (at the end of `[camera]`).
fn with_mount(mount: &str) -> String {
    with(HAND_MOUNT, mount)
}

fn message(text: &str) -> String {
    refused(text).to_string()
}

#[test]
fn the_shipped_eye_to_hand_cell_has_a_fixed_camera_that_sees_the_board_as_desired_at_the_desired_joints() {
    let config = Config::load(config_dir().join("eye-to-hand.toml")).expect("config/eye-to-hand.toml loads");
    let cell = &config.cell;
    let CameraMount::World { base_from_camera, tool_from_board } = cell.mount() else {
        panic!("a fixed camera: {:?}", cell.mount())
    };
    // the board rides 3 cm beyond the flange, facing out
    let offset = tool_from_board.translation.vector;
    assert!((offset - nalgebra::Vector3::new(0.0, 0.0, 0.03)).norm() < 0.01, "{offset}");
    // seen from the fixed camera at q_d as [desired] says, wherever the arm is the camera is where it was put
    let seen = cell.camera_from_board_at(&cell.arm, &cell.desired.joints);
    assert!((seen.to_homogeneous() - cell.desired.camera_from_board.to_homogeneous()).abs().max() < 1e-12);
    let elsewhere = cell.arm.base_from_tool(&(cell.desired.joints * 0.9));
    assert_eq!(cell.mount().base_from_camera(&elsewhere), base_from_camera);
    // the robust cell's law and everything else are the base's
    let robust = Config::load(config_dir().join("vservo-robust.toml")).expect("loads");
    assert_eq!(cell.controller, robust.cell.controller);
    assert!(robust.cell.mount().is_hand());
}

#[test]
fn each_mount_refuses_the_others_pose_and_names_a_missing_one() {
    let hand_with_base = with_mount(&format!(
        "{HAND_MOUNT}\n[camera.base_from_camera]\ntranslation_m = [1.0, 0.0, 0.5]\nrotation_rpy_deg = [0.0, 0.0, 0.0]\n"
    ));
    let text = message(&hand_with_base);
    assert!(text.contains("camera.base_from_camera") && text.contains("a fixed camera's pose"), "{text}");
    let fixed_with_tool = with_mount(&format!("{FIXED_MOUNT}\n{HAND_MOUNT}"));
    let text = message(&fixed_with_tool);
    assert!(text.contains("camera.tool_from_camera") && text.contains("hand camera's pose"), "{text}");
    let fixed_without_pose = with_mount("mount = \"world\"\n");
    assert!(
        message(&fixed_without_pose).contains("camera.base_from_camera"),
        "{}",
        message(&fixed_without_pose)
    );
    let hand_without_pose = with_mount("");
    assert!(
        message(&hand_without_pose).contains("camera.tool_from_camera"),
        "{}",
        message(&hand_without_pose)
    );
    let unknown = with_mount(&format!("mount = \"ceiling\"\n\n{HAND_MOUNT}"));
    assert!(message(&unknown).contains("mount"), "{}", message(&unknown));
}

#[test]
fn a_fixed_camera_refuses_a_board_out_of_the_hands_reach_and_a_board_that_moves_on_its_own() {
    // a camera 3 m away from the hand: the board 0.5 m in front of it is not on the tool
    let far = with_mount(&FIXED_MOUNT.replace("[1.13, -0.15, 0.66]", "[3.5, -0.15, 0.66]"));
    let text = message(&far);
    assert!(text.contains("desired.camera_from_board") && text.contains("within 1 m"), "{text}");
    let moving =
        with_mount(FIXED_MOUNT).replacen("object_motion = \"hold\"", "object_motion = \"circle\"", 1);
    assert!(moving != with_mount(FIXED_MOUNT), "the default holds object_motion = \"hold\"");
    let text = message(&moving);
    assert!(text.contains("scenario.object_motion") && text.contains("rides on the tool"), "{text}");
    // the same circle with the camera on the hand is a scenario of the paper's
    assert!(
        Config::from_toml(
            &DEFAULT.replacen("object_motion = \"hold\"", "object_motion = \"circle\"", 1),
            "t.toml"
        )
        .is_ok()
    );
}

#[test]
fn the_truth_of_a_mount_is_the_mounts_own() {
    // a hand camera's truth cannot be fixed in the world, nor a fixed camera's on the hand
    let hand_truth = with_mount(&format!(
        "{HAND_MOUNT}\n[camera.truth]\nbase_from_camera = {{ translation_m = [1.0, 0.0, 0.5], rotation_rpy_deg = [0.0, 0.0, 0.0] }}\n"
    ));
    let text = message(&hand_truth);
    assert!(text.contains("camera.truth.base_from_camera"), "{text}");
    let fixed_truth = with_mount(&format!(
        "{FIXED_MOUNT}\n[camera.truth]\ntool_from_camera = {{ translation_m = [0.0, 0.0, 0.08], rotation_rpy_deg = [0.0, 0.0, -90.0] }}\n"
    ));
    let text = message(&fixed_truth);
    assert!(text.contains("camera.truth.tool_from_camera"), "{text}");
    // a fixed camera's truth moves the camera that renders, not the board on the tool
    let moved = with_mount(&format!(
        "{FIXED_MOUNT}\n[camera.truth]\nbase_from_camera = {{ translation_m = [1.135, -0.15, 0.66], rotation_rpy_deg = [0.0, 90.0, -180.0] }}\n"
    ));
    let config = Config::from_toml(&moved, "t.toml").expect("valid");
    let (
        CameraMount::World { base_from_camera: believed, tool_from_board },
        CameraMount::World { base_from_camera: truth, tool_from_board: true_board },
    ) = (config.cell.mount(), config.cell.true_mount())
    else {
        panic!("fixed cameras")
    };
    assert!(((truth.translation.vector - believed.translation.vector).norm() - 0.005).abs() < 1e-12);
    assert_eq!(tool_from_board, true_board);
}

/// A fixed camera's file over a hand camera's base drops the base's mount and its truth's pose (config/
/// eye-to-hand-calibration.toml over the demo's hand camera, whose truth is `tool_from_camera`).
#[test]
fn a_fixed_camera_over_a_hand_cameras_file_takes_none_of_its_mount() {
    let config = Config::load(config_dir().join("eye-to-hand-calibration.toml")).expect("loads");
    assert!(!config.cell.mount().is_hand());
    let truth = config.cell.true_camera();
    assert!(truth.base_from_camera.is_some());
    let demo = Config::load(config_dir().join("calibration-demo.toml")).expect("loads");
    assert_eq!(truth.intrinsics, demo.cell.true_camera().intrinsics, "the lens's truth is the base's");
    let resolved =
        vservo_config::resolve(config_dir().join("eye-to-hand-calibration.toml")).expect("resolves");
    assert!(!resolved.contains("tool_from_camera"), "{resolved}");
}
