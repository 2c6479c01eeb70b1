//! The payload layouts as docs/PROTOCOL.md prints them: one Markdown table per message, with offsets taken
//! from the compiler (`offset_of!`), so the document cannot drift from the code (a test compares them).

use std::fmt::Write;
use std::mem::{offset_of, size_of};

use crate::messages::*;

struct Field {
    name: &'static str,
    offset: usize,
    ty: &'static str,
    meaning: &'static str,
}

macro_rules! fields {
    ($msg:ty; $($name:ident: $ty:literal, $meaning:literal;)*) => {
        [$(Field { name: stringify!($name), offset: offset_of!($msg, $name), ty: $ty, meaning: $meaning }),*]
    };
}

fn table(out: &mut String, title: &str, type_name: &str, size: usize, fields: &[Field]) {
    // writing to a String cannot fail
    let _ = writeln!(out, "### {title}\n\ntype name `{type_name}`, {size} bytes, alignment 8\n");
    let _ = writeln!(out, "| offset | field | type | meaning |\n|---:|---|---|---|");
    for f in fields {
        let _ = writeln!(out, "| {} | `{}` | {} | {} |", f.offset, f.name, f.ty, f.meaning);
    }
    out.push('\n');
}

/// The tables of docs/PROTOCOL.md's "Payloads" section.
pub fn layout_tables() -> String {
    let mut out = String::new();
    table(
        &mut out,
        "joint_state",
        "vservo::JointState",
        size_of::<JointStateMsg>(),
        &fields! { JointStateMsg;
            schema: "u32", "schema version (5)";
            faults: "u32", "bits 0–5 position limit (joint 1–6), 8–13 velocity limit, 16–21 torque saturated, 24 driver failed";
            tick: "u64", "driver periods since the driver started";
            stamp_ns: "u64", "CLOCK_MONOTONIC when `q` was measured (ns)";
            driver_epoch: "u64", "changes each time the driver starts";
            period_ns: "u64", "the driver's period (ns)";
            command_mode: "u32", "the command the driver takes: 0 torque, 1 velocity, 2 position";
            driver_status: "u32", "0 following commands, 1 holding (no valid command in time), 2 fault";
            q_rad: "f64[6]", "joint angles (rad)";
            qd_rad_s: "f64[6]", "joint velocities (rad/s)";
            torque_nm: "f64[6]", "joint torques, measured or applied (N·m); NaN where unknown";
            applied_command_tick: "u64", "the `answers_tick` of the command applied over the period that ended here (`tick − 1` in time, older if the driver kept an earlier one); 2⁶⁴−1 if none (holding)";
        },
    );
    table(
        &mut out,
        "joint_command",
        "vservo::JointCommand",
        size_of::<JointCommandMsg>(),
        &fields! { JointCommandMsg;
            schema: "u32", "schema version (5)";
            mode: "u32", "the driver's declared `command_mode`: 0 torque, 1 velocity, 2 position";
            answers_tick: "u64", "the `tick` of the joint state this answers";
            driver_epoch: "u64", "that joint state's `driver_epoch`";
            state_stamp_ns: "u64", "that joint state's `stamp_ns`";
            stamp_ns: "u64", "CLOCK_MONOTONIC as the command is sent (ns)";
            torque_nm: "f64[6]", "joint torques (N·m); mode 0 only, else zero";
            q_ref_rad: "f64[6]", "joint reference q_d at the end of the next period (rad)";
            qd_ref_rad_s: "f64[6]", "joint reference velocity q̇_d over the next period (rad/s)";
            twist_capture_tick: "u64", "the `capture_tick` of the `camera_twist` this command follows (2⁶⁴−1 before the first)";
            twist_applied_tick: "u64", "the joint-state tick at which the rmrc took that twist in (2⁶⁴−1 before the first)";
            reference_since_tick: "u64", "the joint-state tick from which the rmrc's reference runs: where it last started at rest from the measured joints (the first state, a new driver epoch, a driver back after a gap)";
            seal: "u64", "the rmrc's seal under the run's key: the simulated driver applies sealed commands only; an external driver ignores it";
        },
    );
    table(
        &mut out,
        "sim_world (simulation only)",
        "vservo::SimWorld",
        size_of::<SimWorldMsg>(),
        &fields! { SimWorldMsg;
            schema: "u32", "schema version (5)";
            reserved: "u32", "zero";
            tick: "u64", "the plant tick (as in `joint_state`)";
            base_from_board: "f64[12]", "the board's pose in the base frame, 3×4 [R \\| t] row-major (t in m)";
        },
    );
    table(
        &mut out,
        "camera_image (user header; the payload is the image, a slice of u8)",
        "vservo::CameraImageHeader",
        size_of::<CameraImageHeader>(),
        &fields! { CameraImageHeader;
            schema: "u32", "schema version (5)";
            format: "u32", "0: 8-bit grayscale";
            width: "u32", "pixels per row";
            height: "u32", "rows";
            stride_bytes: "u32", "bytes from one row's start to the next (≥ width); the payload holds height × stride bytes";
            reserved: "u32", "zero";
            frame: "u64", "the camera's frame counter, from 0";
            capture_stamp_ns: "u64", "CLOCK_MONOTONIC when the image was exposed (ns)";
        },
    );
    table(
        &mut out,
        "features",
        "vservo::Features",
        size_of::<FeaturesMsg>(),
        &fields! { FeaturesMsg;
            schema: "u32", "schema version (5)";
            valid_mask: "u32", "bit m set when mark m is valid";
            frame: "u64", "frame number (counted by the vision node from its start)";
            capture_tick: "u64", "tick of the latest joint state when the image was taken";
            capture_stamp_ns: "u64", "CLOCK_MONOTONIC when the image was taken (ns)";
            stamp_ns: "u64", "CLOCK_MONOTONIC at publication, the pipeline delay later (ns)";
            features_px: "f64[8]", "ξ = [x₁ y₁ … x₄ y₄] (px, origin top-left), NaN where a mark is not valid";
            mark_status: "u8[4]", "per mark: 0 valid, 1 outside the image, 2 cut by the border, 3 merged, 4 irregular, 5 not found, 6 bad image";
            reserved: "u8[4]", "zero";
            base_from_camera: "f64[12]", "the camera's pose in the robot's base frame at capture (the joint state of `capture_tick`; for an external camera the joint states around `capture_stamp_ns`, interpolated): the top 3 rows of the 4×4 transform, row-major; NaN when not known";
        },
    );
    table(
        &mut out,
        "camera_twist",
        "vservo::CameraTwist",
        size_of::<CameraTwistMsg>(),
        &fields! { CameraTwistMsg;
            schema: "u32", "schema version (5)";
            verdict: "u32", "0 waiting (no frame yet), 1 servoing, 2 marks missing (nowhere to go back to), 3 stopping, 4 safe stop (held by the daemon), 5 servoing on the three marks seen, 6 reacquiring (steering back to where all marks were last seen); 0, 2, 3 and 4 come with a zero twist";
            frame: "u64", "the frame the twist was computed from";
            capture_tick: "u64", "its capture tick";
            gains_version: "u64", "version of the gains used (1 at start)";
            stamp_ns: "u64", "CLOCK_MONOTONIC at publication (ns)";
            twist: "f64[6]", "u = [v_x v_y v_z ω_x ω_y ω_z] in the camera frame (m/s, rad/s)";
            feature_error_px: "f64", "RMS of ξ − ξ_d over the valid features (px); NaN when none";
            missing_mask: "u32", "bit m set when mark m was missing";
            law_flags: "u32", "what the law did beyond its design: 1 the border barrier changed the twist, 2 the frame's own design failed and the fixed gain was used, 4 the target's motion was fed forward; 0 unless the law computed the twist";
        },
    );
    table(
        &mut out,
        "telemetry",
        "vservo::Telemetry",
        size_of::<TelemetryMsg>(),
        &fields! { TelemetryMsg;
            schema: "u32", "schema version (5)";
            node: "u32", "0 plant, 1 vision, 2 servo, 3 rmrc";
            stamp_ns: "u64", "CLOCK_MONOTONIC at publication (ns)";
            window_ns: "u64", "length of the window the timings cover (ns)";
            cycles: "u64", "loop cycles since the node started";
            overruns: "u64", "cycles a period or more late (event-driven nodes: answer later than one period)";
            skipped_periods: "u64", "periods skipped after stalls (not replayed)";
            late_answers: "u64", "plant: ticks whose rmrc answer came late (previous command held)";
            rejected_messages: "u64", "input messages refused (schema, epoch, tick, not finite)";
            gains_version: "u64", "servo: gains version in use; else 0";
            progress: "u64", "plant: tick; vision, servo: frame; rmrc: tick answered";
            wake_latency: "Timing", "wake-up after the deadline (periodic nodes) or after the input was sent (event-driven)";
            execution: "Timing", "wake-up to output";
            round_trip: "Timing", "plant: joint state published → the rmrc's answer in the plant's queue";
            frame_period: "Timing", "vision: between the capture stamps of successive images";
            capture_latency: "Timing", "servo: an image's capture → the twist computed from it";
            feature_error_px: "f64", "servo: RMS feature error of the latest frame (px); else NaN";
            pid: "u32", "process id";
            mode: "u32", "plant: 1 while holding the arm; servo: the last verdict; else 0";
        },
    );
    table(
        &mut out,
        "Timing (inside telemetry)",
        "vservo::Timing",
        size_of::<TimingMsg>(),
        &fields! { TimingMsg;
            count: "u64", "samples in the window";
            p50_ns: "u64", "median (ns)";
            p99_ns: "u64", "99th percentile (ns)";
            p999_ns: "u64", "99.9th percentile (ns)";
            max_ns: "u64", "largest (ns)";
        },
    );
    table(
        &mut out,
        "status",
        "vservo::DaemonStatus",
        size_of::<DaemonStatusMsg>(),
        &fields! { DaemonStatusMsg;
            schema: "u32", "schema version (5)";
            state: "u32", "0 starting, 1 running, 2 degraded, 3 stopping, 4 safe stop (a fault holds the arm at rest)";
            stamp_ns: "u64", "CLOCK_MONOTONIC at publication (ns)";
            uptime_ns: "u64", "since the daemon started (ns)";
            gains_version: "u64", "gains version in use";
            nodes: "NodeStatus[4]", "indexed by node number (0 plant, 1 vision, 2 servo, 3 rmrc)";
            tick_rate_hz: "f64", "joint states per wall-clock second over the last second";
            feature_error_px: "f64", "the servo's latest RMS feature error (px); NaN before the first frame";
            pid: "u32", "the daemon's process id";
            robot: "u32", "the robot driver: 0 no joint state yet, 1 joint states on time, 2 stalled (none within the deadline)";
            fault: "u32", "the fault holding the cell (state 4), or the last one: 0 none, 1 position limit, 2 velocity limit, 3 torque saturated, 4 driver fault, 5 target lost, 6 robot stalled, 7 requested";
            fault_joints: "u32", "bit j: the fault concerns joint j + 1";
            fault_since_ns: "u64", "CLOCK_MONOTONIC when the fault was found (ns); 0 when none";
            safe_stops: "u64", "safe stops since the daemon started";
        },
    );
    table(
        &mut out,
        "NodeStatus (inside status)",
        "vservo::NodeStatus",
        size_of::<NodeStatusMsg>(),
        &fields! { NodeStatusMsg;
            restarts: "u64", "restarts since the daemon started";
            last_telemetry_ns: "u64", "CLOCK_MONOTONIC of the node's latest telemetry (0: none yet)";
            state: "u32", "0 not started, 1 running, 2 backing off (restart pending), 3 stopped, 4 hung (being killed, then restarted)";
            pid: "u32", "process id (0 when not running)";
            last_exit: "i32", "exit status of the last run; a signal as its negated number";
            healthy: "u32", "1 when the node's telemetry is fresh (under 0.5 s old)";
        },
    );
    table(
        &mut out,
        "gains",
        "vservo::Gains",
        size_of::<GainsMsg>(),
        &fields! { GainsMsg;
            schema: "u32", "schema version (5)";
            used_past_gains: "u32", "how many of `past_input_gains` the law uses (0 for the paper's law)";
            version: "u64", "1 at start, +1 per accepted reload or target";
            feature_gain: "f64[48]", "K_ξ, 6×8 row-major (m/s and rad/s per px)";
            past_input_gains: "f64[144]", "K_j on the command sent j + 1 frames ago, four 6×6 row-major";
            desired_features_px: "f64[8]", "ξ_d (px)";
            desired_depths_m: "f64[4]", "Z_d, the marks' depths at the desired pose (m)";
            q: "f64[64]", "Q, 8×8 row-major (for the gains on three marks and a scheduled gain, designed by the servo)";
            r_si: "f64[36]", "R in SI units, 6×6 row-major";
            interaction: "u32", "where B is evaluated: 0 at ξ_d (fixed gain), 1 the mean of ξ_d's and the current, 2 the current";
            feedforward: "u32", "1: the target's image motion is fed forward";
            border_margin_px: "f64", "the barrier keeps seen marks this far inside the image (0: none)";
            seal: "u64", "the daemon's seal (SipHash-2-4 of the fields under the run's key): other gains are refused";
        },
    );
    table(
        &mut out,
        "object",
        "vservo::Object",
        size_of::<ObjectMsg>(),
        &fields! { ObjectMsg;
            schema: "u32", "schema version (5)";
            kind: "u32", "4 hold, 5 step, 6 circle (as in `command`)";
            sequence: "u64", "counts the object commands (1 for the first)";
            translation_m: "f64[3]", "step: the jump in the desired camera frame (m)";
            radius_m: "f64", "circle: radius (m)";
            rev_per_min: "f64", "circle: speed (rev/min)";
            seal: "u64", "the daemon's seal (SipHash-2-4 of the fields under the run's key): other object commands are refused";
        },
    );
    table(
        &mut out,
        "cell_mode",
        "vservo::CellMode",
        size_of::<CellModeMsg>(),
        &fields! { CellModeMsg;
            schema: "u32", "schema version (5)";
            mode: "u32", "0 servoing, 1 safe stop (the rmrc ramps the reference to rest and holds it; the servo sends zero twists)";
            sequence: "u64", "counts the changes (1 at the daemon's start); only a newer one is taken";
            fault: "u32", "safe stop: the fault that caused it (as in `status`)";
            fault_joints: "u32", "safe stop: bit j, joint j + 1 concerned";
            stamp_ns: "u64", "CLOCK_MONOTONIC when decided (ns)";
            seal: "u64", "the daemon's seal (SipHash-2-4 of the fields under the run's key): other modes are refused";
        },
    );
    table(
        &mut out,
        "command (request)",
        "vservo::Command",
        size_of::<CommandMsg>(),
        &fields! { CommandMsg;
            schema: "u32", "schema version (5)";
            kind: "u32", "1 target features, 2 target pose, 3 teach, 4 object hold, 5 object step, 6 object circle, 7 reload, 8 resume, 9 safe stop";
            id: "u64", "chosen by the client; the reply carries it back";
            features_px: "f64[8]", "kind 1: ξ_d (px)";
            translation_m: "f64[3]", "kind 2: the board's position in the desired camera frame (m); kind 5: the jump (m)";
            rotation_rpy_rad: "f64[3]", "kind 2: the board's orientation in the desired camera frame, roll, pitch, yaw (rad), R = Rz·Ry·Rx";
            radius_m: "f64", "kind 6: radius (m)";
            rev_per_min: "f64", "kind 6: speed (rev/min)";
        },
    );
    table(
        &mut out,
        "command (reply)",
        "vservo::CommandReply",
        size_of::<CommandReplyMsg>(),
        &fields! { CommandReplyMsg;
            schema: "u32", "schema version (5)";
            accepted: "u32", "1 accepted, 0 refused";
            id: "u64", "the request's `id`";
            gains_version: "u64", "the gains version in force after the command";
            target_features_px: "f64[8]", "ξ_d in force after the command (px)";
            reason: "u8[256]", "why it was refused, or what was done: UTF-8, zero-padded";
        },
    );
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn protocol_md_shows_the_layouts_of_this_build() {
        let doc = include_str!("../../../docs/PROTOCOL.md");
        let tables = super::layout_tables();
        assert!(
            doc.contains(&tables),
            "docs/PROTOCOL.md is out of date: paste `cargo run -q -p vservo-protocol --example layout` into its Payloads section"
        );
    }
}
