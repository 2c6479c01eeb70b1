#!/usr/bin/env python3
"""A robot cell on ROS 2 for vservo's ROS 2 driver: a ros2_control arm and a ROS camera, simulated by MuJoCo.

On the wire (Cyclone DDS, ROS 2's names and types, clients/python/ros2_types.py) this process is what a real cell
runs under ROS 2: the arm's `controller_manager` with its `joint_state_broadcaster` and a
`forward_command_controller` velocity controller, and a camera driver. vservo (`[robot] driver = "ros2"`,
`[camera] source = "ros2"`, docs/ROS2.md) reads the joint states and the images and commands the controller,
closing its visual-servo loop through ROS 2. The arm and the camera are mujoco_driver.py's (`build_mjcf`, `Arm`,
`Lens`): the scene's standard-DH arm and its hand camera.

- joint_state_broadcaster: every period (`--rate-hz`, default the scene's robot period) it publishes
  `sensor_msgs/JointState` on `joint_states` (DDS topic `rt/joint_states`, type
  `sensor_msgs::msg::dds_::JointState_`; reliable, the last 10): the joints' positions, velocities and drive
  torques, stamped with the system clock (ROS time) when they were read;
- forward_command_controller: it takes `std_msgs/Float64MultiArray` on `forward_velocity_controller/commands`
  (`rt/forward_velocity_controller/commands`, `std_msgs::msg::dds_::Float64MultiArray_`; reliable, the last 10)
  as the joint velocities (rad/s), or with --controller position on `forward_position_controller/commands` as
  the joint positions (rad) to reach by the period's end, and holds each until the next, with no timeout, as
  the real controller does
  (the watchdog is the commander's); one whose length is not the joint count is refused, as is one with a value
  not finite (which the real controller would pass on);
- camera: every vision period it renders the hand camera at the newest joint state and publishes
  `sensor_msgs/Image` on `camera/image_raw` (`rt/camera/image_raw`, `sensor_msgs::msg::dds_::Image_`; mono8,
  frame `camera`; best effort, the last 5: ROS's sensor data profile, or with --image-reliable reliable, the
  last 10: usb_cam's), stamped with the joint state it shows (its exposure).

    ros2_control_arm.py --scene scene.json --domain D [--namespace /ns] [--duration-s S]
                        [--joint-names j1,j2,...] [--joint-states-topic joint_states]
                        [--controller velocity|position] [--command-topic forward_velocity_controller/commands]
                        [--image-topic camera/image_raw]
                        [--image-reliable] [--rate-hz R] [--summary FILE]

Topic names are relative to --namespace; a leading / makes one absolute. The scene comes from `vservoctl scene
--config FILE`. Discovery is Cyclone DDS's (CYCLONEDDS_URI, or its default multicast). It prints
"ros2_control_arm: ready" once the first joint state is out; SIGINT/SIGTERM stop it (exit code 0), and it then
prints what it did (and writes it as JSON to --summary).
"""

import argparse
import json
import math
import os
import signal
import struct
import sys
import threading
import time
from array import array

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco loads: headless OpenGL (as mujoco_driver.py sets it)

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from cyclonedds.core import DDSException, Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402

import ros2_types as ros  # noqa: E402
from mujoco_driver import Arm, Lens, build_mjcf  # noqa: E402
from vservo_driver import sleep_until  # noqa: E402

PROGRAM = "ros2_control_arm"
MAX_CATCH_UP_PERIODS = 100  # the most periods of physics one late wake-up makes up for
COMMANDS_PER_TAKE = 64

# rclcpp's SystemDefaultsQoS (ros2_control's publishers and subscriptions): reliable, volatile, the last 10
RELIABLE = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
               Policy.History.KeepLast(10))
# rmw_qos_profile_sensor_data: best effort, volatile, the last 5
SENSOR_DATA = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5))


def log(message):
    print(f"{PROGRAM}: {message}", file=sys.stderr, flush=True)


def ros_time(stamp_ns):
    """builtin_interfaces/Time of a system-clock stamp."""
    return ros.Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)


def dds_topic(namespace, name):
    """The DDS topic of a ROS topic name, relative to the namespace unless it starts with /."""
    return "rt" + name if name.startswith("/") else ros.topic_name(namespace, name)


