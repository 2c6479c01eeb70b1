//! Every shipped scene the simulated camera renders (each configuration under config/ whose camera is
//! simulated), at its desired view, with its render settings (noise, gradient) and its true camera (lens
//! included): `cargo bench -p vservo-vision --bench scenes`. The bar (issue 38): each in under half its
//! configuration's vision period; docs/BENCHMARKS.md has the figures.

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, criterion_group, criterion_main};
use vservo_config::{Config, VisionSource};
use vservo_vision::source::SimulatedCamera;

/// The configuration files: config/*.toml and config/scenarios/*.toml.
fn shipped_configurations() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config");
    let mut files: Vec<PathBuf> = [root.clone(), root.join("scenarios")]
        .iter()
        .flat_map(|dir| std::fs::read_dir(dir).expect("config/ is there"))
        .map(|entry| entry.expect("a directory entry").path())
        .filter(|path| path.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

fn scenes(c: &mut Criterion) {
    for path in shipped_configurations() {
        let config = Config::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        if config.cell.vision.source != VisionSource::Simulated {
            continue;
        }
        let name = path
            .strip_prefix(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config"))
            .expect("under config/");
        let truth = config.cell.true_camera();
        let mut camera = SimulatedCamera::new(truth.intrinsics, config.cell.board, config.cell.vision.render);
        let pose = config.cell.desired.camera_from_board;
        let mut frame = 0;
        let label = format!(
            "scene {} ({} × {}, vision period {:.0} ms)",
            name.display(),
            truth.intrinsics.width_px(),
            truth.intrinsics.height_px(),
            config.cell.timing.vision_period_s * 1e3
        );
        c.bench_function(&label, |b| {
            b.iter(|| {
                frame += 1;
                camera.capture(black_box(&pose), frame).as_raw().len()
            })
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = scenes
}
criterion_main!(benches);
