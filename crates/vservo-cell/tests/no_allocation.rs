//! The per-tick and per-frame paths of the stages do not allocate (docs/ARCHITECTURE.md): counted by a global
//! allocator that wraps the system's and counts, per thread, the allocations made.
#![allow(unsafe_code)] // a GlobalAlloc can only be implemented unsafely; it only delegates to System

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell as StdCell;

use vservo_cell::{Cell, ServoInput};
use vservo_control::{Interaction, LawOptions, Twist};

struct Counting;

thread_local! {
    static ALLOCATIONS: StdCell<usize> = const { StdCell::new(0) };
}

// SAFETY: every call is passed unchanged to the system allocator; counting touches only a const-initialised
// thread-local, which does not allocate.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        // SAFETY: the caller's contract is the system allocator's
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
        // SAFETY: as above
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

fn allocations_in(f: impl FnOnce()) -> usize {
    let before = ALLOCATIONS.with(StdCell::get);
    f();
    ALLOCATIONS.with(StdCell::get) - before
}

#[test]
fn ticks_and_frames_allocate_nothing_once_running() {
    let config =
        vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
            .expect("the default config loads");
    runs_without_allocating(config);
}

/// The law beyond the paper's: a gain designed on every frame, the feed-forward, the barrier, three marks
/// and reacquiring.
#[test]
fn the_robust_law_allocates_nothing_per_frame_either() {
    let mut config =
        vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
            .expect("the default config loads");
    config.controller.law = vservo_control::ControlLaw::DelayAware;
    config.controller.options =
        LawOptions { interaction: Interaction::Mean, border_margin_px: 20.0, feedforward: true };
    runs_without_allocating(config);
}

fn runs_without_allocating(config: vservo_config::Config) {
    let cell = Cell::new(&config).expect("the default cell");
    let mut plant = cell.plant();
    let mut vision = cell.vision();
    let mut servo = cell.servo();
    let mut rmrc = cell.rmrc(cell.start_joints());
    let dt = config.timing.control_period_s;
    let mut frame = |plant: &vservo_cell::PlantStage, vision: &mut vservo_cell::VisionStage, k: u64| {
        let state = *plant.state();
        let taken = vision.capture(k, state.tick, &state.q, &plant.base_from_board());
        let mut delivered = taken.delivered;
        // frame 4 loses a mark, frame 5 three: the servo goes on with three, then reacquires
        if let Some(d) = delivered.as_mut() {
            for mark in 0..match k {
                4 => 1,
                5 => 3,
                _ => 0,
            } {
                d.features[2 * mark] = f64::NAN;
                d.features[2 * mark + 1] = f64::NAN;
            }
        }
        servo
            .step(delivered.as_ref().map(|d| ServoInput {
                frame: d.frame,
                features: &d.features,
                base_from_camera: d.base_from_camera.as_ref(),
            }))
            .0
    };
    // the first frames fill the pipeline and size the extractor's buffers
    for k in 0..3 {
        let twist: Twist = frame(&plant, &mut vision, k);
        rmrc.set_twist(twist, k as f64 * 0.085);
    }
    let per_frame = allocations_in(|| {
        for k in 3..6 {
            let twist = frame(&plant, &mut vision, k);
            rmrc.set_twist(twist, k as f64 * 0.085);
        }
    });
    assert_eq!(per_frame, 0, "allocations in three frames of vision and servo");
    let per_tick = allocations_in(|| {
        for _ in 0..1000 {
            let state = *plant.state();
            let t = state.tick as f64 * dt;
            let command = rmrc.step(t + dt, &state.q, &state.qd);
            plant.apply(&command);
        }
        plant.hold();
    });
    assert_eq!(per_tick, 0, "allocations in 1000 ticks of rmrc and plant");
}
