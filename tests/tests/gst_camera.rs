//! The GStreamer camera driver (`vservo-gst-camera`, crates/vservo-camera-gst) run as a user runs it:
//! GStreamer's own `videotestsrc` into `camera_image` (frames, counters, stamps, size, pixels against
//! `gst-launch-1.0`'s frame of the same source, the one-writer slot, a clean stop), bad pipelines and
//! wrong caps refused naming them, and the loop closed over RTP on loopback (scripts/run-rtp-camera.sh).

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::Signal;
use serde_json::Value;
use vservo_system_tests::{
    Daemon, Killed, TempConfig, binary, config_from, exclusive, run_script_to_convergence, status, unique,
    wait_until,
};

const WIDTH: usize = 512;
const HEIGHT: usize = 512;
/// The test pattern's frame period: 25 frames a second.
const PERIOD_NS: u64 = 40_000_000;
/// A still GStreamer test pattern of the configured camera's size, 25 frames per second, live.
const CHECKERS: &str = "videotestsrc is-live=true pattern=checkers-8 ! video/x-raw,format=GRAY8,width=512,height=512,framerate=25/1";

/// config/vservo.toml with an external camera under `instance` and `[camera.gstreamer] pipeline`.
fn camera_config(instance: &str, pipeline: &str) -> TempConfig {
    let config = config_from(
        "config/vservo.toml",
        &[
            ("name = \"default\"", &format!("name = \"{instance}\"")),
            ("source = \"simulated\"", "source = \"external\""),
        ],
    );
    let mut text = std::fs::read_to_string(&config.path).expect("config");
    text.push_str(&format!("\n[camera.gstreamer]\npipeline = {}\n", Value::String(pipeline.into())));
    std::fs::write(&config.path, text).expect("config written");
    config
}

/// The driver, its stderr in a file beside the configuration.
fn start_driver(config: &TempConfig) -> (Killed, PathBuf) {
    let log = config.path.with_extension(format!("camera-{}.log", std::process::id()));
    let child = Command::new(binary("vservo-gst-camera"))
        .args(["--config", &config.arg(), "--stats-every-s", "0.5"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).expect("camera log"))
        .spawn()
        .expect("vservo-gst-camera starts");
    (Killed(child), log)
}

