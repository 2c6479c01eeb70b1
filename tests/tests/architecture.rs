//! docs/ARCHITECTURE.md's crate graph is the workspace's own, generated from the Cargo.toml files; and the
//! processes that drive an arm or bridge to ROS keep out of the real-time shell and the core cell.

use std::collections::{BTreeMap, BTreeSet};

use vservo_system_tests::repository_root;

/// Each workspace crate (by package name) and the workspace crates in its `[dependencies]` (not dev- or
/// build-dependencies), read from `crates/*/Cargo.toml` and `tests/Cargo.toml`.
fn crate_graph() -> BTreeMap<String, BTreeSet<String>> {
    let root = repository_root();
    let mut manifests: Vec<_> = std::fs::read_dir(root.join("crates"))
        .expect("crates/")
        .filter_map(|entry| Some(entry.ok()?.path().join("Cargo.toml")))
        .filter(|path| path.exists())
        .collect();
    manifests.push(root.join("tests/Cargo.toml"));
    let parsed: Vec<(String, BTreeSet<String>)> = manifests
        .iter()
        .map(|path| {
            let text = std::fs::read_to_string(path).expect("a manifest");
            let manifest: toml::Table = text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let name = manifest["package"]["name"].as_str().expect("package.name").to_string();
            let dependencies = manifest
                .get("dependencies")
                .and_then(|d| d.as_table())
                .map(|d| d.keys().cloned().collect())
                .unwrap_or_default();
            (name, dependencies)
        })
        .collect();
    let members: BTreeSet<String> = parsed.iter().map(|(name, _)| name.clone()).collect();
    parsed
        .into_iter()
        .map(|(name, dependencies)| (name, dependencies.intersection(&members).cloned().collect()))
        .collect()
}

/// The crate graph as ARCHITECTURE.md prints it: one line per crate, `name → its workspace dependencies`.
fn graph_block(graph: &BTreeMap<String, BTreeSet<String>>) -> String {
    graph
        .iter()
        .map(|(name, dependencies)| {
            let listed = if dependencies.is_empty() {
                "—".to_string()
            } else {
                dependencies.iter().cloned().collect::<Vec<_>>().join(", ")
            };
            format!("{name} → {listed}\n")
        })
        .collect()
}

/// Every crate `name` reaches through its dependencies.
fn reached(graph: &BTreeMap<String, BTreeSet<String>>, name: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut open = vec![name.to_string()];
    while let Some(next) = open.pop() {
        for dependency in graph.get(&next).into_iter().flatten() {
            if seen.insert(dependency.clone()) {
                open.push(dependency.clone());
            }
        }
    }
    seen
}

#[test]
fn the_crate_graph_in_architecture_md_is_the_workspaces() {
    let doc = std::fs::read_to_string(repository_root().join("docs/ARCHITECTURE.md")).expect("the doc");
    // a map, not a manual (issue 36: crate detail goes into the crates' docs)
    assert!(doc.len() < 15_000, "docs/ARCHITECTURE.md is {} bytes: keep it a map, under 15 kB", doc.len());
    let block = graph_block(&crate_graph());
    assert!(
        doc.contains(&format!("```text\n{block}```")),
        "docs/ARCHITECTURE.md's crate graph is out of date; its block under \"Crate graph\" is:\n```text\n{block}```"
    );
}

/// The drivers (robot, camera) and the ROS 2 binaries depend on the wire, the driver library and the
/// configuration, never on the real-time shell, the cell, its stages (control, simulation, vision) or the lockstep:
/// they are processes behind the protocol, not stages of the loop. The configuration takes the stages' settings
/// from `vservo-settings`, below the stages.
#[test]
fn drivers_and_bridges_keep_out_of_the_real_time_shell_and_the_cell() {
    let graph = crate_graph();
    for driver in
        ["vservo-camera-gst", "vservo-ros2", "vservo-franka-driver", "vservo-driver", "vservo-client"]
    {
        let reach = reached(&graph, driver);
        assert!(graph.contains_key(driver), "{driver} is a workspace crate");
        for shell in [
            "vservo-runtime",
            "vservo-cell",
            "vservo-control",
            "vservo-sim",
            "vservo-vision",
            "vservo-lockstep",
            "vservod",
            "vservoctl",
        ] {
            assert!(!reach.contains(shell), "{driver} reaches {shell}: {reach:?}");
        }
    }
    // the premise: the check sees the real graph (the daemon does reach the shell)
    assert!(reached(&graph, "vservod").contains("vservo-runtime"));
}