class RawImage(ros.Image):
    """`sensor_msgs/Image` whose `data` is `bytes`, serialized as one block.

    cyclonedds (11.0.1) serializes a sequence[uint8] as struct.pack_into of one argument per byte: ~10 ms for
    512 × 512, holding the GIL, so the arm loop would miss ten 1 ms periods a frame. `data` is the last member
    and a sequence<uint8> is its 4-byte length then the bytes, unaligned: the message serialized with no data,
    its length patched and the bytes appended is the same CDR (`serialization_is_exact` checks), ~20 µs.
    Written on a topic of `ros.Image` (a subclass passes DataWriter.write's type check).
    """

    def serialize(self, buffer=None, endianness=None, use_version_2=None):
        empty = ros.Image(header=self.header, height=self.height, width=self.width, encoding=self.encoding,
                          is_bigendian=self.is_bigendian, step=self.step)
        head = empty.serialize(buffer, endianness, use_version_2)  # ends with the data's length, 0
        length = struct.pack("<I" if head[1] & 1 else ">I", len(self.data))  # encapsulation id: odd = little-endian
        return head[:-4] + length + bytes(self.data)


def serialization_is_exact():
    """RawImage's bytes are cyclonedds' own, for data lengths that leave each padding, in XCDR1 and 2."""
    for length in (0, 1, 3, 6):
        fields = {"header": ros.Header(stamp=ros.Time(sec=1, nanosec=2), frame_id="camera"), "height": 1,
                  "width": length, "encoding": "mono8", "step": length}
        data = bytes(range(7, 7 + length))
        for version_2 in (False, True):
            if (RawImage(data=data, **fields).serialize(use_version_2=version_2)
                    != ros.Image(data=list(data), **fields).serialize(use_version_2=version_2)):
                return False
    return True


class ForwardController:
    """ros2_control's forward_command_controller on the joints' velocity or position interface: the newest
    Float64MultiArray is the command, held until the next (no timeout).

    Read once a period, before the joint state goes out: ros2_control's update() reads the newest message its
    subscription stored; a message's receipt here is when it is taken (up to one period after it arrived).
    """

    def __init__(self, reader, joint_count, interface):
        self.reader, self.joint_count, self.interface = reader, joint_count, interface
        self.command = None  # rad/s or rad, as the interface says; none yet: the arm stays where it is
        self.taken, self.refused_length, self.refused_non_finite = 0, 0, 0
        self.last_command = None
        self.state_to_command_ns = array("q")  # receipt less the stamp of the newest joint state before it

    def velocity_rad_s(self, q_ref_rad, period_s):
        """The joint velocities for the next period: the command (velocity), or what takes the arm's
        reference to the commanded position by the period's end (position)."""
        if self.command is None:
            return np.zeros(self.joint_count)
        if self.interface == "position":
            return (self.command - q_ref_rad) / period_s
        return self.command

    def update(self, newest_state_stamp_ns):
        for sample in self.reader.take(COMMANDS_PER_TAKE):
            if not isinstance(sample, ros.Float64MultiArray):
                continue  # a writer gone (an invalid sample: no data)
            received_ns = time.time_ns()
            if len(sample.data) != self.joint_count:
                self.refused_length += 1  # as the real controller: the wrong size is ignored
                continue
            command = np.array(sample.data, dtype=float)
            if not np.all(np.isfinite(command)):
                # the real controller writes NaN or infinity through to the hardware; this arm refuses it
                self.refused_non_finite += 1
                continue
            self.command, self.last_command = command, sample.data
            self.taken += 1
            if newest_state_stamp_ns is not None:
                self.state_to_command_ns.append(received_ns - newest_state_stamp_ns)

    @property
    def refused(self):
        return self.refused_length + self.refused_non_finite


class JointStateBroadcaster:
    """ros2_control's joint_state_broadcaster: the joints' positions, velocities and drive torques (incl.
    gravity, as mujoco_driver reports them), stamped with the system clock when read."""

    def __init__(self, writer, joint_names):
        self.writer, self.joint_names = writer, list(joint_names)
        self.published, self.failed = 0, 0

    def publish(self, data):
        joints = len(self.joint_names)
        stamp_ns = time.time_ns()
        q_rad = data.qpos[:joints].copy()
        message = ros.JointState(header=ros.Header(stamp=ros_time(stamp_ns), frame_id=""), name=self.joint_names,
                                 position=q_rad.tolist(), velocity=data.qvel[:joints].tolist(),
                                 effort=(data.qfrc_actuator[:joints] + data.qfrc_gravcomp[:joints]).tolist())
        try:
            self.writer.write(message)
            self.published += 1
        except DDSException as why:  # a reliable reader that stopped acknowledging (until its lease runs out)
            self.failed += 1
            if self.failed == 1:
                log(f"warning: a joint state was not published ({why})")
        return q_rad, stamp_ns