/// Waits up to `timeout` for the driver to exit: its exit code (None: still running, then killed).
fn exit_code(driver: &mut Killed, timeout: Duration) -> Option<i32> {
    let until = Instant::now() + timeout;
    while Instant::now() < until {
        if let Ok(Some(status)) = driver.0.try_wait() {
            return status.code();
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    None
}

/// What `gst-launch-1.0` itself writes for the first frame of `pipeline` (the independent reference).
fn gst_launch_frame(pipeline: &str) -> Vec<u8> {
    let file = std::env::temp_dir().join(format!("vservo-gst-frame-{}.gray", std::process::id()));
    let launch =
        format!("{} num-buffers=1 {} ! filesink location={}", "videotestsrc", pipeline, file.display());
    let out = Command::new("gst-launch-1.0")
        .arg("-q")
        .args(launch.split_whitespace())
        .output()
        .expect("gst-launch");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let frame = std::fs::read(&file).expect("the frame");
    let _ = std::fs::remove_file(&file);
    frame
}

/// One frame as a reader of `camera_image` sees it.
struct Received {
    frame: u64,
    capture_stamp_ns: u64,
    received_ns: u64,
    width: u32,
    height: u32,
    stride_bytes: u32,
    pixels: Vec<u8>,
}

/// Reads `camera_image` of `instance` for `seconds`, like the vision node does.
fn read_frames(instance: &str, seconds: f64) -> Vec<Received> {
    let node = vservo_protocol::create_node(instance, "test-reader").expect("a node");
    let subscriber =
        vservo_protocol::camera_image_subscriber(&node, instance, vservo_protocol::Opening::OpenOnly)
            .expect("camera_image");
    let until = Instant::now() + Duration::from_secs_f64(seconds);
    let mut frames = Vec::new();
    while Instant::now() < until {
        while let Ok(Some(sample)) = subscriber.receive() {
            let received_ns = vservo_time::monotonic_ns();
            let header = *sample.user_header();
            frames.push(Received {
                frame: header.frame,
                capture_stamp_ns: header.capture_stamp_ns,
                received_ns,
                width: header.width,
                height: header.height,
                stride_bytes: header.stride_bytes,
                pixels: sample.payload().to_vec(),
            });
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    frames
}

#[test]
fn videotestsrc_frames_reach_camera_image_counted_stamped_at_capture_and_the_slot_is_one_writers() {
    let _one = exclusive();
    let instance = unique("gst-camera");
    let config = camera_config(&instance, CHECKERS);
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || status(&instance).is_some()), "{}", daemon.log());
    let (mut driver, log) = start_driver(&config);
    let read = |seconds| read_frames(&instance, seconds);
    assert!(
        wait_until(Duration::from_secs(10), || !read(0.2).is_empty()),
        "no frame\n{}",
        std::fs::read_to_string(&log).unwrap_or_default()
    );
    let frames = read(2.0);
    let log_text = || std::fs::read_to_string(&log).unwrap_or_default();

    // 25 frames a second for 2 s (a shared two-core VM may lose a few: they are counted, not asserted away)
    assert!(frames.len() >= 25, "{} frames in 2 s\n{}", frames.len(), log_text());
    for pair in frames.windows(2) {
        assert!(pair[1].frame > pair[0].frame, "frame counter {} then {}", pair[0].frame, pair[1].frame);
        assert!(pair[1].capture_stamp_ns > pair[0].capture_stamp_ns, "stamps not increasing");
    }
    // the stamp is the capture's (the buffer's PTS on CLOCK_MONOTONIC): never after the frame was received
    let mut lateness_ms: Vec<f64> = Vec::new();
    for f in &frames {
        assert!(
            f.capture_stamp_ns <= f.received_ns,
            "frame {} stamped {} ns after it was received",
            f.frame,
            f.capture_stamp_ns - f.received_ns
        );
        lateness_ms.push((f.received_ns - f.capture_stamp_ns) as f64 / 1e6);
        assert_eq!((f.width, f.height, f.stride_bytes), (WIDTH as u32, HEIGHT as u32, WIDTH as u32));
        assert_eq!(f.pixels.len(), WIDTH * HEIGHT);
    }
    lateness_ms.sort_by(f64::total_cmp);
    println!(
        "{} frames; capture stamp → reception median {:.2} ms, max {:.2} ms",
        frames.len(),
        lateness_ms[lateness_ms.len() / 2],
        lateness_ms[lateness_ms.len() - 1]
    );
    // the pixels are GStreamer's own frame of the same pattern, as gst-launch-1.0 writes it
    let reference =
        gst_launch_frame("pattern=checkers-8 ! video/x-raw,format=GRAY8,width=512,height=512,framerate=25/1");
    assert!(
        reference.len() == WIDTH * HEIGHT && frames[0].pixels == reference,
        "pixels differ from gst-launch's"
    );

    // one writer: a second driver of the same instance is refused, naming the stream, with exit code 76
    let (mut second, second_log) = start_driver(&config);
    assert_eq!(exit_code(&mut second, Duration::from_secs(20)), Some(76), "{}", daemon.log());
    let refusal = std::fs::read_to_string(&second_log).unwrap_or_default();
    assert!(refusal.contains("camera_image"), "{refusal}");

    // SIGSTOP for 1 s. The live source is in the stopped process too: on SIGCONT it makes the 25 frames it
    // missed at once, stamped when they were due; the appsink keeps the newest two, and how many of the burst
    // the driver's thread takes before they are dropped depends on the scheduling. What holds whatever it
    // is: the counter counts the source's frames, published or lost (its steps are the stamps' steps in
    // periods), and every frame the source made is either published or counted lost.
    let stopped_ns = vservo_time::monotonic_ns();
    driver.signal(Signal::SIGSTOP);
    std::thread::sleep(Duration::from_secs(1));
    driver.signal(Signal::SIGCONT);
    let resumed_ns = vservo_time::monotonic_ns();
    let after = read(1.0);
    let last_before = frames.last().expect("frames before the stop");
    let first_fresh = after
        .iter()
        .find(|f| f.capture_stamp_ns >= resumed_ns)
        .unwrap_or_else(|| panic!("no frame captured after SIGCONT\n{}", log_text()));
    let stopped_frames = (resumed_ns - stopped_ns) as f64 / PERIOD_NS as f64;
    assert!(
        (first_fresh.frame - last_before.frame) as f64 >= stopped_frames - 1.0,
        "the counter went from {} to {} over a stop of {stopped_frames:.1} frame periods\n{}",
        last_before.frame,
        first_fresh.frame,
        log_text()
    );
    for pair in std::iter::once(last_before).chain(&after).collect::<Vec<_>>().windows(2) {
        let periods = (pair[1].capture_stamp_ns - pair[0].capture_stamp_ns) as f64 / PERIOD_NS as f64;
        assert_eq!(
            (pair[1].frame - pair[0].frame) as f64,
            periods.round(),
            "frames {} and {} are {periods:.2} periods apart",
            pair[0].frame,
            pair[1].frame
        );
    }

    // SIGTERM: a clean stop (exit 0) with the totals; every stamp came from the buffers
    let last_read = after.last().expect("frames after the stop");
    let terminated_ns = vservo_time::monotonic_ns();
    driver.signal(Signal::SIGTERM);
    assert_eq!(exit_code(&mut driver, Duration::from_secs(5)), Some(0), "{}", log_text());
    let totals = log_text().lines().rev().find(|l| l.contains("stopped")).unwrap_or_default().to_string();
    assert!(totals.contains("stamped at arrival 0 (no timestamp)"), "{totals}");
    let count_after = |word: &str| -> u64 {
        totals
            .split(word)
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no `{word}` count in {totals}"))
    };
    let (taken, lost) = (count_after("frames "), count_after(" lost "));
    // the source's frames until SIGTERM, counted from the last one read (numbering starts at 0); within
    // three: a frame made as the signal lands, and the newest two that may still wait in the appsink
    let made =
        last_read.frame as f64 + 1.0 + (terminated_ns - last_read.capture_stamp_ns) as f64 / PERIOD_NS as f64;
    assert!(
        ((taken + lost) as f64 - made).abs() <= 3.0,
        "{taken} published and {lost} lost, but the source made {made:.1} frames\n{totals}"
    );
    println!("{totals}");
    drop(daemon);
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_file(&second_log);
}

/// The luma of one raw frame as GStreamer writes it, by the format's layout as GStreamer documents it (the
/// test's own reading, not the driver's): a YUV format's Y bytes, RGB's BT.601 luma computed in floating point.
fn luma_of_raw(format: &str, raw: &[u8]) -> Vec<u8> {
    let pixels = WIDTH * HEIGHT;
    let bt601 = |r: u8, g: u8, b: u8| {
        (0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b)).round() as u8
    };
    match format {
        // planar: the Y plane first, WIDTH bytes a row (512 is aligned: no padding)
        "I420" | "NV12" => raw[..pixels].to_vec(),
        "YUY2" => raw.iter().step_by(2).take(pixels).copied().collect(),
        "UYVY" => raw.iter().skip(1).step_by(2).take(pixels).copied().collect(),
        "RGB" => raw.chunks_exact(3).map(|p| bt601(p[0], p[1], p[2])).collect(),
        "BGR" => raw.chunks_exact(3).map(|p| bt601(p[2], p[1], p[0])).collect(),
        "BGRx" => raw.chunks_exact(4).map(|p| bt601(p[2], p[1], p[0])).collect(),
        "ARGB" => raw.chunks_exact(4).map(|p| bt601(p[1], p[2], p[3])).collect(),
        other => panic!("no reading of {other}"),
    }
}

/// A colour or YUV camera needs no `videoconvert`: the driver publishes the luma of GStreamer's frame in each
/// format, the same pixels as the test reads from gst-launch-1.0's frame of the same pattern.
#[test]
fn yuv_and_rgb_frames_are_published_as_their_luma() {
    let _one = exclusive();
    let instance = unique("gst-colour");
    let caps = |format: &str| format!("video/x-raw,format={format},width=512,height=512,framerate=25/1");
    let config = camera_config(&instance, "videotestsrc");
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || status(&instance).is_some()), "{}", daemon.log());
    for format in ["YUY2", "UYVY", "I420", "NV12", "RGB", "BGR", "BGRx", "ARGB"] {
        let pipeline = format!("videotestsrc is-live=true pattern=smpte ! {}", caps(format));
        let text = std::fs::read_to_string(&config.path).expect("config");
        let start = text.find("[camera.gstreamer]").expect("the section");
        let with_format =
            format!("{}[camera.gstreamer]\npipeline = {}\n", &text[..start], Value::String(pipeline));
        std::fs::write(&config.path, with_format).expect("config written");
        let (mut driver, log) = start_driver(&config);
        let read = || read_frames(&instance, 0.3);
        let mut frames = Vec::new();
        let published = wait_until(Duration::from_secs(10), || {
            frames = read();
            !frames.is_empty()
        });
        let log_text = std::fs::read_to_string(&log).unwrap_or_default();
        assert!(published, "{format}: no frame\n{log_text}");
        let expected = luma_of_raw(format, &gst_launch_frame(&format!("pattern=smpte ! {}", caps(format))));
        let received = &frames[0];
        assert_eq!((received.width, received.height), (WIDTH as u32, HEIGHT as u32), "{format}");
        let differing = received.pixels.iter().zip(&expected).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{format}: {differing} pixels differ from the luma of gst-launch's frame");
        let distinct: std::collections::BTreeSet<u8> = received.pixels.iter().copied().collect();
        assert!(distinct.len() >= 8, "{format}: the pattern's bars in {} gray levels", distinct.len());
        driver.signal(Signal::SIGTERM);
        assert_eq!(exit_code(&mut driver, Duration::from_secs(5)), Some(0), "{format}: {log_text}");
        let _ = std::fs::remove_file(&log);
    }
    drop(daemon);
}

