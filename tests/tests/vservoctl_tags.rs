//! `vservoctl tags` on real photographs (AprilRobotics apriltag's test data: colour JPEGs of 799 × 533, every tag
//! id 0; scripts/setup-tag-photos.sh; and pupil-labs/apriltags' 26 test images, tests/data/tag-photos), against
//! pupil-apriltags — the C library as Python users run it — on the very same pixels: everything the reference finds
//! at full resolution, vservo lists, and nothing else.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;
use vservo_system_tests::{ScratchDir, repository_root, run, unique};

fn photographs() -> Vec<String> {
    let folder = repository_root().join("target/tag-photos");
    let mut photos: Vec<String> = std::fs::read_dir(&folder)
        .unwrap_or_else(|e| panic!("{}: {e} (scripts/setup-tag-photos.sh makes it)", folder.display()))
        .flatten()
        .map(|entry| entry.path())
        .filter(|path| path.extension().is_some_and(|e| e == "jpg"))
        .map(|path| path.display().to_string())
        .collect();
    photos.sort();
    assert_eq!(photos.len(), 3, "the three photographs");
    photos
}

/// `vservoctl tags --json PICTURES…`: one object per picture.
fn tags_json(pictures: &[String]) -> Vec<Value> {
    let mut args = vec!["tags", "--json"];
    args.extend(pictures.iter().map(String::as_str));
    let out = run("vservoctl", &args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).expect("JSON")).collect()
}

fn centre(corners: &Value) -> (f64, f64) {
    let points = corners.as_array().expect("corners");
    let sum = points
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p[0].as_f64().expect("x"), y + p[1].as_f64().expect("y")));
    (sum.0 / points.len() as f64, sum.1 / points.len() as f64)
}

/// Whether `tags` holds a tag of `id` whose centre is within `within_px` of `at`.
fn holds(tags: &[Value], id: u64, at: (f64, f64), within_px: f64) -> bool {
    tags.iter().any(|t| {
        let c = centre(&t["corners_px"]);
        t["id"].as_u64() == Some(id) && (c.0 - at.0).hypot(c.1 - at.1) <= within_px
    })
}

/// The tags the C library's own test expects in a photograph (its `.txt` beside it), as `{id, corners_px}`.
fn published_tags(photo: &str) -> Vec<Value> {
    let path = PathBuf::from(photo).with_extension("txt");
    vservo_vision::source::read_apriltag_test_detections(&path)
        .expect("the expected tags")
        .into_iter()
        .map(|(id, corners)| serde_json::json!({"id": id, "corners_px": corners.map(|c| [c.x, c.y])}))
        .collect()
}

/// A colour JPEG of an odd size, every tag of the same id: each listed, marked repeated, with its corners, centre
/// and quality; nothing refused for its colour, its size or the repeated id.
#[test]
fn tags_lists_every_tag_of_a_colour_jpeg_of_any_size_each_repeated_id_once_per_tag() {
    let seen = tags_json(&photographs());
    assert_eq!(seen.len(), 3);
    let mut total = 0;
    for picture in &seen {
        assert_eq!(
            (picture["width_px"].as_u64(), picture["height_px"].as_u64()),
            (Some(799), Some(533)),
            "{picture}"
        );
        assert_eq!(picture["colour"], "Rgb8", "{picture}");
        let tags = picture["tags"].as_array().expect("tags");
        assert!(tags.len() >= 9, "{picture}");
        for tag in tags {
            assert_eq!(tag["id"], 0, "{tag}");
            assert_eq!(tag["repeated"], true, "{tag}");
            assert_eq!(tag["corners_px"].as_array().map(Vec::len), Some(4), "{tag}");
            assert!(tag["decision_margin"].as_f64().is_some_and(|m| m > 0.0), "{tag}");
            assert_eq!(tag["refined"].as_array().map(Vec::len), Some(4), "{tag}");
        }
        total += tags.len();
    }
    // the C library's own test expects 47; two of the smallest are lost to the JPEG decoder's rounding
    // (crates/vservo-vision/tests/real_photographs.rs)
    assert_eq!(total, 45);
}

/// On the same pixels (OpenCV's grayscale of each JPEG, as PGM), every tag pupil-apriltags finds with quads at full
/// resolution vservo lists at the same place; and every tag vservo lists is pupil-apriltags', or one the C
/// library's own test expects in that photograph (pupil-apriltags' build misses one of those): no false detection.
#[test]
fn tags_finds_what_pupil_apriltags_finds_at_full_resolution_and_nothing_else() {
    let scratch = ScratchDir::new(&unique("tags-pupil"));
    let reference = pupil_reference(&scratch, &photographs());
    let pgms: Vec<String> = reference.iter().map(|r| r["pgm"].as_str().expect("pgm").to_string()).collect();
    let seen = tags_json(&pgms);
    let (mut theirs, mut ours, mut beyond_pupil) = (0, 0, 0);
    for (picture, expected) in seen.iter().zip(&reference) {
        assert_eq!(picture["colour"], "L8", "{picture}");
        let (found, wanted) =
            (picture["tags"].as_array().expect("tags"), expected["tags"].as_array().expect("tags"));
        for tag in wanted {
            let at = centre(&tag["corners_px"]);
            assert!(
                holds(found, tag["id"].as_u64().expect("id"), at, 1.0),
                "{}: {tag} not listed",
                picture["image"]
            );
        }
        let published = published_tags(expected["image"].as_str().expect("image"));
        for tag in found {
            let (id, at) = (tag["id"].as_u64().expect("id"), centre(&tag["corners_px"]));
            if !holds(wanted, id, at, 1.0) {
                assert!(holds(&published, id, at, 3.0), "{}: {tag} is no reference's", picture["image"]);
                beyond_pupil += 1;
            }
        }
        theirs += wanted.len();
        ours += found.len();
    }
    println!(
        "pupil-apriltags {theirs} tags, vservo {ours} ({beyond_pupil} of them the C library's test expects)"
    );
    assert!(theirs >= 40, "the premise: the reference finds most of the photographs' 47 tags ({theirs})");
}

