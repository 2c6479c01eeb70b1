//! The per-tick and per-frame paths of the stages do not allocate (docs/ARCHITECTURE.md): counted by a global
//! allocator that wraps the system's and counts, per thread, the allocations made.
#![allow(unsafe_code)] // a GlobalAlloc can only be implemented unsafely; it only delegates to System

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell as StdCell;

use vservo_cell::{Cell, DriverTick, Following, ServoInput, TwistLimits};
use vservo_control::{Interaction, LawFlags, LawOptions, Twist};

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
    let flags = runs_without_allocating(config);
    assert!(flags.iter().all(|f| *f == LawFlags::default()), "the paper's law as designed: {flags:?}");
}

/// The law beyond the paper's: a gain designed on every frame, the feed-forward, the barrier, three marks
/// and reacquiring; the law's flags say that the feed-forward and the barrier ran in the frames counted.
#[test]
fn the_robust_law_allocates_nothing_per_frame_either() {
    let mut config =
        vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
            .expect("the default config loads");
    config.cell.controller.law = vservo_control::ControlLaw::DelayAware;
    // a margin just clear of the marks nearest the top edge (70 px at ξ_d), which the translation step
    // moves up: the barrier acts
    config.cell.controller.options = LawOptions {
        interaction: Interaction::Mean,
        border_margin_px: 65.0,
        feedforward: true,
        ..Default::default()
    };
    let flags = runs_without_allocating(config);
    assert!(flags.iter().any(|f| f.feedforward), "{flags:?}");
    assert!(flags.iter().any(|f| f.barrier), "{flags:?}");
}

/// The pose-based laws: the board's pose from the marks, the pose error and its interaction matrix, within
/// the barrier, and the delay-aware image law when a frame shows three marks.
#[test]
fn the_pose_based_laws_allocate_nothing_per_frame_either() {
    use vservo_control::ControlLaw;
    for law in [ControlLaw::Pbvs, ControlLaw::PbvsTarget, ControlLaw::TwoAndAHalfD] {
        let mut config =
            vservo_config::Config::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/vservo.toml"))
                .expect("the default config loads");
        config.cell.controller.law = law;
        config.cell.controller.options.border_margin_px = 65.0;
        let flags = runs_without_allocating(config);
        assert!(flags.iter().any(|f| f.barrier), "{law:?}: {flags:?}");
    }
}

/// Arms from their URDFs (config/arms/xarm6.toml and panda.toml, PyBullet's xArm6 and Panda, simulated
/// kinematically): their chains' kinematics on the 1 ms path, and the seven-joint Panda's redundancy
/// resolution with its null-space task, allocate nothing per tick or frame.
#[test]
fn an_arm_from_a_urdf_allocates_nothing_per_tick_or_frame() {
    for arm in ["xarm6", "panda"] {
        let file = format!("{}/../../config/arms/{arm}.toml", env!("CARGO_MANIFEST_DIR"));
        let config = vservo_config::Config::load(&file).expect("the arm's config loads");
        runs_without_allocating(config);
    }
}

