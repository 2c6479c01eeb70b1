//! `vservoctl board`: the calibration board as an SVG to print at scale. OpenCV's AprilTag 36h11 detector (not
//! vservo's) finds every tag of the rasterised SVG with its id, each corner where the layout says, to a tenth
//! of a millimetre (tests/python/check_board_svg.py); what cannot be made is refused with exit code 2.

use vservo_system_tests::{repository_root, run};

fn check(args: &[&str], tags: u64) -> serde_json::Value {
    check_of("board", args, tags)
}

/// `vservoctl <command> --out FILE.svg --json <args>`, checked by OpenCV's detector.
fn check_of(command: &str, args: &[&str], tags: u64) -> serde_json::Value {
    let dir = std::env::temp_dir().join(format!("vservo-{command}-{}-{tags}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let (svg, layout) = (dir.join("board.svg"), dir.join("board.json"));
    let mut all = vec![command, "--out", svg.to_str().expect("utf-8"), "--json"];
    all.extend_from_slice(args);
    let output = run("vservoctl", &all);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    std::fs::write(&layout, &output.stdout).expect("written");
    let checked = std::process::Command::new(repository_root().join("target/python-venv/bin/python"))
        .arg(repository_root().join("tests/python/check_board_svg.py"))
        .args([&svg, &layout])
        .output()
        .expect("python runs");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(checked.status.success(), "{}", String::from_utf8_lossy(&checked.stderr));
    let figures: serde_json::Value = serde_json::from_slice(&checked.stdout).expect("JSON");
    eprintln!("{figures}");
    assert_eq!(figures["tags_found"].as_u64(), Some(tags), "{figures}");
    assert!(figures["worst_corner_mm"].as_f64().expect("a number") < 0.1, "{figures}");
    figures
}

#[test]
fn every_tag_of_the_printed_board_is_found_where_the_layout_says() {
    // the default board fits A4 landscape (297 × 210 mm)
    let figures = check(&[], 35);
    let size: Vec<f64> =
        figures["size_mm"].as_array().expect("size").iter().filter_map(|v| v.as_f64()).collect();
    assert!(size[0] <= 297.0 && size[1] <= 210.0, "{size:?}");
    check(
        &["--rows", "3", "--columns", "4", "--tag-size-mm", "40", "--gap-mm", "12", "--first-id", "100"],
        12,
    );
}

#[test]
fn a_board_it_cannot_make_is_refused_with_the_reason() {
    let out = std::env::temp_dir().join(format!("vservo-board-bad-{}.svg", std::process::id()));
    let out = out.to_str().expect("utf-8");
    for (args, reason) in [
        (vec!["--gap-mm", "5"], "a quarter of the tag"),
        (vec!["--rows", "0"], "1 to 64 rows"),
        (vec!["--rows", "30", "--columns", "30"], "tag36h11 has ids 0 to 586"),
        (vec!["--tag-size-mm", "NaN"], "the tag must be"),
    ] {
        let mut all = vec!["board", "--out", out];
        all.extend_from_slice(&args);
        let output = run("vservoctl", &all);
        assert_eq!(output.status.code(), Some(2), "{args:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(reason), "{args:?}: {stderr}");
    }
    let output = run("vservoctl", &["board", "--out", "/tmp/board.png"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&output.stderr).contains(".svg"));
    assert!(!std::path::Path::new(out).exists(), "nothing written for a refused board");
}

/// `vservoctl tag`: one tag at its stated scale, read by OpenCV's detector as the id asked for with a black square
/// of the size asked for (its sides measured on the rasterised print, 4 px/mm), with a margin it can be found in;
/// the caption says the id, the size and which edge is up. A tag it cannot make is refused (exit 2).
#[test]
fn a_printed_tag_is_read_with_its_id_and_size() {
    let figures = check_of("tag", &["--id", "3", "--size-mm", "80"], 1);
    assert_eq!(figures["ids"], serde_json::json!([3]), "{figures}");
    let sides: Vec<f64> =
        figures["sides_mm"]["3"].as_array().expect("sides").iter().filter_map(|v| v.as_f64()).collect();
    assert_eq!(sides.len(), 4);
    assert!(sides.iter().all(|side| (side - 80.0).abs() < 0.25), "sides {sides:?} mm, 80 asked");
    let out = std::env::temp_dir().join(format!("vservo-tag-{}.svg", std::process::id()));
    let output =
        run("vservoctl", &["tag", "--id", "586", "--size-mm", "30", "--out", out.to_str().expect("utf-8")]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let svg = std::fs::read_to_string(&out).expect("the SVG");
    let _ = std::fs::remove_file(&out);
    for caption in
        ["tag36h11 id 586", "black square 30 mm", "top of the page is the tag's top", "20 mm</text>"]
    {
        assert!(svg.contains(caption), "{caption:?} missing");
    }
    // the configured target: config/vservo-bundle.toml's four 70 mm tags on one sheet, each where the layout says
    let bundle = repository_root().join("config/vservo-bundle.toml");
    let figures = check_of("tag", &["--config", bundle.to_str().expect("utf-8")], 4);
    assert_eq!(figures["ids"], serde_json::json!([10, 11, 12, 13]), "{figures}");
    for (args, reason) in
        [(["--id", "587", "--size-mm", "80"], "586"), (["--id", "1", "--size-mm", "-5"], "tag")]
    {
        let mut all = vec!["tag", "--out", "/tmp/never-written-tag.svg"];
        all.extend_from_slice(&args);
        let output = run("vservoctl", &all);
        assert_eq!(output.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&output.stderr).contains(reason), "{args:?}");
    }
}
