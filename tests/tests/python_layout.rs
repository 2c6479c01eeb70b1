//! The Python clients' structures and codes (clients/python/) are the Rust declarations': every ctypes
//! structure has the fields, offsets and sizes of the Rust payload of the same type name, and the codes they
//! name have the Rust enums' numbers and names. Read from the Python files as Python sees them.

use std::collections::BTreeMap;

use serde_json::Value;
use vservo_protocol::{CommandKind, CommandMode, DaemonState, DriverStatus, Fault, SCHEMA_VERSION};
use vservo_system_tests::repository_root;

fn python_view() -> Value {
    let python = repository_root().join("target/python-venv/bin/python");
    let out = std::process::Command::new(&python)
        .arg(repository_root().join("tests/python/dump_layouts.py"))
        .arg(repository_root().join("clients/python"))
        .output()
        .expect("python runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON")
}

/// "SCREAMING_CASE" of a code's variant name as the Python files write it.
fn screaming(name: &str) -> String {
    name.to_uppercase().replace([' ', '-'], "_")
}

#[test]
fn the_python_clients_structures_are_the_rust_layouts() {
    let python = python_view();
    let rust: BTreeMap<&str, _> =
        vservo_protocol::layout::layouts().into_iter().map(|l| (l.type_name, l)).collect();
    let structures = python["structures"].as_object().expect("structures");
    assert!(structures.len() >= 8, "{structures:?}");
    for (type_name, layout) in structures {
        let declared =
            rust.get(type_name.as_str()).unwrap_or_else(|| panic!("{type_name}: no such Rust payload"));
        assert_eq!(layout["size"].as_u64(), Some(declared.size as u64), "{type_name}: size");
        let fields: Vec<(String, u64, u64)> = layout["fields"]
            .as_array()
            .expect("fields")
            .iter()
            .map(|f| {
                (
                    f[0].as_str().expect("a name").to_owned(),
                    f[1].as_u64().expect("an offset"),
                    f[2].as_u64().expect("a size"),
                )
            })
            .collect();
        let expected: Vec<(String, u64, u64)> =
            declared.fields.iter().map(|f| (f.name.to_owned(), f.offset as u64, f.size as u64)).collect();
        assert_eq!(fields, expected, "{type_name}: fields (name, offset, size)");
    }
}

#[test]
fn the_python_clients_codes_are_the_rust_enums() {
    let codes = &python_view()["codes"];
    assert_eq!(codes["schema"], serde_json::json!([SCHEMA_VERSION, SCHEMA_VERSION]));
    let names = |all: &[DaemonState]| all.iter().map(|s| s.name()).collect::<Vec<_>>();
    assert_eq!(codes["daemon_state"], serde_json::json!(names(DaemonState::ALL)));
    assert_eq!(codes["fault"], serde_json::json!(Fault::ALL.iter().map(|f| f.name()).collect::<Vec<_>>()));
    for kind in CommandKind::ALL {
        let python_name = screaming(kind.name());
        assert_eq!(
            codes["command_kind"][&python_name].as_u64(),
            Some(u64::from(kind.code())),
            "{python_name}"
        );
    }
    for mode in CommandMode::ALL {
        assert_eq!(codes["command_mode"][screaming(mode.name())].as_u64(), Some(u64::from(mode.code())));
    }
    for status in [DriverStatus::Following, DriverStatus::Holding] {
        assert_eq!(codes["driver_status"][screaming(status.name())].as_u64(), Some(u64::from(status.code())));
    }
}