/// Runs frames and ticks of the cell, counting allocations; the law's flags of the frames counted.
fn runs_without_allocating(config: vservo_config::Config) -> [LawFlags; COUNTED_FRAMES] {
    let cell = Cell::new(&config.cell).expect("the default cell");
    let mut plant = cell.plant();
    let mut vision = cell.vision();
    let mut servo = cell.servo();
    let mut rmrc = cell.rmrc(cell.start_joints());
    let limits = TwistLimits::of(cell.config());
    let ticks_per_frame = u64::from(config.cell.timing.control_ticks_per_frame);
    let mut frame = |plant: &vservo_cell::PlantStage, vision: &mut vservo_cell::VisionStage, k: u64| {
        let state = *plant.state();
        let taken = vision.capture(k, state.tick, &state.q, &plant.base_from_board());
        let mut delivered = taken.delivered;
        // frame 11 sees a mark outside the image (refused), frame 12 loses three: the servo goes on with
        // three, then reacquires
        if let Some(d) = delivered.as_mut() {
            if k == 11 {
                d.features[0] = 600.0;
            }
            for mark in 0..if k == 12 { 3 } else { 0 } {
                d.features[2 * mark] = f64::NAN;
                d.features[2 * mark + 1] = f64::NAN;
            }
        }
        let step = servo.step(delivered.as_ref().map(|d| ServoInput {
            frame: d.frame,
            features: &d.features,
            holder_from_camera: d.holder_from_camera.as_ref(),
            unseen_s: 0.0,
        }));
        assert_eq!(step.outside != 0, k == 11, "frame {k}: {step:?}");
        (step.twist, servo.law_flags())
    };
    // the first frames fill the pipeline, size the extractor's buffers and let the target's motion
    // estimate settle (it is used from its fifth frame)
    const WARM_UP_FRAMES: u64 = 8;
    for k in 0..WARM_UP_FRAMES {
        let (twist, _): (Twist, _) = frame(&plant, &mut vision, k);
        rmrc.set_twist(twist, k * ticks_per_frame);
    }
    let mut flags = [LawFlags::default(); COUNTED_FRAMES];
    let per_frame = allocations_in(|| {
        for (k, flags) in (WARM_UP_FRAMES..).zip(flags.iter_mut()) {
            let twist;
            (twist, *flags) = frame(&plant, &mut vision, k);
            rmrc.take_twist(&twist, true, &limits, k * ticks_per_frame);
        }
    });
    assert_eq!(per_frame, 0, "allocations in {COUNTED_FRAMES} frames of vision and servo");
    // the driver's states as the rmrc follows them: every tick, but none from tick 300 to 309 (the rmrc
    // catches up), one at tick 400 saying the driver holds the arm (the rmrc starts again at rest), a joint move
    // from tick 500 to 649, and a new driver epoch from tick 700 (the rmrc starts again at rest); the rmrc's
    // first state is a start at rest too
    let period_ns = (config.cell.robot.period_s * 1e9).round() as u64;
    let mut followed = [0u32; 3];
    let goal = plant.state().q + vservo_arm::JointVector::from_element(0.05);
    let per_tick = allocations_in(|| {
        let mut last = None;
        for _ in 0..1000 {
            let state = *plant.state();
            let (tick, epoch) = (state.tick, if state.tick >= 700 { 2 } else { 1 });
            if (300..310).contains(&tick) {
                // the rmrc asleep: the driver keeps the last command
                if let Some(command) = last {
                    plant.apply(&command);
                }
                continue;
            }
            let at = DriverTick { epoch, tick, stamp_ns: tick * period_ns, holding: tick == 400 };
            match rmrc.follow(at, &state.q, &state.qd) {
                Following::Resynced => followed[0] += 1,
                Following::Continued { missed_ticks: 0 } => followed[1] += 1,
                Following::Continued { missed_ticks } => followed[2] += missed_ticks as u32,
            }
            if (500..650).contains(&tick) {
                assert!(rmrc.move_joints_to(goal, 0.25, tick), "a goal inside the limits");
            } else if tick == 650 {
                rmrc.end_joint_move();
            }
            let command = rmrc.step(tick, &state.q, &state.qd);
            plant.apply(&command);
            last = Some(command);
        }
        plant.hold();
    });
    assert_eq!(per_tick, 0, "allocations in 1000 ticks of rmrc and plant");
    // the first state, the driver holding, and the new epoch; the ten ticks asleep stepped through at once
    assert_eq!((followed[0], followed[2]), (3, 10), "resynced, continued, ticks caught up: {followed:?}");
    flags
}

/// Frames counted: three with four marks, one with three, one with one, one with four again.
const COUNTED_FRAMES: usize = 6;

/// The jerk-limited reference (an arm with jerk limits on an external driver: config/arms/fr3.toml, seven joints,
/// and ur5e.toml, six): servoing, a joint move and the ramp to rest, tick by tick, allocate nothing.
#[test]
fn the_jerk_limited_reference_allocates_nothing_per_tick() {
    use vservo_sim::interpolator::Interpolator;
    for arm in ["fr3", "ur5e"] {
        let file = format!("{}/../../config/arms/{arm}.toml", env!("CARGO_MANIFEST_DIR"));
        let config = vservo_config::Config::load(&file).expect("the arm's config loads");
        assert!(config.cell.interpolator.jerk_limit.is_some(), "{arm} has jerk limits");
        let settings = config.cell.interpolator;
        let dt = settings.control_period_s;
        let mut interpolator = Interpolator::new(
            settings,
            config.cell.arm.clone(),
            config.cell.mount(),
            config.cell.desired.joints,
        );
        let twist = Twist::new(0.05, -0.02, 0.03, 0.1, 0.0, -0.2);
        // warm up: every path once
        interpolator.set_twist(twist, 0.0);
        for tick in 1..=200 {
            interpolator.step(tick as f64 * dt);
        }
        let mut tick = 200u64;
        let mut run = |interpolator: &mut Interpolator, ticks: u64| {
            for _ in 0..ticks {
                tick += 1;
                interpolator.step(tick as f64 * dt);
            }
        };
        let allocations = allocations_in(|| {
            interpolator.set_twist(twist * -1.0, 0.2);
            run(&mut interpolator, 300);
            interpolator.move_joints_to(config.cell.desired.joints, 0.5);
            run(&mut interpolator, 1000);
            interpolator.end_joint_move();
            interpolator.set_twist(Twist::zeros(), 1.5);
            run(&mut interpolator, 1000);
        });
        assert_eq!(allocations, 0, "{arm}");
        assert_eq!(interpolator.motion_refusals(), 0, "{arm}");
    }
}