def grab(model, data, renderer, lens, q_rad):
    """The image (height × width, u8) the hand camera sees with the arm at q: mujoco_driver's Camera.grab."""
    data.qpos[:len(q_rad)] = q_rad
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)
    renderer.update_scene(data, camera="camera")
    return lens.image(renderer.render()[:, :, 0])  # every surface is gray: red = green = blue


class CameraDriver(threading.Thread):
    """Renders the hand camera every vision period at the newest joint state and publishes it as
    `sensor_msgs/Image`, stamped with that state's stamp. The OpenGL context belongs to this thread. MuJoCo
    releases the GIL for most of a render, but Mesa's render threads and the rest still cost the arm loop a
    period now and then (measured on 2 cores: ~1.5 % of 1 ms periods missed with rendering, ~0.2 % without)."""

    def __init__(self, model, scene, writer, newest_state, stop):
        super().__init__(name="camera", daemon=True)
        self.model, self.writer, self.newest_state, self.stop = model, writer, newest_state, stop
        self.camera = scene["camera"]
        self.period_ns = round(scene["timing"]["vision_period_s"] * 1e9)
        self.image_type = RawImage if serialization_is_exact() else ros.Image
        self.render_ms, self.publish_ms = [], []
        self.published, self.failed = 0, 0
        self.ready = threading.Event()

    def run(self):
        lens = Lens(self.camera)
        renderer = mujoco.Renderer(self.model, lens.canvas_height, lens.canvas_width)
        data = mujoco.MjData(self.model)
        grab(self.model, data, renderer, lens, self.newest_state()[0])  # OpenGL's set-up (~0.2 s): before the arm
        self.ready.set()
        deadline_ns = time.monotonic_ns()
        while not self.stop.is_set():
            q_rad, stamp_ns = self.newest_state()
            started = time.perf_counter()
            image = grab(self.model, data, renderer, lens, q_rad)
            rendered = time.perf_counter()
            self.publish(image, stamp_ns)
            self.render_ms.append(1e3 * (rendered - started))
            self.publish_ms.append(1e3 * (time.perf_counter() - rendered))
            deadline_ns = max(deadline_ns + self.period_ns, time.monotonic_ns() - self.period_ns // 2)  # no making up
            sleep_until(deadline_ns)
        renderer.close()

    def publish(self, image, stamp_ns):
        width, height = self.camera["width_px"], self.camera["height_px"]
        pixels = image.tobytes()  # row by row
        message = self.image_type(header=ros.Header(stamp=ros_time(stamp_ns), frame_id="camera"), height=height,
                                  width=width, encoding="mono8", is_bigendian=0, step=width,
                                  data=pixels if self.image_type is RawImage else list(pixels))
        try:
            self.writer.write(message)
            self.published += 1
        except DDSException as why:  # a reliable writer whose readers do not keep up: the frame is dropped
            self.failed += 1
            if self.failed == 1:
                log(f"warning: an image was not published ({why})")


def percentiles_ms(name, values_ns):
    """`name`_p50, _p99 and _max of durations in ns, in ms (None without any)."""
    values_ms = np.asarray(values_ns, dtype=float) / 1e6
    return {f"{name}_p50": float(np.quantile(values_ms, 0.5)) if len(values_ms) else None,
            f"{name}_p99": float(np.quantile(values_ms, 0.99)) if len(values_ms) else None,
            f"{name}_max": float(values_ms.max()) if len(values_ms) else None}


def mean_max_ms(name, values_ms):
    return {f"{name}_mean": float(np.mean(values_ms)) if values_ms else None,
            f"{name}_max": float(np.max(values_ms)) if values_ms else None}


def steps_per_period(model, period_s):
    """MuJoCo steps per period of the loop (its timestep is the scene's robot period, build_mjcf)."""
    timestep_s = model.opt.timestep
    steps = round(period_s / timestep_s)
    if steps < 1:
        raise SystemExit(f"{PROGRAM}: --rate-hz {1 / period_s:g} is faster than the physics "
                         f"({1 / timestep_s:g} steps/s)")
    if abs(steps * timestep_s - period_s) > 1e-9:
        log(f"warning: a period of {period_s * 1e3:g} ms is {steps} steps of {timestep_s * 1e3:g} ms: "
            "the simulated arm runs off wall-clock time")
    return steps


def parse_arguments(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", required=True, help="scene JSON (vservoctl scene --config FILE)")
    parser.add_argument("--domain", type=int, required=True, help="the ROS_DOMAIN_ID")
    parser.add_argument("--namespace", default="", help="the ROS namespace of the topics (e.g. /cell)")
    parser.add_argument("--duration-s", type=float, default=math.inf)
    parser.add_argument("--joint-names", help="comma-separated; default joint1..jointN")
    parser.add_argument("--joint-states-topic", default="joint_states")
    parser.add_argument("--controller", choices=("velocity", "position"), default="velocity",
                        help="the forward controller's interface (default velocity)")
    parser.add_argument("--command-topic", help="default forward_velocity_controller/commands, or "
                        "forward_position_controller/commands with --controller position")
    parser.add_argument("--image-topic", default="camera/image_raw")
    parser.add_argument("--image-reliable", action="store_true",
                        help="publish images reliable, the last 10 (usb_cam's) instead of best effort, the last 5")
    parser.add_argument("--rate-hz", type=float, help="joint states per second; default 1 / the scene's robot period")
    parser.add_argument("--summary", help="write what was done here as JSON at exit")
    return parser.parse_args(argv)


class SharedState:
    """The newest joint state (q, its stamp) for the camera thread."""

    def __init__(self, q_rad):
        self.lock, self.q_rad, self.stamp_ns = threading.Lock(), q_rad, time.time_ns()

    def set(self, q_rad, stamp_ns):
        with self.lock:
            self.q_rad, self.stamp_ns = q_rad, stamp_ns

    def get(self):
        with self.lock:
            return self.q_rad, self.stamp_ns


def run_arm(arm, broadcaster, controller, shared, period_ns, steps, duration_s, stop):
    """The arm loop on absolute deadlines (CLOCK_MONOTONIC): ros2_control's cycle each period, the controllers'
    update (the newest command taken, the joint state out), then the hardware's write and the arm moving for
    the periods that passed (normally one). What it measured."""
    gaps_ns, last_publish_ns, state_stamp_ns, faults = array("q"), None, None, 0
    tick, periods_missed, start_ns = 0, 0, time.monotonic_ns()
    while not stop.is_set():
        controller.update(state_stamp_ns)
        q_rad, state_stamp_ns = broadcaster.publish(arm.data)
        now_ns = time.monotonic_ns()
        shared.set(q_rad, state_stamp_ns)
        if last_publish_ns is None:
            log("ready")
        else:
            gaps_ns.append(now_ns - last_publish_ns)
        last_publish_ns = now_ns
        faults |= arm.faults()
        if now_ns - start_ns >= duration_s * 1e9:
            break
        sleep_until(start_ns + (tick + 1) * period_ns)
        periods = max(1, (time.monotonic_ns() - start_ns) // period_ns - tick)
        for _ in range(min(periods, MAX_CATCH_UP_PERIODS)):
            velocity_rad_s = controller.velocity_rad_s(arm.q_ref, period_ns / 1e9)
            for _ in range(steps):
                arm.step(velocity_rad_s)
        tick += periods
        periods_missed += periods - 1
    return {"elapsed_s": (time.monotonic_ns() - start_ns) / 1e9, "gaps_ns": gaps_ns, "periods_missed": periods_missed,
            "faults": faults}


def summarize(options, topics, joint_names, period_s, steps, arm, loop, broadcaster, controller, camera):
    elapsed_s, gaps_ns = loop["elapsed_s"], loop["gaps_ns"]
    return {
        "topics": topics,
        "joint_names": joint_names,
        "rate_hz": 1 / period_s,
        "physics_steps_per_period": steps,
        "elapsed_s": elapsed_s,
        "joint_states_published": broadcaster.published,
        "joint_states_per_s": broadcaster.published / elapsed_s if elapsed_s > 0 else None,
        "joint_states_failed": broadcaster.failed,
        "periods_missed": loop["periods_missed"],
        **percentiles_ms("joint_state_gap_ms", gaps_ns),
        "commands_taken": controller.taken,
        "commands_refused": controller.refused,
        "commands_refused_length": controller.refused_length,
        "commands_refused_non_finite": controller.refused_non_finite,
        "controller": controller.interface,
        "last_command": controller.last_command,
        "state_to_command_count": len(controller.state_to_command_ns),  # receipt less the newest state's stamp
        **percentiles_ms("state_to_command_ms", controller.state_to_command_ns),
        "frames_published": camera.published,
        "frames_failed": camera.failed,
        "image_reliable": options.image_reliable,
        **mean_max_ms("render_ms", camera.render_ms),
        **mean_max_ms("image_publish_ms", camera.publish_ms),
        "image_serialization": "spliced bytes" if camera.image_type is RawImage else "cyclonedds sequence[uint8]",
        "final_joints_rad": arm.data.qpos[:len(joint_names)].tolist(),
        "fault_bits_seen": loop["faults"],
    }


def main(argv=None) -> int:
    options = parse_arguments(argv)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    with open(options.scene) as file:
        scene = json.load(file)
    if scene["arm"].get("dh") is None:
        log("this arm is built from a standard-DH table; the scene's arm comes from a URDF")
        return 2
    joints = len(scene["start_joints_rad"])
    joint_names = (options.joint_names.split(",") if options.joint_names
                   else [f"joint{i}" for i in range(1, joints + 1)])
    if len(joint_names) != joints:
        log(f"--joint-names gives {len(joint_names)} names; the arm has {joints} joints")
        return 2
    model = mujoco.MjModel.from_xml_string(build_mjcf(scene))
    arm = Arm(model, scene)
    period_s = 1.0 / options.rate_hz if options.rate_hz else scene["robot"]["period_s"]
    steps = steps_per_period(model, period_s)

    namespace = "/" + options.namespace.strip("/") if options.namespace.strip("/") else ""
    topics = {kind: dds_topic(namespace, name) for kind, name in (
        ("joint_states", options.joint_states_topic), ("commands", options.command_topic or f"forward_{options.controller}_controller/commands"),
        ("image", options.image_topic))}
    participant = DomainParticipant(options.domain)
    broadcaster = JointStateBroadcaster(
        DataWriter(participant, Topic(participant, topics["joint_states"], ros.JointState), qos=RELIABLE),
        joint_names)
    controller = ForwardController(
        DataReader(participant, Topic(participant, topics["commands"], ros.Float64MultiArray), qos=RELIABLE), joints,
        options.controller)
    image_qos = RELIABLE if options.image_reliable else SENSOR_DATA
    image_writer = DataWriter(participant, Topic(participant, topics["image"], ros.Image), qos=image_qos)

    shared = SharedState(arm.data.qpos[:joints].copy())
    camera = CameraDriver(model, scene, image_writer, shared.get, stop)
    camera.start()
    while not camera.ready.wait(0.1):
        if not camera.is_alive():
            return 1  # the camera failed to start (its error is printed)
    loop = run_arm(arm, broadcaster, controller, shared, round(period_s * 1e9), steps, options.duration_s, stop)
    stop.set()
    camera.join(timeout=5.0)

    summary = summarize(options, topics, joint_names, period_s, steps, arm, loop, broadcaster, controller, camera)
    report(summary)
    if options.summary:
        with open(options.summary, "w") as file:
            json.dump(summary, file, indent=1)
    return 0


def report(summary):
    def ms(*keys):
        return "/".join("-" if summary[key] is None else f"{summary[key]:.2f}" for key in keys)

    log(f"{summary['joint_states_published']} joint states ({summary['joint_states_per_s'] or 0:.1f}/s at "
        f"{summary['rate_hz']:g} Hz), gap p50/p99/max "
        f"{ms('joint_state_gap_ms_p50', 'joint_state_gap_ms_p99', 'joint_state_gap_ms_max')} ms; commands taken "
        f"{summary['commands_taken']}, refused {summary['commands_refused']}, last {summary['last_command']}; "
        f"state→command p50/p99 {ms('state_to_command_ms_p50', 'state_to_command_ms_p99')} ms; "
        f"{summary['frames_published']} frames, render mean/max {ms('render_ms_mean', 'render_ms_max')} ms, "
        f"publish mean/max {ms('image_publish_ms_mean', 'image_publish_ms_max')} ms")


if __name__ == "__main__":
    sys.exit(main())