/// Issue 36: the core cell takes only its own part of the configuration (`vservo_config::CellConfig`), never the
/// whole `Config` with the shells' settings (runtime, faults, viewer, ROS 2, drivers); its tests may load a file.
#[test]
fn the_core_cell_takes_only_its_part_of_the_configuration() {
    let mut whole = Vec::new();
    for file in rust_files(&repository_root().join("crates/vservo-cell/src")) {
        let text = std::fs::read_to_string(&file).expect("a source file");
        let code = text.split("#[cfg(test)]").next().unwrap_or_default();
        for (number, line) in code.lines().enumerate() {
            let line = line.split("//").next().unwrap_or_default();
            let bytes = line.as_bytes();
            let named = line.match_indices("Config").any(|(at, _)| {
                let before = at.checked_sub(1).map(|i| bytes[i]);
                let after = bytes.get(at + "Config".len()).copied();
                !before.is_some_and(|b| b.is_ascii_alphanumeric() || b == b'_')
                    && !after.is_some_and(|b| b.is_ascii_alphanumeric() || b == b'_')
            });
            if named {
                whole.push(format!("{}:{}: {}", file.display(), number + 1, line.trim()));
            }
        }
    }
    assert!(whole.is_empty(), "the cell names the whole configuration:\n{}", whole.join("\n"));
    // the premise: the scan sees the cell's part where it is taken
    let lib =
        std::fs::read_to_string(repository_root().join("crates/vservo-cell/src/lib.rs")).expect("lib.rs");
    assert!(lib.contains("pub fn new(config: &CellConfig)"));
}

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).expect("a folder").flatten() {
        let path = entry.path();
        if path.is_dir() {
            files.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

/// Issue 36: the rule for taking a command (its age window and its checks) is written once in Rust, in
/// `vservo-driver` (which the simulated plant, the ROS 2 driver and the Franka driver call), and once in Python,
/// in `vservo_driver.py` (which tests/tests/python_layout.rs ties to the Rust); no other source writes it again.
#[test]
fn the_command_admission_rule_is_written_once_in_rust_and_once_in_python() {
    let root = repository_root();
    let rule =
        ["MAX_COMMAND_AGE_TICKS: u64 =", "+ MAX_COMMAND_AGE_TICKS", "answers_tick +", "answers_tick <"];
    let mut found: Vec<String> = Vec::new();
    for file in rust_files(&root.join("crates")) {
        let text = std::fs::read_to_string(&file).expect("a source file");
        for pattern in rule.iter().chain([".driver_epoch !=", ".driver_epoch =="].iter()) {
            if text.contains(pattern) {
                found
                    .push(format!("{}: {pattern}", file.strip_prefix(&root).expect("in the tree").display()));
            }
        }
    }
    let (driver_side, elsewhere): (Vec<&String>, Vec<&String>) =
        found.iter().partition(|f| f.starts_with("crates/vservo-driver/src/side.rs"));
    assert!(elsewhere.is_empty(), "the admission rule written again: {elsewhere:?}");
    // the premise: the patterns find the rule where it is
    assert!(driver_side.iter().any(|f| f.ends_with("MAX_COMMAND_AGE_TICKS: u64 =")), "{found:?}");
    assert!(driver_side.iter().any(|f| f.ends_with("+ MAX_COMMAND_AGE_TICKS")), "{found:?}");
    assert!(driver_side.iter().any(|f| f.ends_with(".driver_epoch !=")), "{found:?}");
    let python: Vec<String> = std::fs::read_dir(root.join("clients/python"))
        .expect("clients/python")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "py"))
        .filter(|p| {
            let text = std::fs::read_to_string(p).expect("a Python file");
            text.contains("MAX_COMMAND_AGE_TICKS = ") || text.contains("+ MAX_COMMAND_AGE_TICKS")
        })
        .map(|p| p.file_name().expect("a name").to_string_lossy().to_string())
        .collect();
    assert_eq!(python, ["vservo_driver.py"], "the Python rule in one module");
}

