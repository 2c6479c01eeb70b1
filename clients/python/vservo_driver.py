"""The driver side of vservo's contract (docs/DRIVERS.md, docs/PROTOCOL.md schema 13), shared by the reference
drivers (mujoco_driver.py, pybullet_driver.py): the payloads a robot and camera driver exchange with vservo as
ctypes structures, their codes, deadlines on CLOCK_MONOTONIC, and the iceoryx2 node and services opened exactly
as vservo creates them. A driver of your own may import it too (with vservo_client.py beside it).
"""

import ctypes
import math
import sys
import time

import iceoryx2 as iox2

import vservo_client  # finds the instance as every vservo client does (clients/python/vservo_client.py)

SCHEMA = vservo_client.SCHEMA_VERSION  # one declaration (vservo_client.py), checked against the Rust one
MAX_JOINTS = 7  # joints joint_state and joint_command have room for; joint_count says how many are the arm's
TORQUE, VELOCITY, POSITION = 0, 1, 2  # command modes
FOLLOWING, HOLDING = 0, 1  # driver_status
COMMAND_TIMEOUT_NS = 20_000_000  # no valid command for this long: hold
MAX_COMMAND_AGE_TICKS = 2  # a command answers the last joint state published or one of the 2 before it
NONE = (1 << 64) - 1  # applied_command_tick with no command applied (holding)


class JointState(ctypes.Structure):
    """vservo::JointState, 232 bytes."""

    _fields_ = [("schema", ctypes.c_uint32), ("faults", ctypes.c_uint32), ("tick", ctypes.c_uint64),
                ("stamp_ns", ctypes.c_uint64), ("driver_epoch", ctypes.c_uint64), ("period_ns", ctypes.c_uint64),
                ("command_mode", ctypes.c_uint32), ("driver_status", ctypes.c_uint32),
                ("joint_count", ctypes.c_uint32), ("driver_error", ctypes.c_uint32),
                ("q_rad", ctypes.c_double * MAX_JOINTS), ("qd_rad_s", ctypes.c_double * MAX_JOINTS),
                ("torque_nm", ctypes.c_double * MAX_JOINTS), ("applied_command_tick", ctypes.c_uint64)]

    @staticmethod
    def type_name() -> str:
        return "vservo::JointState"


class JointCommand(ctypes.Structure):
    """vservo::JointCommand, 248 bytes (the seal is the rmrc's, for the simulated driver: an external one
    ignores it)."""

    _fields_ = [("schema", ctypes.c_uint32), ("mode", ctypes.c_uint32), ("joint_count", ctypes.c_uint32),
                ("guard", ctypes.c_uint32), ("answers_tick", ctypes.c_uint64),
                ("driver_epoch", ctypes.c_uint64), ("state_stamp_ns", ctypes.c_uint64), ("stamp_ns", ctypes.c_uint64),
                ("torque_nm", ctypes.c_double * MAX_JOINTS), ("q_ref_rad", ctypes.c_double * MAX_JOINTS),
                ("qd_ref_rad_s", ctypes.c_double * MAX_JOINTS), ("twist_capture_tick", ctypes.c_uint64),
                ("twist_applied_tick", ctypes.c_uint64), ("reference_since_tick", ctypes.c_uint64),
                ("seal", ctypes.c_uint64)]

    @staticmethod
    def type_name() -> str:
        return "vservo::JointCommand"


class CellMode(ctypes.Structure):
    """vservo::CellMode, 128 bytes: whether the cell servos, is held in a safe stop or moves its joints (vservod's,
    sealed with the run's key; a driver without the key cannot check the seal, but the stream's one writer slot is
    vservod's while it runs)."""

    _fields_ = [("schema", ctypes.c_uint32), ("mode", ctypes.c_uint32), ("sequence", ctypes.c_uint64),
                ("fault", ctypes.c_uint32), ("fault_joints", ctypes.c_uint32), ("speed_fraction", ctypes.c_double),
                ("speed_scale", ctypes.c_double), ("goal_rad", ctypes.c_double * MAX_JOINTS), ("writers", ctypes.c_uint32 * 4),
                ("stamp_ns", ctypes.c_uint64), ("seal", ctypes.c_uint64)]

    @staticmethod
    def type_name() -> str:
        return "vservo::CellMode"


class CameraImageHeader(ctypes.Structure):
    """vservo::CameraImageHeader, 56 bytes: the user header of `camera_image`, whose payload is the pixels (u8)."""

    _fields_ = [("schema", ctypes.c_uint32), ("format", ctypes.c_uint32), ("width", ctypes.c_uint32),
                ("height", ctypes.c_uint32), ("stride_bytes", ctypes.c_uint32), ("reserved", ctypes.c_uint32),
                ("frame", ctypes.c_uint64), ("capture_stamp_ns", ctypes.c_uint64),
                ("exposure_us", ctypes.c_double), ("gain_db", ctypes.c_double)]

    @staticmethod
    def type_name() -> str:
        return "vservo::CameraImageHeader"


