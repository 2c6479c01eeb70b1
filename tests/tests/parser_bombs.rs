//! Bounded parsers (issue 37; README, "What the configuration accepts, the cell can do"): the security review's
//! bombs — URDFs of 12,500 and 200,000 nested elements and of 10 MB, a calibration file of nested YAML aliases,
//! a GStreamer pipeline of 8,000 elements — given to vservod and `vservoctl sim` through a configuration are
//! refused within 1 s, in under 100 MB, naming the file and the bound, and in a short error. (vservod answering
//! SIGTERM while it parses the longest files the bounds allow: tests/tests/vservod_stop_path.rs.)

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use vservo_system_tests::{ScratchDir, binary, repository_root, unique};

/// The bars: refused within this…
const REFUSED_WITHIN: Duration = Duration::from_secs(1);
/// …in at most this much memory (the process's peak resident set, kB)…
const PEAK_KB: i64 = 100 * 1024;

/// How a process ended: its exit status, wall time, peak resident set (kB) and standard error.
struct Ended {
    status: std::process::ExitStatus,
    took: Duration,
    peak_kb: i64,
    stderr: String,
}

/// Waits for `child`, at most `guard`. The peak memory is the largest of every child this test binary has
/// waited for (`getrusage(RUSAGE_CHILDREN)`): its children are the refused runs only, so that each stayed
/// within it. It is an upper bound: a child's count starts from the test process's own pages, shared at the
/// fork (about 24 MB here; the refused programs alone peak at 9–10 MB, measured with GNU time).
fn wait_measured(mut child: Child, started: Instant, guard: Duration) -> Ended {
    let status = loop {
        if let Some(status) = child.try_wait().expect("the child is waited for") {
            break status;
        }
        if started.elapsed() > guard {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{} still runs after {guard:?}", child.id());
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let took = started.elapsed();
    let usage =
        nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN).expect("getrusage");
    let mut stderr = String::new();
    if let Some(mut pipe) = child.stderr.take() {
        use std::io::Read;
        let _ = pipe.read_to_string(&mut stderr);
    }
    Ended { status, took, peak_kb: usage.max_rss(), stderr }
}

fn start(program: &str, config: &Path, out: &Path) -> Child {
    let mut command = Command::new(binary(program));
    match program {
        "vservod" => command.args(["--config", &config.display().to_string()]),
        _ => command.args([
            "sim",
            "--config",
            &config.display().to_string(),
            "--out",
            &out.display().to_string(),
        ]),
    };
    command.stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().expect("starts")
}

/// `config` given to vservod and to `vservoctl sim`: each refuses it within the bars, naming `file` and `bound`.
fn refused_by_both(what: &str, config: &Path, file: &Path, bound: &str, scratch: &ScratchDir) {
    for program in ["vservod", "vservoctl"] {
        let started = Instant::now();
        let ended =
            wait_measured(start(program, config, &scratch.0.join("out")), started, Duration::from_secs(60));
        println!(
            "{what}, {program}: exit {:?} in {:.3} s, peak {:.1} MB: {}",
            ended.status.code(),
            ended.took.as_secs_f64(),
            ended.peak_kb as f64 / 1024.0,
            ended.stderr.lines().last().unwrap_or("").chars().take(300).collect::<String>()
        );
        let refusal = if program == "vservod" { 1 } else { 2 };
        assert_eq!(ended.status.code(), Some(refusal), "{what}, {program}: refused\n{}", ended.stderr);
        assert!(ended.took < REFUSED_WITHIN, "{what}, {program}: refused after {:?}", ended.took);
        assert!(ended.peak_kb < PEAK_KB, "{what}, {program}: {} kB", ended.peak_kb);
        let file = file.display().to_string();
        assert!(
            ended.stderr.contains(&file) && ended.stderr.contains(bound),
            "{what}, {program}: the error names {file} and the bound ({bound}):\n{}",
            ended.stderr
        );
        assert!(ended.stderr.len() < 4096, "{what}, {program}: a short error, {} bytes", ended.stderr.len());
    }
}

/// An overlay of config/arms/ur5e.toml (an arm read from a URDF) reading `urdf`.
fn urdf_config(scratch: &ScratchDir, name: &str, urdf: &Path) -> PathBuf {
    let base = repository_root().join("config/arms/ur5e.toml");
    let text = format!(
        "extends = \"{}\"\n[instance]\nname = \"{}\"\n[robot.arm]\nurdf = \"{}\"\ntip_link = \"flange\"\n",
        base.display(),
        unique(name),
        urdf.display()
    );
    scratch.write(&format!("{name}.toml"), &text)
}

#[test]
fn the_reviews_urdf_bombs_are_refused_at_once_in_little_memory_naming_the_file_and_the_bound() {
    let scratch = ScratchDir::new(&unique("urdf-bombs"));
    let bombs = [
        ("nested-12500", format!("<robot>{}{}</robot>", "<link>".repeat(12_500), "</link>".repeat(12_500))),
        ("nested-200000", format!("<robot>{}{}</robot>", "<a>".repeat(200_000), "</a>".repeat(200_000))),
        ("ten-mb", format!("<robot name=\"x\"><!--{}--></robot>", "x".repeat(10_000_000))),
        ("flat-25000", format!("<robot name=\"x\">{}</robot>", "<link name=\"l\"/>".repeat(25_000))),
    ];
    for (name, text) in &bombs {
        let urdf = scratch.write(&format!("{name}.urdf"), text);
        let config = urdf_config(&scratch, name, &urdf);
        let bound = match *name {
            // 1.4 MB: over the files' bound before its depth is looked at
            "ten-mb" | "nested-200000" => "longer than 1 MiB",
            "flat-25000" => "more than 20000 elements",
            _ => "elements nest deeper than 32",
        };
        refused_by_both(&format!("URDF {name} ({} bytes)", text.len()), &config, &urdf, bound, &scratch);
    }
}

#[test]
fn the_reviews_alias_bomb_and_a_pipeline_of_thousands_of_elements_are_refused_at_once() {
    let scratch = ScratchDir::new(&unique("text-bombs"));
    // 589 bytes that grew to gigabytes in the loader: nine levels of six aliases each
    let mut yaml =
        String::from("a: &a [\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\"]\n");
    for level in 0..9u8 {
        let (name, previous) = (char::from(b'b' + level), char::from(b'a' + level));
        yaml += &format!(
            "{name}: &{name} [*{previous},*{previous},*{previous},*{previous},*{previous},*{previous}]\n"
        );
    }
    let calibration = scratch.write("bomb.yaml", &yaml);
    let base = repository_root().join("config/vservo.toml");
    let config = scratch.write(
        "alias.toml",
        &format!(
            "extends = \"{}\"\n[instance]\nname = \"{}\"\n[camera]\ncalibration_file = \"{}\"\n",
            base.display(),
            unique("alias-bomb"),
            calibration.display()
        ),
    );
    refused_by_both("the alias bomb", &config, &calibration, "an alias (*…) at line", &scratch);

    let elements = vec!["identity"; 8_000].join(" ! ");
    let pipeline = format!("videotestsrc ! {elements} ! video/x-raw,format=GRAY8");
    let config = scratch.write(
        "pipeline.toml",
        &format!(
            "extends = \"{}\"\n[instance]\nname = \"{}\"\n[camera]\nsource = \"gstreamer\"\n[camera.gstreamer]\npipeline = \"{pipeline}\"\n",
            base.display(),
            unique("pipeline-bomb")
        ),
    );
    let bound = "camera.gstreamer.pipeline = (88039 bytes): longer than the 4096 bytes";
    refused_by_both("a pipeline of 8,000 elements", &config, &config, bound, &scratch);
}