#[test]
fn bad_pipelines_and_wrong_caps_are_refused_naming_the_pipeline_and_why() {
    let _one = exclusive();
    // (pipeline, what the error must say); no daemon runs: each is refused before the instance is looked for
    let cases = [
        ("nosuchelement ! videoconvert", "nosuchelement"),
        ("videotestsrc ! ! !", "camera.gstreamer.pipeline"),
        ("videotestsrc ! fakesink", "camera.gstreamer.pipeline"),
        (
            "videotestsrc is-live=true ! video/x-raw,format=GRAY16_LE,width=512,height=512",
            "format GRAY16_LE, not one the driver turns into gray",
        ),
        (
            "videotestsrc is-live=true ! video/x-raw,format=GRAY8,width=320,height=240",
            "320×240, not the configured camera's 512×512",
        ),
        ("videotestsrc is-live=true ! video/x-raw,width=512,height=512 ! jpegenc", "ends in image/jpeg"),
        ("videotestsrc is-live=true ! video/x-raw,width=512,height=512 ! jpegenc", "jpegdec ! videoconvert"),
        ("v4l2src device=/dev/no-such-video ! videoconvert", "v4l2-ctl --list-devices"),
        ("videotestsrc num-buffers=0 ! video/x-raw,format=GRAY8,width=512,height=512", "ended"),
        ("", "camera.gstreamer.pipeline"),
    ];
    for (pipeline, expected) in cases {
        let config = camera_config(&unique("gst-refused"), pipeline);
        let (mut driver, log) = start_driver(&config);
        let code = exit_code(&mut driver, Duration::from_secs(20));
        let stderr = std::fs::read_to_string(&log).unwrap_or_default();
        assert_eq!(code, Some(1), "{pipeline:?}: {stderr}");
        assert!(stderr.contains(expected), "{pipeline:?}: expected {expected:?} in\n{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        if !pipeline.is_empty() {
            assert!(stderr.contains(&format!("{pipeline:?}")), "the error names the pipeline: {stderr}");
        }
        let _ = std::fs::remove_file(&log);
    }
    // a configuration without the section
    let config = config_from("config/vservo.toml", &[]);
    let (mut driver, log) = start_driver(&config);
    assert_eq!(exit_code(&mut driver, Duration::from_secs(20)), Some(1));
    let stderr = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(stderr.contains("no [camera.gstreamer] section"), "{stderr}");
    let _ = std::fs::remove_file(&log);
}