# --- taking a command: the rule of the Rust driver side (crates/vservo-driver, `DriverSide::take_command`),
# tied to it by tests/tests/python_layout.rs, which hands both the same commands ---
def refusal(command, *, epoch, mode, joint_count, last_tick):
    """Why the driver refuses `command` (a JointCommand), as crates/vservo-driver's `CommandRefused::kind` names
    it, or None when it takes it: of this schema, this run of the driver (`epoch`), the declared `mode` and
    `joint_count`, answering the last joint state published (`last_tick`; None before the first) or one of the
    MAX_COMMAND_AGE_TICKS before it — after the driver's own silence too: a command is as old as its tick says —,
    and finite in the values of its mode."""
    if command.schema != SCHEMA:
        return "schema"
    if command.driver_epoch != epoch:
        return "epoch"
    if command.mode != mode:
        return "mode"
    if command.joint_count != joint_count:
        return "joint count"
    if last_tick is None or command.answers_tick > last_tick:
        return "not published"
    if command.answers_tick + MAX_COMMAND_AGE_TICKS < last_tick:
        return "too old"
    if not all(math.isfinite(v) for v in command_values(command, mode, joint_count)):
        return "not finite"
    return None


SERVOING, SAFE_STOP, MOVING = 0, 1, 2  # cell modes
REST_RAD_S = 1e-9  # speeds this small count as rest, of either sign


def speed_gained_braking(acceleration, jerk):
    """The speed a joint still gains while a jerk-limited ramp to rest takes its acceleration (rad/s²) to zero at
    `jerk` (rad/s³): a²/2j (zero without a jerk limit)."""
    gained = acceleration * acceleration / (2.0 * jerk) if jerk else math.inf
    return gained if math.isfinite(gained) else 0.0


class HeldCell:
    """While the cell is held (its `cell_mode` a safe stop), a velocity command is taken only if it brings the arm
    to rest: each joint no faster than the speed in force when the hold began plus what a ramp to rest still gains
    (`speed_gained_braking` of its limits), never turned around, and never faster again than a later command plus
    that gain. The rule of the Rust driver side (crates/vservo-driver's `held`), tied to it by
    tests/tests/python_layout.rs. Call `cell_mode` with each `cell_mode` read, `refusal` before taking a command
    and `took` after."""

    def __init__(self, gain_rad_s):
        self.gain = list(gain_rad_s)
        self.in_force = None
        self.sequence = None
        self.envelope = None  # (fastest, direction) per joint while held

    def cell_mode(self, mode, sequence):
        if mode not in (SERVOING, SAFE_STOP, MOVING) or (self.sequence is not None and sequence <= self.sequence):
            return
        self.sequence = sequence
        if mode != SAFE_STOP:
            self.envelope = None
        elif self.envelope is None:
            speed = self.in_force or [0.0] * len(self.gain)
            self.envelope = ([abs(v) + g for v, g in zip(speed, self.gain)],
                             [0.0 if abs(v) <= REST_RAD_S else math.copysign(1.0, v) for v in speed])

    def refusal(self, speeds):
        """"not towards rest" (crates/vservo-driver's `CommandRefused::kind`) or None."""
        if self.envelope is None:
            return None
        fastest, direction = self.envelope
        for v, most, way in zip(speeds, fastest, direction):
            if abs(v) > most or (way * v < 0.0 and abs(v) > REST_RAD_S):
                return "not towards rest"
        return None

    def took(self, speeds):
        self.in_force = list(speeds)
        if self.envelope is not None:
            fastest, _ = self.envelope
            fastest[:] = [min(most, abs(v) + g) for most, v, g in zip(fastest, speeds, self.gain)]


def held_cell(scene, joint_count):
    """The `HeldCell` of the scene's arm (`vservoctl scene`): its acceleration and jerk limits."""
    arm = scene["arm"]
    jerks = arm.get("jerk_limits_rad_s3") or [None] * joint_count
    return HeldCell([speed_gained_braking(a, j if j is not None else math.inf)
                     for a, j in zip(arm["acceleration_limits_rad_s2"][:joint_count], jerks[:joint_count])])


def cell_modes(node, instance):
    """A reader of the instance's `cell_mode` (vservod's; its newest is kept for a new reader)."""
    service = (node.service_builder(iox2.ServiceName.new(f"vservo/{instance}/cell_mode"))
               .publish_subscribe(CellMode).open())
    return service.subscriber_builder().create()


def follow_cell_mode(reader, held):
    """Hands `held` each cell mode that arrived."""
    while (sample := reader.receive()) is not None:
        mode = CellMode.from_buffer_copy(sample.payload().contents)
        if mode.schema == SCHEMA:
            held.cell_mode(mode.mode, mode.sequence)


