//! `vservoctl sim` as a user runs it: it writes the summary, the data and the plots.

use vservo_system_tests::{repository_root, run};

#[test]
fn sim_writes_summary_csvs_and_plots() {
    let out = std::env::temp_dir().join(format!("vservo-sim-{}", std::process::id()));
    let config = repository_root().join("config/scenarios/translation-step.toml");
    let output = run(
        "vservoctl",
        &[
            "sim",
            "--config",
            config.to_str().expect("utf-8"),
            "--duration",
            "3",
            "--controller",
            "delay-aware",
            "--plant",
            "kinematic",
            "--out",
            out.to_str().expect("utf-8"),
        ],
    );
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary.json"))
            .expect("JSON");
    assert_eq!(summary["law"], "delay-aware");
    assert_eq!(summary["plant"], "kinematic");
    for key in ["settling_time_s", "overshoot_percent", "final_error_px"] {
        assert!(summary[key].as_f64().is_some(), "{key}: {summary}");
    }
    assert!(summary["final_error_px"].as_f64().expect("number") < 0.5);
    let features = std::fs::read_to_string(out.join("features.csv")).expect("features.csv");
    let header = features.lines().next().expect("a header");
    assert!(header.starts_with("t,x1,y1,x2,y2,x3,y3,x4,y4,true_x1,true_y1,"), "{header}");
    assert_eq!(header.split(',').count(), 17);
    // one row per 85 ms frame over 3 s
    assert_eq!(features.lines().count(), 1 + 36);
    let joints = std::fs::read_to_string(out.join("joints.csv")).expect("joints.csv");
    assert_eq!(joints.lines().count(), 1 + 300, "every 10 ms");
    for plot in ["trajectory.svg", "error.svg"] {
        let svg = std::fs::read_to_string(out.join(plot)).expect("a plot");
        assert!(svg.starts_with("<svg") && svg.contains("polyline"), "{plot}");
    }
    let _ = std::fs::remove_dir_all(out);
    // overrides are checked
    let output = run("vservoctl", &["sim", "--config", config.to_str().expect("utf-8"), "--duration", "-1"]);
    assert_eq!(output.status.code(), Some(2));
}
