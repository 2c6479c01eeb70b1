//! Replaying a real-time run's pace as data: the rmrc stage decides its restarts at rest itself from the
//! joint states it is fed, as the real-time node does, and a replay of a run answered in time is the run.

use std::collections::HashMap;

use vservo_config::Config;
use vservo_lockstep::{DriverTick, Lockstep, Replay, Trace};

const PERIOD_NS: u64 = 1_000_000;

fn lockstep() -> Lockstep {
    let mut config =
        Config::from_toml(include_str!("../../../config/vservo.toml"), "vservo.toml").expect("valid");
    config.cell.scenario.duration_s = 1.0;
    Lockstep::new(&config).expect("reachable")
}

/// Every tick's joint state answered, on a driver clock that starts at `t0_ns`; from tick `stall_at` on
/// (if any) the stamps are `gap_ns` later, as after a driver that stalled.
fn answered(t0_ns: u64, stall: Option<(u64, u64)>) -> HashMap<u64, DriverTick> {
    (0..1000)
        .map(|tick| {
            let late = stall.filter(|(at, _)| tick >= *at).map_or(0, |(_, gap_ns)| gap_ns);
            (tick, DriverTick { epoch: 7, tick, stamp_ns: t0_ns + tick * PERIOD_NS + late, holding: false })
        })
        .collect()
}

fn features(trace: &Trace) -> Vec<[f64; 8]> {
    trace.frames.iter().map(|f| std::array::from_fn(|k| f.measured[k])).collect()
}

#[test]
fn a_replay_of_a_run_answered_in_time_is_that_run_bit_for_bit() {
    let mut own = lockstep();
    let nominal = own.run(|_| {});
    assert_eq!(own.resyncs(), &[0], "the rmrc starts at rest on its first state, only");
    let replay = Replay { states_answered: answered(123_456_789, None), ..Replay::default() };
    let mut replaying = lockstep();
    let replayed = replaying.run_replaying(|_| {}, &replay);
    assert_eq!(replaying.resyncs(), &[0]);
    assert_eq!(replayed, nominal);
}

#[test]
fn the_rmrc_restarts_at_rest_where_the_states_it_is_fed_say_the_driver_stalled() {
    // the translation step is under way at 0.5 s; 60 ms without a state is beyond the 50 periods' deadline
    let stalled = Replay { states_answered: answered(0, Some((500, 60 * PERIOD_NS))), ..Replay::default() };
    let mut lockstep_stalled = lockstep();
    let after_stall = lockstep_stalled.run_replaying(|_| {}, &stalled);
    assert_eq!(lockstep_stalled.resyncs(), &[0, 500]);
    // within the deadline it carries on
    let slow = Replay { states_answered: answered(0, Some((500, 40 * PERIOD_NS))), ..Replay::default() };
    let mut lockstep_slow = lockstep();
    let carried_on = lockstep_slow.run_replaying(|_| {}, &slow);
    assert_eq!(lockstep_slow.resyncs(), &[0]);
    // the restart dropped the twist it held: the frames after it differ, those before do not
    let (stalled, carried_on) = (features(&after_stall), features(&carried_on));
    let frame_of_tick = |tick: usize| tick / 85;
    assert_eq!(stalled[..=frame_of_tick(500)], carried_on[..=frame_of_tick(500)]);
    assert_ne!(stalled[frame_of_tick(500) + 2..], carried_on[frame_of_tick(500) + 2..]);
    // a new driver epoch, with no gap, restarts it too
    let mut states = answered(0, None);
    for state in states.values_mut().filter(|s| s.tick >= 700) {
        state.epoch = 8;
    }
    let mut restarted = lockstep();
    restarted.run_replaying(|_| {}, &Replay { states_answered: states, ..Replay::default() });
    assert_eq!(restarted.resyncs(), &[0, 700]);
}
