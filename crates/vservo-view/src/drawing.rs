//! The cell as Foxglove shows it: vservo's messages turned into Foxglove's well-known schemas
//! (`foxglove.RawImage`, `foxglove.ImageAnnotations`, `foxglove.FrameTransforms`), so that a recording opens
//! as the camera's picture with the marks on it and the arm in 3D. Pure conversions; the recorder writes them.
//!
//! Every stamp in these messages is the host's CLOCK_MONOTONIC (as in vservo's own messages): an image and
//! its annotations carry the same capture stamp, which is how Foxglove's image panel pairs them.

use foxglove::messages::{
    CircleAnnotation, Color, FrameTransform, FrameTransforms, ImageAnnotations, Point2, PointsAnnotation,
    Quaternion, RawImage, TextAnnotation, Timestamp, Vector3,
};
use nalgebra::{IsometryMatrix3, UnitQuaternion};
use vservo_wire::{CameraImageHeader, FeaturesMsg, JointStateMsg, MarkStatus, SimWorldMsg};

/// Foxglove's topics of a recording.
pub const IMAGE_TOPIC: &str = "/camera/image";
/// The marks on the image.
pub const ANNOTATIONS_TOPIC: &str = "/camera/annotations";
/// The arm's links, the camera and the board.
pub const TRANSFORMS_TOPIC: &str = "/tf";
/// The image's frame.
pub const CAMERA_FRAME: &str = "camera";

/// A stamp in ns as Foxglove's timestamp.
pub(crate) fn timestamp(stamp_ns: u64) -> Timestamp {
    let (seconds, nanos) = vservo_time::Nanos(stamp_ns).split();
    Timestamp::new(seconds as u32, nanos)
}

fn color(r: f64, g: f64, b: f64) -> Option<Color> {
    Some(Color { r, g, b, a: 1.0 })
}

/// The camera's 8-bit gray image (`mono8`).
pub fn raw_image(header: &CameraImageHeader, pixels: &[u8]) -> RawImage {
    RawImage {
        timestamp: Some(timestamp(header.capture_stamp_ns)),
        frame_id: CAMERA_FRAME.to_string(),
        width: header.width,
        height: header.height,
        encoding: "mono8".to_string(),
        step: header.stride_bytes,
        data: pixels.to_vec().into(),
    }
}

/// The marks of a frame on its image: each mark the servo used as a circle, green where vservo refined its
/// position and orange where it is a tag decoder's corner (`refined_mask`), where it should be (`desired_px`)
/// as a blue circle, the error between them as a line, and each mark the frame lacks as a red text saying why,
/// at its desired position. With a tag, its decoder's margin and its edges' fit in the top left corner.
pub fn annotations(features: &FeaturesMsg, desired_px: Option<&[f64; 8]>) -> ImageAnnotations {
    let stamp = Some(timestamp(features.capture_stamp_ns));
    let mut circles = Vec::with_capacity(8);
    let mut lines = Vec::with_capacity(8);
    let mut texts = Vec::new();
    for mark in 0..4 {
        let measured = Point2 { x: features.features_px[2 * mark], y: features.features_px[2 * mark + 1] };
        let valid =
            features.valid_mask & (1 << mark) != 0 && measured.x.is_finite() && measured.y.is_finite();
        let desired = desired_px.map(|d| Point2 { x: d[2 * mark], y: d[2 * mark + 1] });
        if valid {
            let refined = features.refined_mask & (1 << mark) != 0;
            circles.push(CircleAnnotation {
                timestamp: stamp,
                position: Some(measured),
                diameter: 14.0,
                thickness: 2.0,
                fill_color: None,
                outline_color: if refined { color(0.1, 0.9, 0.2) } else { color(1.0, 0.55, 0.0) },
                metadata: Vec::new(),
            });
            if let Some(desired) = desired {
                lines.extend([measured, desired]);
            }
        } else {
            let why = MarkStatus::try_from(features.mark_status[mark]).map_or("unknown", MarkStatus::name);
            texts.push(TextAnnotation {
                timestamp: stamp,
                position: Some(desired.unwrap_or(Point2 { x: 10.0, y: 20.0 + 18.0 * mark as f64 })),
                text: format!("mark {} {why}", mark + 1),
                font_size: 14.0,
                text_color: color(1.0, 0.2, 0.2),
                background_color: Some(Color { r: 0.0, g: 0.0, b: 0.0, a: 0.6 }),
                metadata: Vec::new(),
            });
        }
        if let Some(desired) = desired {
            circles.push(CircleAnnotation {
                timestamp: stamp,
                position: Some(desired),
                diameter: 10.0,
                thickness: 1.0,
                fill_color: None,
                outline_color: color(0.2, 0.5, 1.0),
                metadata: Vec::new(),
            });
        }
    }
    if features.decision_margin.is_finite() {
        texts.push(tag_quality_text(features, stamp));
    }
    let points = if lines.is_empty() {
        Vec::new()
    } else {
        vec![PointsAnnotation {
            timestamp: stamp,
            // LINE_LIST: each pair of points is a segment
            r#type: 4,
            points: lines,
            outline_color: color(1.0, 0.8, 0.1),
            outline_colors: Vec::new(),
            fill_color: None,
            thickness: 1.5,
            metadata: Vec::new(),
        }]
    };
    ImageAnnotations { timestamp: stamp, circles, points, texts, metadata: Vec::new() }
}