/// Issue 36: no source file of the workspace is over 600 lines (a room with several jobs shows as a long file),
/// except declaration tables, which are named here.
#[test]
fn no_source_file_is_over_600_lines_except_declaration_tables() {
    const MOST_LINES: usize = 600;
    /// The tag36h11 family's 587 codes, generated from the AprilTag C library's table.
    const TABLES: [&str; 1] = ["crates/vservo-scene/src/tag36h11.rs"];
    let root = repository_root();
    let mut long: Vec<String> = Vec::new();
    let mut counted = 0;
    for dir in ["crates", "tests", "clients", "scripts"] {
        let files = source_files(&root.join(dir));
        counted += files.len();
        for file in files {
            let name = file.strip_prefix(&root).expect("in the tree").display().to_string();
            let lines = std::fs::read_to_string(&file).expect("a source file").lines().count();
            if lines > MOST_LINES && !TABLES.contains(&name.as_str()) {
                long.push(format!("{name}: {lines} lines"));
            }
        }
    }
    assert!(long.is_empty(), "over {MOST_LINES} lines: {long:?}");
    // the premise: the walk finds the sources, the table among them
    assert!(counted > 200, "{counted} source files");
    assert!(source_files(&root.join("crates/vservo-scene/src")).iter().any(|f| f.ends_with("tag36h11.rs")));
}

/// Every `.rs` and `.py` file under `dir`, recursively (build outputs and Python caches left out).
fn source_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return files };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        if path.is_dir() && !["target", "__pycache__", ".venv"].contains(&name.to_string_lossy().as_ref()) {
            files.extend(source_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs" || e == "py") {
            files.push(path);
        }
    }
    files
}

/// Issue 48: seconds become nanoseconds and back in one place, `vservo-time` (rounded, never truncated); no other
/// code of the workspace (its sources, examples and benches; tests left out: a file under `tests/`, and a source
/// file from its `#[cfg(test)]` on) writes 10⁹ as a number.
#[test]
fn no_code_outside_vservo_time_converts_seconds_and_nanoseconds() {
    let mut found: Vec<String> = Vec::new();
    for (name, code) in code_before_its_tests() {
        if name.starts_with("crates/vservo-time/") || name.contains("/tests/") {
            continue;
        }
        for (number, line) in code.lines().enumerate() {
            let before_comment = line.split("//").next().unwrap_or(line);
            if writes_a_billion(before_comment) {
                found.push(format!("{name}:{}: {}", number + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "seconds and nanoseconds converted outside vservo-time: {found:#?}");
    // the premise: the pattern finds the conversions it is there to keep out, and not a hexadecimal table's digits
    assert!(writes_a_billion("let period_ns = (period_s * 1e9).round() as u64;"));
    assert!(writes_a_billion("t.tv_sec() as u64 * 1_000_000_000"));
    assert!(!writes_a_billion("0x0000_0004_a1e9_3a9d,") && !writes_a_billion("x < 1e-9"));
}

/// Whether `code` writes 10⁹ (`1e9`, `1_000_000_000`, `1000000000`) as a number of its own.
fn writes_a_billion(code: &str) -> bool {
    code.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.'))
        .map(|token| token.trim_end_matches('.'))
        .any(|token| {
            let digits = token.trim_end_matches("u64").trim_end_matches("f64").trim_end_matches("i128");
            digits == "1e9" || digits == "1.0e9" || digits.replace('_', "") == "1000000000"
        })
}

/// Issue 48: a sealed stream's sample (the servo's features, the rmrc's twists) is admitted in one call,
/// `vservo_wire::stream::SealedStream::admit` (schema, seal, announced writer and freshness): no other source
/// asks for a stream's standing itself.
#[test]
fn a_sealed_streams_admission_is_written_once() {
    let mut found: Vec<String> = code_before_its_tests()
        .into_iter()
        .filter(|(_, code)| code.contains("stream_standing("))
        .map(|(name, _)| name)
        .collect();
    found.sort();
    assert_eq!(
        found,
        ["crates/vservo-wire/src/freshness.rs", "crates/vservo-wire/src/stream.rs"],
        "a stream's standing asked outside the one admission"
    );
    let admitting: Vec<String> = rust_files(&repository_root().join("crates/vservo-runtime/src/nodes"))
        .iter()
        .filter(|file| std::fs::read_to_string(file).expect("a source file").contains(".admit(taken"))
        .map(|file| file.file_name().expect("a name").to_string_lossy().to_string())
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    assert_eq!(admitting, ["rmrc.rs", "servo.rs"], "the servo and the rmrc admit through it");
}

/// Every Rust file under `crates/` (its path from the repository's root) with its text up to its `#[cfg(test)]`
/// line: the code that is not a unit test.
fn code_before_its_tests() -> Vec<(String, String)> {
    let root = repository_root();
    rust_files(&root.join("crates"))
        .into_iter()
        .map(|file| {
            let name = file.strip_prefix(&root).expect("in the tree").display().to_string();
            let text = std::fs::read_to_string(&file).expect("a source file");
            let code: Vec<&str> = text.lines().take_while(|line| line.trim() != "#[cfg(test)]").collect();
            (name, code.join("\n"))
        })
        .collect()
}