def command_values(command, mode, joint_count):
    """The values of the command's mode, for the arm's joints: q̇ (velocity), q_ref (position) or τ (torque)."""
    values = {VELOCITY: command.qd_ref_rad_s, POSITION: command.q_ref_rad, TORQUE: command.torque_nm}[mode]
    return list(values)[:joint_count]


# --- clock: absolute deadlines on CLOCK_MONOTONIC (time.sleep would drift by its own overhead every period) ---
_libc = ctypes.CDLL(None, use_errno=True)
_libc.prctl(29, 1, 0, 0, 0)  # PR_SET_TIMERSLACK = 1 ns (the default 50 µs would show up as lateness)


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


MOST_PERIODS_CAUGHT_UP = 100  # a wake-up later than this many periods advances the physics by this many


def periods_passed(start_ns: int, tick: int, period_ns: int, now_ns: int) -> int:
    """The driver periods from tick `tick` (counted from `start_ns`) to `now_ns`, at least one: a driver that woke
    late advances its physics by them (at most MOST_PERIODS_CAUGHT_UP at a time)."""
    return max(1, (now_ns - start_ns) // period_ns - tick)


def spread_ms(values_ns) -> str:
    """p50/p99/max of `values_ns` in milliseconds, as the drivers print their joint-state gaps at the end."""
    import numpy as np

    values_ms = np.array(values_ns) / 1e6
    return f"{np.median(values_ms):.2f}/{np.percentile(values_ms, 99):.2f}/{values_ms.max():.2f}"


def sleep_until(deadline_ns: int) -> None:
    """clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME): ctypes releases the GIL while it sleeps."""
    _libc.clock_nanosleep(1, 1, ctypes.byref(_Timespec(deadline_ns // 10**9, deadline_ns % 10**9)), None)


# --- iceoryx2: services exactly as vservo creates them (docs/PROTOCOL.md) ---
def make_node(instance: str, program: str, stop=lambda: False):
    """A node in the instance's iceoryx2 root and prefix (vservod makes them: wait for it, saying so once as
    `program`); None if `stop()` says so while waiting."""
    waited = False
    while not stop():
        try:
            config = vservo_client.instance_config(instance)
            break
        except vservo_client.NotRunning as why:
            if not waited:
                print(f"{program}: {why}; waiting for it", file=sys.stderr)
                waited = True
            time.sleep(0.2)
        except vservo_client.SchemaMismatch as why:
            # one line, nothing opened: the driver cannot talk to this daemon
            sys.exit(f"{program}: {why}")
    else:
        return None
    node = (iox2.NodeBuilder.new().config(config)
            .signal_handling_mode(iox2.SignalHandlingMode.Disabled)  # SIGINT/SIGTERM are the driver's
            .create(iox2.ServiceType.Ipc))
    # each stream has one publisher slot: a driver that died (killed, crashed) still holds it until someone
    # cleans up its leftovers; do it before taking the slot (docs/DRIVERS.md)
    node.try_cleanup_dead_nodes()
    return node


def open_topic(node, instance, name, payload, history, buffer, header=None):
    builder = node.service_builder(iox2.ServiceName.new(f"vservo/{instance}/{name}")).publish_subscribe(payload)
    if header is not None:
        builder = builder.user_header(header)
    # one publisher per stream: vservod creates the service so; the slot is the driver's
    return (builder.max_publishers(1).max_subscribers(8).history_size(history).subscriber_max_buffer_size(buffer)
            .enable_safe_overflow(True).open_or_create())


def open_notifier(node, instance, name):
    service = (node.service_builder(iox2.ServiceName.new(f"vservo/{instance}/{name}")).event()
               .max_notifiers(1).max_listeners(4).open_or_create())
    return service.notifier_builder().create()


MAX_IMAGE_BYTES = 1280 * 1024  # the largest camera_image sample (vservo_protocol::MAX_IMAGE_BYTES)


def camera_image_publisher(node, instance, width, height):
    """The `camera_image` stream's publisher and its event: a function that publishes an 8-bit gray image of
    `width` × `height` as frame `frame`, exposed at `stamp_ns` (as vservo_protocol::publish_mono8 does)."""
    import numpy as np

    service = open_topic(node, instance, "camera_image", iox2.Slice[ctypes.c_uint8], 0, 2, CameraImageHeader)
    publisher = service.publisher_builder().initial_max_slice_len(MAX_IMAGE_BYTES).create()
    notifier = open_notifier(node, instance, "camera_image")

    def publish(image, frame, stamp_ns):
        sample = publisher.loan_slice_uninit(width * height)
        header = sample.user_header().contents
        header.schema, header.format, header.width, header.height = SCHEMA, 0, width, height
        header.stride_bytes, header.reserved, header.frame, header.capture_stamp_ns = width, 0, frame, stamp_ns
        header.exposure_us, header.gain_db = math.nan, math.nan  # a simulator's camera reports neither
        np.frombuffer(sample.payload().as_memory_view(), dtype=np.uint8)[:] = image.ravel()
        sample.assume_init().send()
        notifier.notify()

    return publish
