//! `vservoctl gains` and `vservoctl stability` on the default configuration and on broken ones.

use serde_json::Value;
use vservo_system_tests::{config_with, default_config, run};

fn json_of(command: &str, config: &str) -> Value {
    let output = run("vservoctl", &[command, "--config", config, "--json"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).expect("one JSON object")
}

fn floats(value: &Value) -> Vec<f64> {
    value.as_array().expect("an array").iter().map(|v| v.as_f64().expect("a number")).collect()
}

#[test]
fn gains_json_matches_the_library_design() {
    let path = default_config();
    let json = json_of("gains", path.to_str().expect("utf-8 path"));
    let config = vservo_config::Config::load(&path).expect("valid");
    let gains = vservo_control::Gains::design(&config.cell.gains_spec()).expect("designable");
    let k = json["K"].as_array().expect("K rows");
    assert_eq!(k.len(), 6);
    for (r, row) in k.iter().enumerate() {
        let row = floats(row);
        assert_eq!(row.len(), 8);
        for (c, value) in row.iter().enumerate() {
            assert!((value - gains.paper.k[(r, c)]).abs() < 1e-15, "K[{r}][{c}]");
        }
    }
    assert_eq!(floats(&json["singular_values"]).len(), 6);
    let eig = floats(&json["eig_abs"]);
    assert_eq!(eig.len(), 8);
    assert_eq!(eig.iter().filter(|l| (*l - 1.0).abs() < 1e-9).count(), 2, "{eig:?}");
    let delayed = floats(&json["eig_abs_delayed"]);
    assert_eq!(delayed.len(), 12, "six modes times (delay + 1) frames");
    assert!(delayed[0] < 1.0, "the default gain is stable with its delay: {delayed:?}");
}

#[test]
fn stability_json_has_every_margin_and_each_is_positive() {
    let path = default_config();
    let json = json_of("stability", path.to_str().expect("utf-8 path"));
    for prefix in ["", "delayed_", "delay_aware_"] {
        for key in ["trans_x", "trans_y", "trans_z", "rot_x", "rot_y", "rot_z"] {
            let value = json[format!("{prefix}{key}")].as_f64().unwrap_or_else(|| panic!("{prefix}{key}"));
            assert!(value > 0.0, "{prefix}{key} = {value}");
        }
    }
    // the paper's 10° rotation step about the optical axis is within the margin
    assert!(json["rot_z"].as_f64().expect("number") > 10.0);
}

#[test]
fn a_bad_config_exits_with_2_naming_the_file_key_and_value() {
    let bad = config_with("r = [1.0, 1.0, 1.0, 6.0, 6.0, 6.0]", "r = [1.0, 1.0, 1.0, 6.0, 6.0, -6.0]");
    for command in ["gains", "stability"] {
        let output = run("vservoctl", &[command, "--config", &bad.arg()]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(&bad.arg()) && stderr.contains("controller.r") && stderr.contains("-6.0"),
            "{stderr}"
        );
    }
    let unknown = config_with("[controller]", "[controller]\ngain = 4");
    let output = run("vservoctl", &["gains", "--config", &unknown.arg()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("unknown field") && stderr.contains("gain"), "{stderr}");
    let output = run("vservoctl", &["gains", "--config", "/nonexistent.toml"]);
    assert_eq!(output.status.code(), Some(2));
}