/// pupil-apriltags' tags in `pictures` at full resolution, one object per picture (`image`, `pgm`: its grayscale as
/// OpenCV makes it, written into `scratch`, `tags`).
fn pupil_reference(scratch: &ScratchDir, pictures: &[String]) -> Vec<Value> {
    let python = repository_root().join("target/python-venv/bin/python");
    let out = Command::new(&python)
        .arg(repository_root().join("tests/python/pupil_tags.py"))
        .arg(&scratch.0)
        .args(pictures)
        .output()
        .expect("python runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).expect("JSON")).collect()
}

/// pupil-labs/apriltags' 26 test images (tests/data/tag-photos/pupil-apriltags, MANIFEST.md: tags on an office
/// table through an undistorted wide lens, 640 × 480 colour; one tag turned −70° to 70°, 1056 × 792): on the same
/// pixels vservo lists every tag the C library finds at full resolution, at the same place, and no other.
#[test]
fn tags_finds_what_pupil_apriltags_finds_on_pupil_labs_test_images_and_nothing_else() {
    let folder = repository_root().join("tests/data/tag-photos/pupil-apriltags");
    let mut pictures: Vec<String> = std::fs::read_dir(&folder)
        .expect("the committed photographs")
        .flatten()
        .map(|entry| entry.path())
        .filter(|path| path.extension().is_some_and(|e| e == "png"))
        .map(|path| path.display().to_string())
        .collect();
    pictures.sort();
    assert_eq!(pictures.len(), 26);
    let scratch = ScratchDir::new(&unique("tags-pupil-labs"));
    let reference = pupil_reference(&scratch, &pictures);
    let pgms: Vec<String> = reference.iter().map(|r| r["pgm"].as_str().expect("pgm").to_string()).collect();
    let seen = tags_json(&pgms);
    let (mut theirs, mut ours, mut missed, mut extra) = (0, 0, Vec::new(), Vec::new());
    for (picture, expected) in seen.iter().zip(&reference) {
        let (found, wanted) =
            (picture["tags"].as_array().expect("tags"), expected["tags"].as_array().expect("tags"));
        for tag in wanted {
            if !holds(found, tag["id"].as_u64().expect("id"), centre(&tag["corners_px"]), 1.0) {
                missed.push(format!("{}: {tag}", picture["image"]));
            }
        }
        for tag in found {
            if !holds(wanted, tag["id"].as_u64().expect("id"), centre(&tag["corners_px"]), 1.0) {
                extra.push(format!("{}: {tag}", picture["image"]));
            }
        }
        theirs += wanted.len();
        ours += found.len();
    }
    println!(
        "pupil-apriltags {theirs} tags, vservo {ours}; missed {missed:?}; not the reference's {extra:?}"
    );
    assert!(theirs >= 26, "the premise: the reference finds the tags ({theirs})");
    assert!(missed.is_empty(), "{missed:#?}");
    assert!(extra.is_empty(), "{extra:#?}");
}

/// `--draw` writes the picture, its size, with the tags drawn in colour; a second time only with --force; and
/// `vision extract` reads the colour JPEG and names both sizes in every mark's reason, the picture not being the
/// configured camera's.
#[test]
fn tags_draws_the_picture_annotated_and_extract_names_a_size_that_is_not_the_cameras() {
    let scratch = ScratchDir::new(&unique("tags-draw"));
    let photo = photographs().remove(0);
    let drawn: PathBuf = scratch.0.join("drawn.png");
    let draw = |force: bool| {
        let mut args = vec!["tags", photo.as_str(), "--draw", drawn.to_str().expect("a UTF-8 path")];
        if force {
            args.push("--force");
        }
        run("vservoctl", &args)
    };
    assert!(draw(false).status.success());
    let picture = image::open(&drawn).expect("a PNG").to_rgb8();
    assert_eq!(picture.dimensions(), (799, 533));
    let coloured = picture.pixels().filter(|p| p[0] != p[1] || p[1] != p[2]).count();
    assert!(coloured > 500, "{coloured} coloured pixels: the tags are drawn");
    assert!(!draw(false).status.success(), "an existing file is kept without --force");
    assert!(draw(true).status.success());
    let config = repository_root().join("config/vservo-apriltag.toml").display().to_string();
    let extract = run("vservoctl", &["vision", "extract", "--config", &config, &photo, "--json"]);
    assert!(extract.status.success(), "{}", String::from_utf8_lossy(&extract.stderr));
    let said: Value = serde_json::from_slice(&extract.stdout).expect("one JSON object");
    for reason in said["reasons"].as_array().expect("reasons") {
        let reason = reason.as_str().expect("a reason");
        assert!(reason.contains("799×533") && reason.contains("640×480"), "{said}");
    }
}
