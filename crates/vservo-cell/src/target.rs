//! Where a client may put the servo's target: features, a camera pose relative to the board, or what the
//! camera sees now (teach) become ξ_d and the marks' depths there, or a [`TargetRefused`] saying why not.
//!
//! Pure: the daemon hands in the configuration, the barrier's margin in force and what it last heard of the
//! cell ([`CellNow`]); nothing here reads a clock or a message. The board is placed from the joints and the
//! features (board-plane homography), as a real cell has it: no simulated world is consulted.

use nalgebra::Vector3;
use vservo_arm::JointVector;
use vservo_config::CellConfig;
use vservo_scene::{FeatureVector, IsometryMatrix3, MARKS, MarkDepths, ProjectionError};

/// Features closer than this to the image border are refused as targets (px): a mark there is cut by the
/// border or leaves the image at the first disturbance.
pub const TARGET_BORDER_MARGIN_PX: f64 = 10.0;
/// A feature target must be the image of the board from some camera pose to within this (px).
pub const TARGET_POSE_FIT_PX: f64 = 3.0;
/// Two target marks closer than this (px) would merge in the image.
pub const TARGET_MIN_SEPARATION_PX: f64 = 20.0;

/// A placed target: what the servo's gains are designed for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// ξ_d (px).
    pub features: FeatureVector,
    /// Z_d, the marks' depths at the target (m).
    pub depths: MarkDepths,
}

/// What a client asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TargetRequest {
    /// These features (px).
    Features(FeatureVector),
    /// The board at this pose in the camera frame: a translation (m) and roll-pitch-yaw angles (rad).
    Pose {
        /// The board's origin in the camera frame (m).
        translation_m: Vector3<f64>,
        /// R = Rz(yaw)·Ry(pitch)·Rx(roll) (rad).
        rotation_rpy_rad: Vector3<f64>,
    },
    /// What the camera sees now.
    Teach,
}

impl TargetRequest {
    /// The request's name, as a refusal is introduced.
    pub fn name(&self) -> &'static str {
        match self {
            TargetRequest::Features(_) => "target",
            TargetRequest::Pose { .. } => "target pose",
            TargetRequest::Teach => "teach",
        }
    }
}

/// What the daemon last heard of the cell.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CellNow {
    /// The joints of the latest joint state.
    pub joints: Option<JointVector>,
    /// The latest features, if they show all four marks.
    pub features_seen: Option<FeatureVector>,
}

/// Why a target is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TargetRefused {
    /// A feature or a pose number is NaN or infinite.
    #[error("a number is not finite")]
    NotFinite,
    /// A mark outside the image, or too close to its border.
    #[error(
        "mark {} at ({x:.1}, {y:.1}) px is outside the image or within {margin_px} px{} of its border ({width_px}×{height_px} px)",
        mark + 1,
        if *barrier_margin { " (controller.border_margin_px)" } else { "" }
    )]
    OutsideImage {
        /// The mark (zero-based).
        mark: usize,
        /// Its position (px).
        x: f64,
        /// Its position (px).
        y: f64,
        /// The margin in force (px).
        margin_px: f64,
        /// Whether the margin is the barrier's (`controller.border_margin_px`), wider than the border margin.
        barrier_margin: bool,
        /// The image's size (px).
        width_px: u32,
        /// The image's size (px).
        height_px: u32,
    },
    /// Two marks so close that they would merge in the image.
    #[error("marks {} and {} are {apart_px:.1} px apart (at least {TARGET_MIN_SEPARATION_PX} px)", first + 1, second + 1)]
    MarksTooClose {
        /// The first mark (zero-based).
        first: usize,
        /// The second mark (zero-based).
        second: usize,
        /// Their distance (px).
        apart_px: f64,
    },
    /// The marks' order is the mirror of the layout's.
    #[error("the marks are in mirrored order (the board would have to be seen from behind)")]
    Mirrored,
    /// No camera pose images the board's marks at the features.
    #[error("no camera pose images the board's marks there (three of them in a line?)")]
    NoCameraPose,
    /// The best-fitting pose reprojects the marks too far from the features.
    #[error(
        "these features are no image of the board: the camera pose fitted to them (plane homography) reprojects the marks up to {off_px:.1} px away (at most {TARGET_POSE_FIT_PX} px)"
    )]
    NotAnImageOfTheBoard {
        /// The largest reprojection error (px).
        off_px: f64,
    },
    /// A mark behind the camera.
    #[error("{0}")]
    Projection(#[from] ProjectionError),
    /// No arm configuration puts the camera there with the board where it is.
    #[error("out of the arm's reach, or no arm configuration inside the joint limits reaches it")]
    Unreachable,
    /// Teach: the camera does not see the four marks.
    #[error("the camera does not see all four marks now")]
    MarksNotSeen,
    /// Teach: the features seen give no board pose.
    #[error("the board's pose cannot be found from the features seen now")]
    BoardPoseNotFound,
}

