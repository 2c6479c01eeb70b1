//! Wall time of a whole lockstep run: `cargo bench -p vservo-lockstep`.

use criterion::{Criterion, criterion_group, criterion_main};
use vservo_config::Config;
use vservo_lockstep::Lockstep;

fn lockstep(c: &mut Criterion) {
    let config =
        Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml").expect("valid");
    let mut group = c.benchmark_group("lockstep");
    group.sample_size(10);
    group.bench_function("translation_step_30s_dynamic_rendered", |b| {
        b.iter(|| Lockstep::new(&config).expect("reachable").run(|_| {}).frames.len())
    });
    group.finish();
}

criterion_group!(benches, lockstep);
criterion_main!(benches);
