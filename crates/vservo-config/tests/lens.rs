//! `[camera]`'s lens: fx, fy, the principal point and OpenCV's distortion, or a calibration file (a ROS
//! camera_info YAML, an OpenCV FileStorage YAML written by OpenCV itself) in their place; bad files and
//! keys refused naming the file, the key and why.

use std::path::{Path, PathBuf};

use vservo_config::{Config, ConfigError};

fn config_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

fn data(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(file)
}

/// A directory of this test's own, with `files` written into it.
fn directory_with(name: &str, files: &[(&str, &str)]) -> PathBuf {
    let directory = std::env::temp_dir().join(format!("vservo-lens-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&directory).expect("a temporary directory");
    for (file, text) in files {
        std::fs::write(directory.join(file), text).expect("a temporary file");
    }
    directory
}

/// A configuration over the default whose `[camera]` lens is `camera` (in a file of its own directory, with
/// `files` beside it).
fn load_with_camera(name: &str, camera: &str, files: &[(&str, &str)]) -> Result<Config, ConfigError> {
    let base = config_dir().join("vservo.toml").canonicalize().expect("the default exists");
    let text = format!("extends = {:?}\n\n[camera]\n{camera}\n", base.display().to_string());
    let mut all = vec![("vservo.toml", text.as_str())];
    all.extend_from_slice(files);
    let directory = directory_with(name, &all);
    let loaded = Config::load(directory.join("vservo.toml"));
    std::fs::remove_dir_all(&directory).ok();
    loaded
}

#[test]
fn the_distorted_cell_has_its_lens() {
    let config =
        Config::load(config_dir().join("vservo-distorted.toml")).expect("vservo-distorted.toml is valid");
    let camera = config.cell.camera;
    assert_eq!((camera.fx_px(), camera.fy_px()), (600.0, 606.0));
    assert_eq!((camera.width_px(), camera.height_px()), (640, 480));
    assert_eq!(camera.principal_point_px(), nalgebra::Point2::new(322.0, 237.0));
    assert_eq!(camera.distortion().coefficients(), [-0.25, 0.08, 0.0, 0.0, 0.0]);
    assert!(config.cell.vision.undistort);
    // the robust law it extends
    assert_eq!(config.cell.controller.options.border_margin_px, 20.0);
}

#[test]
fn the_default_camera_is_the_papers_pinhole() {
    let config = Config::load(config_dir().join("vservo.toml")).expect("the default loads");
    assert_eq!(config.cell.camera, vservo_scene::CameraIntrinsics::paper());
}

#[test]
fn a_ros_camera_info_file_gives_the_lens() {
    let ros = std::fs::read_to_string(data("ros_camera_info_usb_cam.yaml")).expect("the ROS example");
    let config =
        load_with_camera("ros", "calibration_file = \"camera_info.yaml\"", &[("camera_info.yaml", &ros)])
            .expect("a ROS camera_info file is taken");
    let camera = config.cell.camera;
    assert_eq!((camera.fx_px(), camera.fy_px()), (438.783367, 437.302876));
    // ROS's pixel centres are at integers, vservo's at + ½
    assert_eq!(camera.principal_point_px(), nalgebra::Point2::new(305.593336 + 0.5, 243.738352 + 0.5));
    assert_eq!((camera.width_px(), camera.height_px()), (640, 480));
    assert_eq!(camera.distortion().coefficients(), [-0.361976, 0.110510, 0.001014, 0.000505, 0.0]);
}

#[test]
fn an_opencv_file_written_by_opencv_gives_the_lens() {
    let opencv = std::fs::read_to_string(data("opencv_calibration.yaml")).expect("the OpenCV file");
    assert!(
        opencv.starts_with("%YAML:1.0") && opencv.contains("!!opencv-matrix"),
        "written by cv2.FileStorage"
    );
    let config = load_with_camera(
        "opencv",
        "calibration_file = \"calibration.yaml\"",
        &[("calibration.yaml", &opencv)],
    )
    .expect("an OpenCV FileStorage file is taken");
    let camera = config.cell.camera;
    assert_eq!((camera.fx_px(), camera.fy_px()), (600.0, 606.0));
    // OpenCV's pixel centres are at integers, vservo's at + ½
    assert_eq!(camera.principal_point_px(), nalgebra::Point2::new(322.5, 237.5));
    assert_eq!(camera.distortion().coefficients(), [-0.25, 0.08, 0.0, 0.0, 0.0]);
}

#[test]
fn the_merged_text_names_the_calibration_file_wherever_it_is_read() {
    let ros = std::fs::read_to_string(data("ros_camera_info_usb_cam.yaml")).expect("the ROS example");
    let base = config_dir().join("vservo.toml").canonicalize().expect("the default exists");
    let text = format!(
        "extends = {:?}\n[camera]\ncalibration_file = \"cal/info.yaml\"\n",
        base.display().to_string()
    );
    let directory = directory_with("merged", &[("vservo.toml", &text)]);
    std::fs::create_dir_all(directory.join("cal")).expect("a directory");
    std::fs::write(directory.join("cal/info.yaml"), ros).expect("a file");
    let (config, merged) = Config::load_with_text(directory.join("vservo.toml")).expect("loads");
    let again = Config::from_toml(&merged, "stdin").expect("the merged text loads on its own");
    std::fs::remove_dir_all(&directory).ok();
    assert_eq!(again.cell.camera, config.cell.camera);
}

#[test]
fn bad_lenses_and_calibration_files_name_the_file_key_and_why() {
    const ROS: &str = include_str!("data/ros_camera_info_usb_cam.yaml");
    // (a file that writes any lens key writes the whole lens: the rest of it)
    let lens =
        |keys: &str| format!("principal_point_px = [256.0, 256.0]\nwidth_px = 512\nheight_px = 512\n{keys}");
    let cases: Vec<(&str, String, &str, &str)> = vec![
        ("both", lens("focal_px = 500.0\nfx_px = 500.0\nfy_px = 500.0"), "camera.focal_px", "not both"),
        ("fx alone", lens("fx_px = 500.0"), "camera.fy_px", "must be given with camera.fx_px"),
        ("no focal", lens(""), "camera.focal_px", "must be given"),
        (
            "no size",
            "focal_px = 500.0\nprincipal_point_px = [256.0, 256.0]".into(),
            "camera.width_px",
            "must be given",
        ),
        (
            "nan k1",
            lens("focal_px = 500.0\ndistortion = [nan, 0.0, 0.0, 0.0, 0.0]"),
            "camera.distortion",
            "NaN",
        ),
        (
            "huge k1",
            lens("focal_px = 500.0\ndistortion = [1e300, 0.0, 0.0, 0.0, 0.0]"),
            "camera.distortion",
            "from -10 to 10",
        ),
        (
            "file and fx",
            "calibration_file = \"c.yaml\"\nfx_px = 1.0".into(),
            "camera.calibration_file",
            "camera.fx_px",
        ),
        ("no file", "calibration_file = \"missing.yaml\"".into(), "camera.calibration_file", "cannot read"),
        ("not yaml", "calibration_file = \"c.yaml\"".into(), "camera.calibration_file", "not YAML"),
        (
            "no matrix",
            "calibration_file = \"c.yaml\"".into(),
            "camera.calibration_file",
            "camera_matrix: missing",
        ),
        (
            "eight numbers",
            "calibration_file = \"c.yaml\"".into(),
            "camera.calibration_file",
            "camera_matrix.data: has 8 numbers",
        ),
        ("skew", "calibration_file = \"c.yaml\"".into(), "camera.calibration_file", "skew 0.5"),
        (
            "fisheye",
            "calibration_file = \"c.yaml\"".into(),
            "camera.calibration_file",
            "distortion_model: \"equidistant\"",
        ),
        (
            "rational",
            "calibration_file = \"c.yaml\"".into(),
            "camera.calibration_file",
            "distortion_coefficients.data[5]",
        ),
        ("width", "calibration_file = \"c.yaml\"".into(), "camera.calibration_file", "image_width: missing"),
        (
            "text in data",
            "calibration_file = \"c.yaml\"".into(),
            "camera.calibration_file",
            "camera_matrix.data[2]",
        ),
    ];
    let file_for = |name: &str| -> String {
        match name {
            "not yaml" => "camera_matrix: [1, 2\n".into(),
            "no matrix" => ROS.replace("camera_matrix:", "camera_matrices:"),
            "eight numbers" => ROS.replace(
                "0.000000, 0.000000, 1.000000]\ndistortion_model",
                "0.000000, 0.000000]\ndistortion_model",
            ),
            "skew" => ROS.replace("[438.783367, 0.000000,", "[438.783367, 0.5,"),
            "fisheye" => ROS.replace("plumb_bob", "equidistant"),
            "rational" => ROS.replace(
                "cols: 5\n  data: [-0.361976, 0.110510, 0.001014, 0.000505, 0.000000]",
                "cols: 8\n  data: [-0.361976, 0.110510, 0.001014, 0.000505, 0.0, 0.2, 0.0, 0.0]",
            ),
            "width" => ROS.replace("image_width: 640\n", ""),
            "text in data" => ROS.replace("305.593336", "centre"),
            _ => ROS.into(),
        }
    };
    for (name, camera, key, fragment) in cases {
        let file = file_for(name);
        let error = load_with_camera(&name.replace(' ', "-"), &camera, &[("c.yaml", &file)]).expect_err(name);
        let message = error.to_string();
        assert_eq!(error.key(), Some(key), "{name}: {message}");
        assert!(message.contains("vservo.toml"), "{name}: names the configuration: {message}");
        assert!(message.contains(fragment), "{name}: says why ({fragment:?}): {message}");
        if camera.contains("c.yaml") && name != "file and fx" {
            assert!(message.contains("c.yaml"), "{name}: names the calibration file: {message}");
        }
    }
}

/// The security review's calibration file: 589 bytes of nested aliases grew to gigabytes in the loader. Aliases,
/// deep nesting and huge files are refused before the loader sees them, at once and naming why.
#[test]
fn alias_bombs_deep_nesting_and_huge_calibration_files_are_refused_before_loading() {
    let mut bomb =
        String::from("a: &a [\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\"]\n");
    for level in 0..9 {
        let (name, previous) = (char::from(b'b' + level), char::from(b'a' + level));
        bomb += &format!(
            "{name}: &{name} [*{previous},*{previous},*{previous},*{previous},*{previous},*{previous}]\n"
        );
    }
    let refused = vservo_config::calibration::parse(&bomb).expect_err("an alias bomb");
    assert!(refused.to_string().contains("an alias (*…) at line"), "{refused}");
    let deep = format!("image_width: 640\nnested: {}{}\n", "[".repeat(40), "]".repeat(40));
    let refused = vservo_config::calibration::parse(&deep).expect_err("deep nesting");
    assert!(refused.to_string().contains("nest deeper than 16"), "{refused}");
    let huge = format!(
        "image_width: 640\ncomment: \"{}\"\n",
        "x".repeat(vservo_config::calibration::MAX_CALIBRATION_BYTES)
    );
    let refused = vservo_config::calibration::parse(&huge).expect_err("huge");
    assert!(refused.to_string().contains("a calibration file is read up to"), "{refused}");
}

/// A GStreamer pipeline of thousands of elements kept the camera driver deaf to SIGTERM while GStreamer parsed
/// it: a pipeline longer than a camera's is refused, naming the key.
#[test]
fn a_pipeline_longer_than_a_cameras_is_refused() {
    let elements = vec!["identity"; 2000].join(" ! ");
    let camera = format!(
        "source = \"external\"\n[camera.gstreamer]\npipeline = \"videotestsrc ! {elements} ! appsink name=vservo\""
    );
    let refused = load_with_camera("long-pipeline", &camera, &[]).expect_err("refused");
    let text = refused.to_string();
    assert!(text.contains("camera.gstreamer.pipeline") && text.contains("4096 bytes"), "{text}");
    let camera =
        "source = \"external\"\n[camera.gstreamer]\npipeline = \"videotestsrc ! appsink name=vservo\"";
    load_with_camera("short-pipeline", camera, &[]).expect("a camera's pipeline is taken");
}

/// A size the calibration file gave is the file's fault: a camera larger than a camera_image sample carries is
/// refused naming `camera.calibration_file` and the file, not `camera.width_px`, which the configuration left out.
#[test]
fn a_size_from_the_calibration_file_is_blamed_on_the_file() {
    const ROS: &str = include_str!("data/ros_camera_info_usb_cam.yaml");
    let huge = ROS.replacen("image_width: 640", "image_width: 4000", 1).replacen(
        "image_height: 480",
        "image_height: 3000",
        1,
    );
    assert_ne!(huge, ROS, "the file's size written as the test expects");
    let error = load_with_camera("huge", "calibration_file = \"big.yaml\"", &[("big.yaml", &huge)])
        .expect_err("4000 × 3000 is more than a sample");
    assert_eq!(error.key(), Some("camera.calibration_file"), "{error}");
    let message = error.to_string();
    assert!(message.contains("\"big.yaml\"") || message.contains("big.yaml\""), "{message}");
    assert!(message.contains("4000 × 3000") && message.contains("calibrates a larger camera"), "{message}");
    assert!(!message.contains("lower camera.width_px"), "{message}");
}