/// The pids of the running processes of `program` whose command line mentions `text`.
fn processes_of(program: &str, text: &str) -> Vec<i32> {
    let Ok(entries) = std::fs::read_dir("/proc") else { return Vec::new() };
    entries
        .flatten()
        .filter_map(|e| e.file_name().to_str().and_then(|n| n.parse::<i32>().ok()))
        .filter(|pid| {
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            let cmdline = String::from_utf8_lossy(&cmdline);
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            let zombie = stat.rsplit_once(") ").is_some_and(|(_, rest)| rest.starts_with('Z'));
            cmdline.split('\0').next().is_some_and(|p| p.ends_with(program))
                && cmdline.contains(text)
                && !zombie
        })
        .collect()
}

/// `camera.source = "gstreamer"`: vservod starts the GStreamer camera itself, on the configuration in force (the
/// copy in the instance's directory, not the user's file), its frames reach `camera_image`, and it ends with
/// the daemon, even a daemon SIGKILLed.
#[test]
fn vservod_starts_the_gstreamer_camera_on_the_configuration_in_force_and_it_ends_with_the_daemon() {
    let _one = exclusive();
    let instance = unique("gst-started");
    let config = camera_config(&instance, CHECKERS);
    let text = std::fs::read_to_string(&config.path).expect("config");
    std::fs::write(&config.path, text.replacen("source = \"external\"", "source = \"gstreamer\"", 1))
        .expect("config written");
    let daemon = Daemon::start(&config);
    assert!(wait_until(Duration::from_secs(10), || status(&instance).is_some()), "{}", daemon.log());
    assert!(
        wait_until(Duration::from_secs(15), || !read_frames(&instance, 0.2).is_empty()),
        "no frame from the camera vservod started\n{}",
        daemon.log()
    );
    let frames = read_frames(&instance, 1.0);
    assert!(frames.len() >= 12, "{} frames in 1 s at 25 frames/s\n{}", frames.len(), daemon.log());
    assert!(daemon.log().contains("the GStreamer camera started"), "{}", daemon.log());
    let cameras = processes_of("vservo-gst-camera", &instance);
    assert_eq!(cameras.len(), 1, "one camera of the instance: {cameras:?}");
    let cmdline =
        String::from_utf8_lossy(&std::fs::read(format!("/proc/{}/cmdline", cameras[0])).unwrap_or_default())
            .replace('\0', " ");
    assert!(
        cmdline.contains(&format!("{instance}/config.toml")) && !cmdline.contains(&config.arg()),
        "the camera runs the configuration in force, not the user's file: {cmdline}"
    );
    // SIGKILL: the daemon cannot stop its helper; the helper ends by itself
    daemon.signal(Signal::SIGKILL);
    assert!(
        wait_until(Duration::from_secs(5), || processes_of("vservo-gst-camera", &instance).is_empty()),
        "the camera outlived its daemon: {:?}",
        processes_of("vservo-gst-camera", &instance)
    );
    drop(daemon);
}

/// `scripts/run-rtp-camera.sh --json`: the MuJoCo driver's frames over RTP/UDP on loopback into the camera
/// driver close the loop below 1 px.
#[test]
fn run_rtp_camera_converges_below_one_pixel() {
    let _one = exclusive();
    run_script_to_convergence("run-rtp-camera.sh", &[]);
}