/// A tag's quality as a line of text: the decoder's margin and corrected bits, each edge's fit RMS.
/// A bundle's tags used ("tags 1 2 4 of the bundle"), nothing for a single tag (mask 1) or none.
fn bundle_text(tags_used_mask: u16) -> String {
    if tags_used_mask <= 1 {
        return String::new();
    }
    let used: Vec<String> =
        (0..16).filter(|k| tags_used_mask & (1 << k) != 0).map(|k| (k + 1).to_string()).collect();
    format!(", bundle tags {}", used.join(" "))
}

fn tag_quality_text(features: &FeaturesMsg, stamp: Option<Timestamp>) -> TextAnnotation {
    let edges: Vec<String> = features
        .edge_rms_px
        .iter()
        .map(|rms| if rms.is_finite() { format!("{rms:.2}") } else { "—".to_string() })
        .collect();
    TextAnnotation {
        timestamp: stamp,
        position: Some(Point2 { x: 10.0, y: 100.0 }),
        text: format!(
            "tag margin {:.0}, {} bit(s) corrected, edges {} px{}",
            features.decision_margin,
            features.bits_corrected,
            edges.join(" "),
            bundle_text(features.tags_used_mask)
        ),
        font_size: 12.0,
        text_color: color(1.0, 1.0, 1.0),
        background_color: Some(Color { r: 0.0, g: 0.0, b: 0.0, a: 0.6 }),
        metadata: Vec::new(),
    }
}

fn transform(stamp_ns: u64, parent: &str, child: &str, pose: &IsometryMatrix3<f64>) -> FrameTransform {
    let t = pose.translation.vector;
    let q = UnitQuaternion::from_rotation_matrix(&pose.rotation);
    FrameTransform {
        timestamp: Some(timestamp(stamp_ns)),
        parent_frame_id: parent.to_string(),
        child_frame_id: child.to_string(),
        translation: Some(Vector3 { x: t.x, y: t.y, z: t.z }),
        rotation: Some(Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }),
    }
}

/// The arm's links (`base` → `link1` … `linkN`, N its joints) and the camera (`linkN` → `camera` on the hand,
/// `base` → `camera` fixed in the world) at a joint state; none
/// from a joint state of another arm's joint count (drawn, it would be drawn wrongly).
pub fn arm_transforms(
    arm: &vservo_arm::SerialArm,
    mount: &vservo_scene::CameraMount,
    state: &JointStateMsg,
) -> FrameTransforms {
    let Some(q) = state.arm_q_rad(arm.joint_count()).map(vservo_arm::JointVector::from) else {
        return FrameTransforms { transforms: Vec::new() };
    };
    let frames = arm.link_frames(&q);
    let mut transforms: Vec<FrameTransform> = frames
        .iter()
        .take(arm.joint_count())
        .enumerate()
        .map(|(i, base_from_link)| {
            transform(state.stamp_ns, "base", &format!("link{}", i + 1), base_from_link)
        })
        .collect();
    match mount {
        // the camera rides on the last link, whatever the arm's number of joints
        vservo_scene::CameraMount::Hand { tool_from_camera } => {
            let hand = format!("link{}", arm.joint_count());
            transforms.push(transform(state.stamp_ns, &hand, CAMERA_FRAME, tool_from_camera));
        }
        vservo_scene::CameraMount::World { base_from_camera, .. } => {
            transforms.push(transform(state.stamp_ns, "base", CAMERA_FRAME, base_from_camera));
        }
    }
    FrameTransforms { transforms }
}

