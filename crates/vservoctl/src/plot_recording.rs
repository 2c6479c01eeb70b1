//! `vservoctl plot FILE --out DIR`: the figures of `vservoctl sim`, drawn from an MCAP recording of a
//! running instance (`vservoctl record`).

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use serde_json::Value;
use vservo_arm::JointVector;
use vservo_control::Twist;
use vservo_lockstep::{FrameRecord, JointRecord, Trace};
use vservo_protocol::fault_bits;
use vservo_scene::FeatureVector;
use vservo_sim::plant::Faults;

use crate::config_arg::ConfigArg;

/// Arguments of `vservoctl plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// The MCAP recording.
    file: PathBuf,
    /// Where the figures go.
    #[arg(long, default_value = "plot-out")]
    out: PathBuf,
    /// The configuration the recorded instance ran (for the camera and the desired pose).
    #[command(flatten)]
    config: ConfigArg,
    /// Also a contact sheet of N of the recorded camera images (`vservoctl record --image-every`), spread over
    /// the recording, each with its marks drawn: frames.svg (and frames.json).
    #[arg(long, value_name = "N", default_value_t = 0)]
    frames: usize,
}

fn numbers<const N: usize>(value: &Value) -> Option<[f64; N]> {
    let array = value.as_array()?;
    (array.len() == N).then(|| std::array::from_fn(|i| array[i].as_f64().unwrap_or(f64::NAN)))
}

/// A joint state as recorded: q, q̇, τ (the arm's joints, the other slots zero) and the fault bits.
type RecordedState = (JointVector, JointVector, JointVector, u32);

/// What a recording holds that the figures need.
struct Recorded {
    /// (frame, capture tick, features) in the order recorded.
    features: Vec<(u64, u64, FeatureVector)>,
    /// The twist computed from each frame.
    twists: BTreeMap<u64, Twist>,
    /// The joint states by tick.
    states: BTreeMap<u64, RecordedState>,
    /// ξ_d, the last the gains said.
    desired: FeatureVector,
}

/// A recording turned into the lockstep's trace: one frame per recorded feature vector (time from the
/// first frame's capture tick), the twist computed from it, the camera where the joint state of its
/// capture tick put it; joints every 10 ms.
pub fn trace_of(bytes: &[u8], config: &vservo_config::Config) -> anyhow::Result<Trace> {
    let recorded = read_recording(bytes, config)?;
    let Some(&(_, first_tick, _)) = recorded.features.first() else {
        bail!("the recording holds no features: was the instance running while it recorded?");
    };
    Ok(Trace {
        frames: camera_frames(&recorded, config, first_tick),
        joints: joints_every_10_ms(&recorded.states, config.cell.timing.control_period_s, first_tick),
        faults: faults_seen(&recorded.states),
        desired_features: recorded.desired,
        clearance: None,
    })
}

/// vservo's services in the recording (JSON; Foxglove's views are for Foxglove); joint states of another arm
/// than the configured one refused.
fn read_recording(bytes: &[u8], config: &vservo_config::Config) -> anyhow::Result<Recorded> {
    let joint_count = config.cell.arm.joint_count();
    let mut recorded = Recorded {
        features: Vec::new(),
        twists: BTreeMap::new(),
        states: BTreeMap::new(),
        desired: config.cell.desired.features,
    };
    let mut foreign_states = 0u64;
    for message in mcap::MessageStream::new(bytes)? {
        let message = message?;
        if message.channel.message_encoding != "json" {
            continue;
        }
        let topic = message.channel.topic.rsplit('/').next().unwrap_or_default().to_string();
        let data: Value = serde_json::from_slice(&message.data).context("a message that is not JSON")?;
        match topic.as_str() {
            "features" => {
                let (Some(frame), Some(tick), Some(xi)) = (
                    data["frame"].as_u64(),
                    data["capture_tick"].as_u64(),
                    numbers::<8>(&data["features_px"]),
                ) else {
                    continue;
                };
                recorded.features.push((frame, tick, FeatureVector::from(xi)));
            }
            "camera_twist" => {
                if let (Some(frame), Some(twist)) = (data["frame"].as_u64(), numbers::<6>(&data["twist"])) {
                    recorded.twists.insert(frame, Twist::from(twist));
                }
            }
            "joint_state" => match joint_state(&data, joint_count) {
                Some(Ok((tick, state))) => {
                    recorded.states.insert(tick, state);
                }
                Some(Err(())) => foreign_states += 1,
                None => {}
            },
            "gains" => {
                if let Some(xi) = numbers::<8>(&data["desired_features_px"]) {
                    recorded.desired = FeatureVector::from(xi);
                }
            }
            _ => {}
        }
    }
    if foreign_states > 0 {
        bail!(
            "{foreign_states} joint states of the recording are not of the configured arm ({joint_count} joints, {}): plot it with the configuration it was recorded with",
            config.origin
        );
    }
    Ok(recorded)
}