/// Places the target `request` asks for, with the barrier's margin `border_margin_px` in force.
pub fn place(
    config: &CellConfig,
    border_margin_px: f64,
    request: &TargetRequest,
    now: &CellNow,
) -> Result<Target, TargetRefused> {
    match *request {
        TargetRequest::Features(features) => place_features(config, border_margin_px, features, now),
        TargetRequest::Pose { translation_m, rotation_rpy_rad } => {
            let values = translation_m.iter().chain(rotation_rpy_rad.iter());
            if !values.into_iter().all(|v| v.is_finite()) {
                return Err(TargetRefused::NotFinite);
            }
            let camera_from_board = vservo_config::pose_from_rpy(translation_m, rotation_rpy_rad);
            let (features, depths) =
                config.camera.project_marks_with_depths(&config.board, &camera_from_board)?;
            check_features(config, border_margin_px, &features)?;
            check_reachable(config, &camera_from_board, now)?;
            Ok(Target { features, depths })
        }
        TargetRequest::Teach => {
            let features = now.features_seen.ok_or(TargetRefused::MarksNotSeen)?;
            let camera_from_board = config
                .camera
                .board_pose_from_features(&config.board, &features)
                .ok_or(TargetRefused::BoardPoseNotFound)?;
            let (_, depths) = config.camera.project_marks_with_depths(&config.board, &camera_from_board)?;
            check_features(config, border_margin_px, &features)?;
            Ok(Target { features, depths })
        }
    }
}

/// Features as a target: checked, then the camera pose that sees the board so gives the depths, and must
/// be reachable.
fn place_features(
    config: &CellConfig,
    border_margin_px: f64,
    features: FeatureVector,
    now: &CellNow,
) -> Result<Target, TargetRefused> {
    check_features(config, border_margin_px, &features)?;
    let camera_from_board = config
        .camera
        .board_pose_from_features(&config.board, &features)
        .ok_or(TargetRefused::NoCameraPose)?;
    let (seen, depths) = config.camera.project_marks_with_depths(&config.board, &camera_from_board)?;
    let off_px = (seen - features).amax();
    if off_px > TARGET_POSE_FIT_PX {
        return Err(TargetRefused::NotAnImageOfTheBoard { off_px });
    }
    check_reachable(config, &camera_from_board, now)?;
    Ok(Target { features, depths })
}

/// Finite, inside the image clear of the margin, marks apart, in the layout's orientation: what every target
/// must be, and what the target in force must still be after a reload changes the barrier's margin.
pub fn check_features(
    config: &CellConfig,
    border_margin_px: f64,
    features: &FeatureVector,
) -> Result<(), TargetRefused> {
    if !features.iter().all(|v| v.is_finite()) {
        return Err(TargetRefused::NotFinite);
    }
    inside_margin(&config.camera, features, border_margin_px)?;
    marks_apart(features)?;
    if quad_area(features).signum() != quad_area(&config.desired.features).signum() {
        return Err(TargetRefused::Mirrored);
    }
    Ok(())
}

/// Every mark inside the image, [`TARGET_BORDER_MARGIN_PX`] or the barrier's margin (whichever is wider)
/// from its border: the barrier would keep the servo from a target inside its margin.
fn inside_margin(
    camera: &vservo_scene::CameraIntrinsics,
    features: &FeatureVector,
    barrier_margin_px: f64,
) -> Result<(), TargetRefused> {
    let (width_px, height_px) = (camera.width_px(), camera.height_px());
    let margin_px = TARGET_BORDER_MARGIN_PX.max(barrier_margin_px);
    for mark in 0..MARKS {
        let (x, y) = (features[2 * mark], features[2 * mark + 1]);
        // (judged where the lens shows the mark: the features are pinhole pixels)
        let observed = camera.observed_of_pinhole(&nalgebra::Point2::new(x, y));
        if !camera.contains_with_margin(&observed, margin_px) {
            return Err(TargetRefused::OutsideImage {
                mark,
                x,
                y,
                margin_px,
                barrier_margin: barrier_margin_px > TARGET_BORDER_MARGIN_PX,
                width_px,
                height_px,
            });
        }
    }
    Ok(())
}