/// The board (`base` → `board`), which only a simulation knows; stamped with the joint state of its tick.
pub fn board_transform(world: &SimWorldMsg, stamp_ns: u64) -> FrameTransforms {
    // a pose that is none (not finite, not a rotation) is not drawn
    let pose = vservo_scene::pose_rows::pose_from_rows(&world.base_from_board);
    FrameTransforms {
        transforms: pose.iter().map(|pose| transform(stamp_ns, "base", "board", pose)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn features(valid_mask: u32) -> FeaturesMsg {
        FeaturesMsg {
            valid_mask,
            frame: 3,
            capture_tick: 255,
            capture_stamp_ns: 12_345_678_901,
            stamp_ns: 12_400_000_000,
            features_px: [100.0, 110.0, 300.0, 120.0, 310.0, 330.0, 90.0, 320.0],
            mark_status: [
                MarkStatus::Valid.code(),
                MarkStatus::Valid.code(),
                MarkStatus::OutsideImage.code(),
                MarkStatus::Valid.code(),
            ],
            ..FeaturesMsg::default()
        }
    }

    #[test]
    fn the_marks_the_servo_used_are_drawn_where_the_features_say_and_a_missing_one_is_named() {
        let desired = [151.0, 168.0, 318.0, 178.0, 339.0, 75.0, 172.0, 70.0];
        let message = features(0b1011);
        let drawn = annotations(&message, Some(&desired));
        let measured: Vec<(f64, f64)> = drawn
            .circles
            .iter()
            .filter(|c| c.diameter == 14.0)
            .map(|c| c.position.map_or((f64::NAN, f64::NAN), |p| (p.x, p.y)))
            .collect();
        assert_eq!(measured, vec![(100.0, 110.0), (300.0, 120.0), (90.0, 320.0)]);
        assert_eq!(drawn.circles.iter().filter(|c| c.diameter == 10.0).count(), 4);
        assert_eq!(drawn.points[0].points.len(), 6, "one error segment per mark used");
        assert_eq!(drawn.texts.len(), 1);
        assert_eq!(drawn.texts[0].text, "mark 3 outside the image");
        let stamp = drawn.timestamp.expect("stamped");
        assert_eq!((stamp.sec(), stamp.nsec()), (12, 345_678_901));
    }

    #[test]
    fn a_decoders_corner_is_drawn_apart_from_refined_ones_and_the_tags_quality_is_written() {
        let message = FeaturesMsg {
            refined_mask: 0b0111,
            edge_rms_px: [0.08, f64::NAN, 0.12, 0.1],
            decision_margin: 84.6,
            bits_corrected: 1,
            ..features(0b1111)
        };
        let drawn = annotations(&message, None);
        let outlines: Vec<_> = drawn.circles.iter().map(|c| c.outline_color).collect();
        assert_eq!(outlines[..3], [color(0.1, 0.9, 0.2), color(0.1, 0.9, 0.2), color(0.1, 0.9, 0.2)]);
        assert_eq!(outlines[3], color(1.0, 0.55, 0.0), "mark 4 is the decoder's corner");
        assert_eq!(drawn.texts.len(), 1);
        assert_eq!(drawn.texts[0].text, "tag margin 85, 1 bit(s) corrected, edges 0.08 — 0.12 0.10 px");
        // a bundle with its third tag unseen says which tags gave the corners
        let bundle = FeaturesMsg { tags_used_mask: 0b1011, ..message };
        assert!(annotations(&bundle, None).texts[0].text.ends_with("px, bundle tags 1 2 4"));
        // disc marks: no tag line
        assert!(annotations(&features(0b1111), None).texts.is_empty());
    }

    #[test]
    fn the_camera_sits_on_the_last_link_and_the_links_chain_from_the_base() {
        let arm = vservo_arm::puma560::puma560();
        let state = JointStateMsg {
            stamp_ns: 5,
            q_rad: [0.1, -0.5, 0.3, 0.0, 0.4, 0.2, 0.0],
            ..JointStateMsg::default()
        };
        let tool_from_camera = IsometryMatrix3::translation(0.0, 0.0, 0.1);
        let frames = arm_transforms(&arm, &vservo_scene::CameraMount::Hand { tool_from_camera }, &state);
        assert_eq!(frames.transforms.len(), 7);
        let tool =
            arm.base_from_tool(&vservo_arm::JointVector::from(state.arm_q_rad(6).expect("six joints")));
        let link6 = frames.transforms[5].translation.expect("translation");
        assert!((link6.x - tool.translation.x).abs() < 1e-12 && (link6.z - tool.translation.z).abs() < 1e-12);
        assert_eq!(frames.transforms[6].parent_frame_id, "link6");
    }
}