/// A recorded joint state's tick and values; `Some(Err)` for a state of an arm of another joint count (it would
/// be drawn wrongly), `None` for one that is not a joint state.
fn joint_state(data: &Value, joint_count: usize) -> Option<Result<(u64, RecordedState), ()>> {
    let (Some(tick), Some(q), Some(qd)) =
        (data["tick"].as_u64(), numbers::<7>(&data["q_rad"]), numbers::<7>(&data["qd_rad_s"]))
    else {
        return None;
    };
    if data["joint_count"].as_u64() != Some(joint_count as u64) {
        return Some(Err(()));
    }
    // a driver that does not know its torques sends NaN (null)
    let torque = numbers::<7>(&data["torque_nm"]).unwrap_or([f64::NAN; 7]);
    let faults = data["faults"].as_u64().unwrap_or(0) as u32;
    let arm_joints = |v: [f64; 7]| vservo_arm::joint_vector(&v[..joint_count.min(7)]).unwrap_or_default();
    Some(Ok((tick, (arm_joints(q), arm_joints(qd), arm_joints(torque), faults))))
}

/// One record per frame: the camera where the joint state nearest its capture tick put it.
fn camera_frames(recorded: &Recorded, config: &vservo_config::Config, first_tick: u64) -> Vec<FrameRecord> {
    let arm = &config.cell.arm;
    let mount = config.cell.mount();
    // the camera relative to the board: in the frame that holds the board still (the base for a hand camera)
    let desired_from_holder =
        mount.holder_from_camera(&arm.base_from_tool(&config.cell.desired.joints)).inverse();
    let states = &recorded.states;
    let mut frames = Vec::with_capacity(recorded.features.len());
    for (frame, tick, measured) in &recorded.features {
        let Some((_, (q, ..))) = states.range(..=*tick).next_back().or_else(|| states.range(*tick..).next())
        else {
            continue;
        };
        let base_from_tool = arm.base_from_tool(q);
        let base_from_camera = mount.base_from_camera(&base_from_tool);
        frames.push(FrameRecord {
            t_s: tick.saturating_sub(first_tick) as f64 * config.cell.timing.control_period_s,
            measured: *measured,
            truth: FeatureVector::from_element(f64::NAN),
            twist: recorded.twists.get(frame).copied().unwrap_or_else(Twist::zeros),
            verdict: None,
            camera_position_m: base_from_camera.translation.vector,
            camera_in_desired_m: (desired_from_holder * mount.holder_from_camera(&base_from_tool))
                .translation
                .vector,
            motion_blur_px: 0.0,
        });
    }
    frames
}

/// The joint states from the first frame on, one every 10 ms.
fn joints_every_10_ms(states: &BTreeMap<u64, RecordedState>, dt: f64, first_tick: u64) -> Vec<JointRecord> {
    let every = (0.01 / dt).round().max(1.0) as u64;
    states
        .iter()
        .filter(|(tick, _)| *tick % every == 0 && **tick >= first_tick)
        .map(|(tick, (q, qd, torque, _))| JointRecord {
            t_s: (tick - first_tick) as f64 * dt,
            q: *q,
            qd: *qd,
            torque: *torque,
        })
        .collect()
}

/// Every fault bit any joint state carried.
fn faults_seen(states: &BTreeMap<u64, RecordedState>) -> Faults {
    let mut faults = Faults::default();
    for (.., bits) in states.values() {
        let joints = |shift| fault_bits::joints(*bits, shift) as u8;
        faults.position_limit |= joints(fault_bits::POSITION_LIMIT_SHIFT);
        faults.velocity_limit |= joints(fault_bits::VELOCITY_LIMIT_SHIFT);
        faults.torque_saturated |= joints(fault_bits::TORQUE_SATURATED_SHIFT);
        faults.integration_failed |= bits & fault_bits::DRIVER_FAILED != 0;
    }
    faults
}

pub fn run(args: &PlotArgs) -> anyhow::Result<()> {
    let config = args.config.load()?;
    let bytes = std::fs::read(&args.file).with_context(|| format!("reading {}", args.file.display()))?;
    let trace = trace_of(&bytes, &config).with_context(|| format!("{}", args.file.display()))?;
    vservo_config::new_file::folder(&args.out)?;
    crate::plots::draw(&trace, &config, &args.out)?;
    println!(
        "{} frames, {} joint states every 10 ms: figures in {}",
        trace.frames.len(),
        trace.joints.len(),
        args.out.display()
    );
    if args.frames > 0 {
        let drawn = crate::contact_sheet::write(&bytes, &config, args.frames, &args.out)
            .with_context(|| format!("{}: the contact sheet", args.file.display()))?;
        println!("{drawn} camera images with their marks: {}", args.out.join("frames.svg").display());
    }
    Ok(())
}
