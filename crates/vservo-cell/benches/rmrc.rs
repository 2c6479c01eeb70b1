//! The rmrc stage's tick with and without the collision guard: `cargo bench -p vservo-cell` (docs/BENCHMARKS.md,
//! "The collision guard"). The UR5e (six joints, config/arms/ur5e.toml: its collision meshes, the camera's box, the
//! floor and the board) and the Panda (seven, config/arms/panda.toml), each servoing on a twist, the guard on as
//! its file writes it and off.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use vservo_cell::{Cell, DriverTick};
use vservo_config::Config;
use vservo_control::Twist;

fn rmrc_ticks(c: &mut Criterion) {
    for (arm, joints) in [("ur5e", 6), ("panda", 7)] {
        for guarded in [true, false] {
            let file = format!("{}/../../config/arms/{arm}.toml", env!("CARGO_MANIFEST_DIR"));
            let mut config = Config::load(&file).expect("the arm file");
            if !guarded {
                config.cell.collision = None;
            }
            let cell = Cell::new(&config.cell).expect("the cell");
            let q = *cell.start_joints();
            let mut rmrc = cell.rmrc(&q);
            let qd = vservo_arm::JointVector::zeros();
            let period_ns = vservo_time::nanos(config.cell.robot.period_s);
            let twist = Twist::new(0.02, -0.01, 0.01, 0.02, 0.0, -0.02);
            let mut tick = 0u64;
            let name =
                format!("rmrc_tick_{arm}_{joints}_joints_guard_{}", if guarded { "on" } else { "off" });
            c.bench_function(&name, |b| {
                b.iter(|| {
                    // a new twist every frame, the reference restarted every 2 s so that it stays near the start
                    if tick.is_multiple_of(2000) {
                        rmrc.follow(
                            DriverTick { epoch: tick + 1, tick, stamp_ns: tick * period_ns, holding: false },
                            &q,
                            &qd,
                        );
                    }
                    if tick.is_multiple_of(42) {
                        rmrc.set_twist(twist, tick);
                    }
                    let command = rmrc.step(black_box(tick), &q, &qd);
                    tick += 1;
                    command
                })
            });
        }
    }
}

criterion_group!(benches, rmrc_ticks);
criterion_main!(benches);