/// No two marks closer than [`TARGET_MIN_SEPARATION_PX`].
fn marks_apart(features: &FeatureVector) -> Result<(), TargetRefused> {
    for first in 0..MARKS {
        for second in first + 1..MARKS {
            let apart_px = (features[2 * first] - features[2 * second])
                .hypot(features[2 * first + 1] - features[2 * second + 1]);
            if apart_px < TARGET_MIN_SEPARATION_PX {
                return Err(TargetRefused::MarksTooClose { first, second, apart_px });
            }
        }
    }
    Ok(())
}

/// Signed area of the quadrilateral of the four marks in feature order (shoelace; px²).
fn quad_area(features: &FeatureVector) -> f64 {
    let mut twice = 0.0;
    for a in 0..MARKS {
        let b = (a + 1) % MARKS;
        twice += features[2 * a] * features[2 * b + 1] - features[2 * b] * features[2 * a + 1];
    }
    twice / 2.0
}

/// The arm can put the camera at `camera_from_board` with the board where it is now.
fn check_reachable(
    config: &CellConfig,
    camera_from_board: &IsometryMatrix3<f64>,
    now: &CellNow,
) -> Result<(), TargetRefused> {
    let (base_from_board, joints_now) = board_and_joints_now(config, now);
    let base_from_tool = match config.fixed_camera {
        None => base_from_board * camera_from_board.inverse() * config.tool_from_camera.inverse(),
        Some(_) => config.mount().base_from_tool_seeing(camera_from_board, &base_from_board),
    };
    config.arm.reach(&base_from_tool, &joints_now).map(|_| ()).ok_or(TargetRefused::Unreachable)
}

