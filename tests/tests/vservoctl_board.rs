//! `vservoctl board`: the calibration board as an SVG to print at scale. OpenCV's AprilTag 36h11 detector (not
//! vservo's) finds every tag of the rasterised SVG with its id, each corner where the layout says, to a tenth
//! of a millimetre (tests/python/check_board_svg.py); what cannot be made is refused with exit code 2.

use vservo_system_tests::{repository_root, run};

fn check(args: &[&str], tags: u64) -> serde_json::Value {
    let dir = std::env::temp_dir().join(format!("vservo-board-{}-{tags}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let (svg, layout) = (dir.join("board.svg"), dir.join("board.json"));
    let mut all = vec!["board", "--out", svg.to_str().expect("utf-8"), "--json"];
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