/// Where the board is, in the base frame, and the joints now: the camera's pose from forward kinematics
/// times the board's pose the features give. Before both are heard, the configuration's desired arrangement.
fn board_and_joints_now(config: &CellConfig, now: &CellNow) -> (IsometryMatrix3<f64>, JointVector) {
    let seen = now.features_seen.and_then(|f| config.camera.board_pose_from_features(&config.board, &f));
    match (now.joints, seen) {
        (Some(joints), Some(camera_from_board)) => {
            (config.base_from_camera_at(&config.arm, &joints) * camera_from_board, joints)
        }
        (Some(joints), None) => (config.base_from_board(&config.arm), joints),
        (None, _) => (config.base_from_board(&config.arm), config.desired.joints),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> CellConfig {
        vservo_config::Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml")
            .expect("the default")
            .cell
    }

    /// A target the default cell reaches (the integration test's).
    fn reachable() -> FeatureVector {
        FeatureVector::from([161.0, 168.0, 328.0, 178.0, 349.0, 75.0, 182.0, 70.0])
    }

    #[test]
    fn features_that_image_the_board_are_placed_with_their_depths() {
        let config = config();
        let placed = place(&config, 0.0, &TargetRequest::Features(reachable()), &CellNow::default())
            .expect("a reachable target");
        assert_eq!(placed.features, reachable());
        assert!(placed.depths.iter().all(|z| *z > 0.0), "{:?}", placed.depths);
        // the desired features are a target too, at the desired depths
        let desired = config.desired.features;
        let placed = place(&config, 0.0, &TargetRequest::Features(desired), &CellNow::default())
            .expect("the configured target");
        assert!((placed.depths - config.desired.depths).amax() < 1e-6, "{:?}", placed.depths);
    }

    #[test]
    fn each_bad_feature_target_is_refused_by_its_reason() {
        let config = config();
        let refused = |features: [f64; 8]| {
            place(&config, 0.0, &TargetRequest::Features(features.into()), &CellNow::default())
                .expect_err("refused")
        };
        let mut nan = reachable();
        nan[0] = f64::NAN;
        assert_eq!(refused(nan.into()), TargetRefused::NotFinite);
        assert!(matches!(
            refused([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 600.0]),
            TargetRefused::OutsideImage { mark: 3, barrier_margin: false, .. }
        ));
        assert!(matches!(
            refused([151.0, 168.0, 155.0, 170.0, 339.0, 75.0, 172.0, 70.0]),
            TargetRefused::MarksTooClose { first: 0, second: 1, .. }
        ));
        assert_eq!(refused([151.0, 168.0, 172.0, 70.0, 339.0, 75.0, 318.0, 178.0]), TargetRefused::Mirrored);
        assert!(matches!(
            refused([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 210.0, 70.0]),
            TargetRefused::NotAnImageOfTheBoard { off_px } if off_px > TARGET_POSE_FIT_PX
        ));
    }

    #[test]
    fn a_target_is_kept_clear_of_the_barriers_margin_when_it_is_wider_than_the_border_margin() {
        let config = config();
        // mark 4 at 15 px from the top
        let target = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 15.0]);
        assert!(inside_margin(&config.camera, &target, 0.0).is_ok());
        let refused = inside_margin(&config.camera, &target, 20.0).expect_err("inside the barrier's margin");
        assert!(matches!(refused, TargetRefused::OutsideImage { mark: 3, barrier_margin: true, .. }));
        assert!(
            refused.to_string().contains("mark 4")
                && refused.to_string().contains("controller.border_margin_px")
        );
        let refused =
            inside_margin(&config.camera, &target.map(|v| v - 10.0), 0.0).expect_err("within 10 px");
        assert!(!refused.to_string().contains("controller.border_margin_px"), "{refused}");
    }

    #[test]
    fn a_pose_is_refused_when_a_number_is_not_finite_the_marks_crowd_or_the_board_is_behind_the_camera() {
        let config = config();
        let pose = |z: f64, x: f64| TargetRequest::Pose {
            translation_m: Vector3::new(x, 0.0, z),
            rotation_rpy_rad: Vector3::zeros(),
        };
        let now = CellNow::default();
        assert_eq!(place(&config, 0.0, &pose(f64::NAN, 0.0), &now), Err(TargetRefused::NotFinite));
        // a board 3 m away: its marks crowd together
        assert!(matches!(
            place(&config, 0.0, &pose(3.0, 0.0), &now),
            Err(TargetRefused::MarksTooClose { .. })
        ));
        // behind the camera
        assert!(matches!(place(&config, 0.0, &pose(-0.5, 0.0), &now), Err(TargetRefused::Projection(_))));
    }

    #[test]
    fn the_desired_pose_is_a_target_and_one_far_beyond_the_arm_is_not() {
        let config = config();
        let desired = &config.desired.camera_from_board;
        let now = CellNow { joints: Some(config.desired.joints), features_seen: None };
        let placed = place(
            &config,
            0.0,
            &TargetRequest::Pose {
                translation_m: desired.translation.vector,
                rotation_rpy_rad: {
                    let (r, p, y) = desired.rotation.euler_angles();
                    Vector3::new(r, p, y)
                },
            },
            &now,
        )
        .expect("the desired pose");
        assert!((placed.features - config.desired.features).amax() < 1e-6);
        // the board seen 2.5 m further along the optical axis: the desired view of it is out of reach
        let far = nalgebra::Translation3::new(0.0, 0.0, 2.5) * desired;
        let seen_far = config.camera.project_marks(&config.board, &far).expect("in front");
        let now = CellNow { joints: Some(config.desired.joints), features_seen: Some(seen_far) };
        let desired_view = TargetRequest::Features(config.desired.features);
        assert_eq!(place(&config, 0.0, &desired_view, &now), Err(TargetRefused::Unreachable));
    }

    #[test]
    fn teach_takes_what_the_camera_sees_and_needs_all_four_marks() {
        let config = config();
        assert_eq!(
            place(&config, 0.0, &TargetRequest::Teach, &CellNow::default()),
            Err(TargetRefused::MarksNotSeen)
        );
        let now = CellNow { joints: None, features_seen: Some(reachable()) };
        let taught = place(&config, 0.0, &TargetRequest::Teach, &now).expect("taught");
        assert_eq!(taught.features, reachable());
        // seen inside the barrier's margin: refused like any target
        let near_border = FeatureVector::from([151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 15.0]);
        let now = CellNow { joints: None, features_seen: Some(near_border) };
        assert!(matches!(
            place(&config, 20.0, &TargetRequest::Teach, &now),
            Err(TargetRefused::OutsideImage { mark: 3, barrier_margin: true, .. })
        ));
    }

    #[test]
    fn the_area_sign_follows_the_order_of_the_marks() {
        let square = FeatureVector::from([0.0, 0.0, 10.0, 0.0, 10.0, 10.0, 0.0, 10.0]);
        let mirrored = FeatureVector::from([0.0, 0.0, 0.0, 10.0, 10.0, 10.0, 10.0, 0.0]);
        assert_eq!(quad_area(&square), 100.0);
        assert_eq!(quad_area(&mirrored), -100.0);
    }
}
