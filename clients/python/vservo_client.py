#!/usr/bin/env python3
"""A Python client for a running vservo instance, over iceoryx2 shared memory (PyPI `iceoryx2` 0.10).

It speaks the layout of docs/PROTOCOL.md: it sends commands (targets, object motion, reload and resume) to the
daemon's `command` request-response service and reads the replies, asks for a safe stop on the instance's
safe-stop path (a FIFO no client can crowd out; the status confirms it), and it reads the `status` and
`camera_twist` topics.

    python3 vservo_client.py [--instance NAME] target x1,y1,x2,y2,x3,y3,x4,y4
    python3 vservo_client.py [--instance NAME] pose x,y,z [roll,pitch,yaw in degrees]
    python3 vservo_client.py [--instance NAME] teach | reload | safe-stop | resume | status | twist
    python3 vservo_client.py [--instance NAME] object hold | object step x,y,z | object circle RADIUS_M REV_PER_MIN

Exit code 0 when the daemon accepted the command (for safe-stop: when the status shows the cell in the safe
stop asked for), 3 when it refused it (the reason is printed; for safe-stop: the cell was already in a safe
stop), 1 when no daemon answered (or a safe stop could not be confirmed), 2 on bad arguments, 75 when every command slot was taken (nothing was sent: try again). Use it as a library too: `Client("default").set_target([...])`.
"""

import argparse
import ctypes
import errno
import math
import os
import stat
import sys
import time

import iceoryx2 as iox2

SCHEMA_VERSION = 14
(TARGET_FEATURES, TARGET_POSE, TARGET_TEACH, OBJECT_HOLD, OBJECT_STEP, OBJECT_CIRCLE, RELOAD, RESUME,
 SAFE_STOP, MOVE_JOINTS, SERVO, SPEED) = range(1, 13)
STATES = ["starting", "running", "degraded", "stopping", "safe-stop", "moving"]
MAX_JOINTS = 7
FAULTS = ["none", "position_limit", "velocity_limit", "torque_saturated", "driver_fault", "target_lost",
          "robot_stalled", "requested", "stream_taken", "camera_stalled", "start_held", "supervision_stalled",
          "collision"]


class Command(ctypes.Structure):
    """vservo::Command, 216 bytes."""

    _fields_ = [
        ("schema", ctypes.c_uint32),
        ("kind", ctypes.c_uint32),
        ("id", ctypes.c_uint64),
        ("features_px", ctypes.c_double * 8),
        ("translation_m", ctypes.c_double * 3),
        ("rotation_rpy_rad", ctypes.c_double * 3),
        ("radius_m", ctypes.c_double),
        ("rev_per_min", ctypes.c_double),
        ("joint_count", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("joints_rad", ctypes.c_double * MAX_JOINTS),
        ("speed_fraction", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "vservo::Command"


class CommandReply(ctypes.Structure):
    """vservo::CommandReply, 344 bytes."""

    _fields_ = [
        ("schema", ctypes.c_uint32),
        ("accepted", ctypes.c_uint32),
        ("id", ctypes.c_uint64),
        ("gains_version", ctypes.c_uint64),
        ("target_features_px", ctypes.c_double * 8),
        ("reason", ctypes.c_uint8 * 256),
    ]

    @staticmethod
    def type_name() -> str:
        return "vservo::CommandReply"

    def reason_text(self) -> str:
        raw = bytes(self.reason)
        return raw.split(b"\0", 1)[0].decode("utf-8", errors="replace")


class CameraTwist(ctypes.Structure):
    """vservo::CameraTwist, 120 bytes."""

    _fields_ = [
        ("schema", ctypes.c_uint32),
        ("verdict", ctypes.c_uint32),
        ("frame", ctypes.c_uint64),
        ("capture_tick", ctypes.c_uint64),
        ("gains_version", ctypes.c_uint64),
        ("stamp_ns", ctypes.c_uint64),
        ("twist", ctypes.c_double * 6),
        ("feature_error_px", ctypes.c_double),
        ("missing_mask", ctypes.c_uint32),
        ("law_flags", ctypes.c_uint32),
        ("writer_pid", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("seal", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return "vservo::CameraTwist"


class NodeStatus(ctypes.Structure):
    """vservo::NodeStatus, 32 bytes."""

    _fields_ = [
        ("restarts", ctypes.c_uint64),
        ("last_telemetry_ns", ctypes.c_uint64),
        ("state", ctypes.c_uint32),
        ("pid", ctypes.c_uint32),
        ("last_exit", ctypes.c_int32),
        ("healthy", ctypes.c_uint32),
    ]


class DaemonStatus(ctypes.Structure):
    """vservo::DaemonStatus, 296 bytes."""

    _fields_ = [
        ("schema", ctypes.c_uint32),
        ("state", ctypes.c_uint32),
        ("stamp_ns", ctypes.c_uint64),
        ("uptime_ns", ctypes.c_uint64),
        ("gains_version", ctypes.c_uint64),
        ("nodes", NodeStatus * 4),
        ("tick_rate_hz", ctypes.c_double),
        ("feature_error_px", ctypes.c_double),
        ("pid", ctypes.c_uint32),
        ("robot", ctypes.c_uint32),
        ("fault", ctypes.c_uint32),
        ("fault_joints", ctypes.c_uint32),
        ("fault_since_ns", ctypes.c_uint64),
        ("safe_stops", ctypes.c_uint64),
        ("driver_error", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("speed_scale", ctypes.c_double),
        ("clearance_m", ctypes.c_double),
        ("clearance_between", ctypes.c_char * 64),
    ]

    @staticmethod
    def type_name() -> str:
        return "vservo::DaemonStatus"


class NoAnswer(Exception):
    """No daemon answered in time."""


RUNTIME_DIR_ENV = "VSERVO_RUNTIME_DIR"
SYSTEM_RUNTIME_DIR = "/run/vservo"


class NotRunning(Exception):
    """No vservod of the instance has made its runtime directory (docs/PROTOCOL.md, "Where an instance lives")."""


class OtherUser(PermissionError):
    """The instance is another user's: run the client as that user."""


class SchemaMismatch(Exception):
    """The instance's daemon speaks another protocol schema than this module (its directory's `schema` file)."""


def _check_schema(instance: str, path: str) -> None:
    """The instance in `path` speaks this module's schema (a directory without a `schema` file, of a daemon from
    before it, is taken as it is), as `InstanceDir::locate` checks it."""
    try:
        with open(os.path.join(path, "schema")) as f:
            text = f.read().strip()
    except FileNotFoundError:
        return
    if text != str(SCHEMA_VERSION):
        raise SchemaMismatch(f"instance {instance!r} speaks protocol schema {text}, this program schema "
                             f"{SCHEMA_VERSION}: update the older side (docs/PROTOCOL.md, \"Changelog\", says what "
                             f"changed and how to migrate)")


def _user_name(uid: int) -> str:
    try:
        import pwd
        return pwd.getpwuid(uid).pw_name
    except (KeyError, ImportError):
        return f"uid {uid}"


def _candidate_paths(instance: str):
    """Where a client looks for `instance`, in order (as vservoctl, `InstanceDir::locate`)."""
    if os.environ.get(RUNTIME_DIR_ENV):
        return [os.path.join(os.environ[RUNTIME_DIR_ENV], instance)]
    bases = [SYSTEM_RUNTIME_DIR]
    if os.geteuid() != 0:
        xdg = os.environ.get("XDG_RUNTIME_DIR")
        bases.append(os.path.join(xdg, "vservo") if xdg else f"/tmp/vservo-{os.geteuid()}")
    return [os.path.join(base, instance) for base in bases]


def _sighting(path: str):
    """What is at `path` (`<base>/<instance>`): ("absent", None, path), ("ours", uid, path), ("other", owner uid,
    the instance's directory), or ("closed", the base's owner uid or None, a base this user may not search: the
    instance may be there, of a user unknown)."""
    try:
        info = os.lstat(path)
    except PermissionError:
        base = os.path.dirname(path)
        try:
            owner = os.stat(base).st_uid
        except OSError:
            owner = None
        return ("closed", owner, base)
    except OSError:
        return ("absent", None, path)
    if info.st_uid == os.geteuid():
        return ("ours", info.st_uid, path)
    return ("other", info.st_uid, path)


def decide_location(sightings):
    """Which sighting tells where the instance is: the first of this user's, wherever it is (the system's
    /run/vservo, root's and closed to this user, says nothing about this user's instance); else the first of
    another user's (the instance really is that user's); else the first base closed to this user (the instance
    may be there); else None."""
    for kind in ("ours", "other", "closed"):
        for sighting in sightings:
            if sighting[0] == kind:
                return sighting
    return None


def locate_instance(instance: str):
    """The base directory and shared-memory prefix of a vservo instance, found as vservoctl finds them:
    `$VSERVO_RUNTIME_DIR/<instance>` when that is set, else `/run/vservo/<instance>` and the user's own
    (`$XDG_RUNTIME_DIR/vservo/<instance>` or `/tmp/vservo-<uid>/<instance>`): an instance of this user wherever
    it is, another user's only when none is ours."""
    paths = _candidate_paths(instance)
    found = decide_location([_sighting(path) for path in paths])
    if found is None:
        raise NotRunning(f"no vservod of instance {instance!r} is running (looked in {', '.join(paths)})")
    kind, uid, path = found
    if kind == "closed":
        owner = "whose it is cannot be told" if uid is None else f"the directory is user \"{_user_name(uid)}\"'s"
        raise OtherUser(f"no vservod of instance {instance!r} of this user is running (looked in {', '.join(paths)}); "
                        f"{path} is closed to this user ({owner}) and may hold another user's: if the instance runs "
                        f"there, run the client as the user who started its daemon (for example "
                        f"`sudo -u <that user> python3 …`)")
    if kind == "other":
        owner = _user_name(uid)
        raise OtherUser(f"instance {instance!r} is run by user {owner!r} ({path} is that user's): "
                        f"run the client as that user (for example `sudo -u {owner} python3 …`)")
    try:
        with open(os.path.join(path, "prefix")) as f:
            prefix = f.read().strip()
    except FileNotFoundError:
        raise NotRunning(f"no vservod of instance {instance!r} is running (no {path}/prefix)") from None
    _check_schema(instance, path)
    random = prefix[len("vservo_"):-1]
    if not (prefix.startswith("vservo_") and prefix.endswith("_") and len(random) == 16
            and all(c in "0123456789abcdef" for c in random)):
        raise ValueError(f"{path}/prefix: {prefix!r} is not a prefix vservod writes")
    return os.path.dirname(path), prefix


def instance_config(instance: str):
    """The iceoryx2 configuration of a running instance: its root path and prefix (docs/PROTOCOL.md)."""
    base, prefix = locate_instance(instance)
    config = iox2.config.default()
    config.global_cfg.prefix = iox2.FileName.new(prefix)
    config.global_cfg.root_path = iox2.Path.new(os.path.join(base, "iceoryx2") + "/")
    return config


SAFE_STOP_FILE = "safe_stop"


def ask_for_safe_stop(instance: str) -> str:
    """Asks the instance's daemon for a safe stop on its safe-stop path (docs/PROTOCOL.md): one byte written
    without blocking to the FIFO `safe_stop` in the instance's directory. No command slot is needed. Returns
    the FIFO's path; raises NotRunning when no daemon reads it."""
    base, _ = locate_instance(instance)
    path = os.path.join(base, instance, SAFE_STOP_FILE)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError as error:
        if error.errno == errno.ENXIO:
            raise NotRunning(f"{path}: no vservod reads the safe-stop path: the instance is not running") from None
        if error.errno == errno.ENOENT:
            raise NotRunning(f"{path}: no safe-stop path: no vservod (of a version that makes it) runs "
                             f"instance {instance!r}") from None
        raise
    try:
        if not stat.S_ISFIFO(os.fstat(fd).st_mode):
            raise ValueError(f"{path}: not a FIFO: not the safe-stop path vservod makes")
        try:
            os.write(fd, b"!")
        except BlockingIOError:
            pass  # full of requests not yet taken: this one is among them
        except BrokenPipeError:
            raise NotRunning(f"{path}: no vservod reads the safe-stop path: the instance is not running") from None
    finally:
        os.close(fd)
    return path


class SafeStopped:
    """A safe stop the status confirmed: the fault the cell is held for, and whether it was held before."""

    def __init__(self, path: str, fault: str, held_before: bool, confirmed_after_s: float):
        self.path = path
        self.fault = fault
        self.held_before = held_before
        self.confirmed_after_s = confirmed_after_s


class Busy(Exception):
    """Every command slot of the instance was taken at that moment: nothing was sent; try again."""


class Client:
    """A connection to one vservo instance."""

    def __init__(self, instance: str = "default", timeout_s: float = 2.0):
        self.instance = instance
        self.timeout_s = timeout_s
        # every vservo instance lives in its own runtime directory, under its own prefix (docs/PROTOCOL.md)
        self.node = iox2.NodeBuilder.new().config(instance_config(instance)).create(iox2.ServiceType.Ipc)
        self._next_id = os.getpid() << 32

    def _service_name(self, service: str):
        return iox2.ServiceName.new(f"vservo/{self.instance}/{service}")

    def request(self, command: Command) -> CommandReply:
        """Sends one command and returns the daemon's reply.

        The command slot is held only while the answer is awaited: an idle client locks nobody out."""
        try:
            service = (
                self.node.service_builder(self._service_name("command"))
                .request_response(Command, CommandReply)
                .open()
            )
        except Exception as error:  # the service exists only while a daemon runs
            raise NoAnswer(f"no vservod of instance {self.instance!r} ({error})") from error
        try:
            commands = service.client_builder().create()
        except Exception as error:
            if "ExceedsMaxSupportedClients" in repr(error) or "ExceedsMaxSupportedClients" in str(error):
                raise Busy(f"instance {self.instance!r} is busy: every command slot is taken; "
                           "nothing was sent, try again") from error
            raise
        self._next_id += 1
        command.schema = SCHEMA_VERSION
        command.id = self._next_id
        try:
            pending = commands.send_copy(command)
            deadline = time.monotonic() + self.timeout_s
            while time.monotonic() < deadline:
                response = pending.receive()
                if response is not None:
                    reply = CommandReply.from_buffer_copy(response.payload().contents)
                    if reply.id == command.id:
                        return reply
                time.sleep(0.001)
        finally:
            # let go of the slot now, not when the garbage collector gets to it
            del commands
        raise NoAnswer(f"no answer from vservod of instance {self.instance!r} within {self.timeout_s} s")

    def set_target(self, features_px) -> CommandReply:
        """ξ_d = the eight features [x1, y1, …, x4, y4] (px)."""
        command = Command(kind=TARGET_FEATURES)
        for i, value in enumerate(features_px):
            command.features_px[i] = value
        return self.request(command)

    def set_target_pose(self, translation_m, rpy_rad=(0.0, 0.0, 0.0)) -> CommandReply:
        """The board at `translation_m` in the desired camera frame, turned by roll, pitch, yaw (rad)."""
        command = Command(kind=TARGET_POSE)
        for i in range(3):
            command.translation_m[i] = translation_m[i]
            command.rotation_rpy_rad[i] = rpy_rad[i]
        return self.request(command)

    def teach(self) -> CommandReply:
        return self.request(Command(kind=TARGET_TEACH))

    def reload(self) -> CommandReply:
        return self.request(Command(kind=RELOAD))

    def resume(self) -> CommandReply:
        """Servo again after a safe stop (refused, with each cause, while a fault's cause is still there)."""
        return self.request(Command(kind=RESUME))

    def safe_stop(self) -> SafeStopped:
        """Bring the arm to rest and hold it until `resume`: asked for on the safe-stop path (no command slot
        needed), confirmed from the status; NoAnswer when the status does not show it in time."""
        asked_at_ns = time.monotonic_ns()  # CLOCK_MONOTONIC, the daemon's clock for fault_since_ns
        path = ask_for_safe_stop(self.instance)
        deadline = time.monotonic() + self.timeout_s
        status = None
        while time.monotonic() < deadline:
            status = self.status()
            if status.state < len(STATES) and STATES[status.state] == "safe-stop":
                fault = FAULTS[status.fault] if status.fault < len(FAULTS) else str(status.fault)
                return SafeStopped(path, fault, status.fault_since_ns < asked_at_ns,
                                   time.monotonic() - (deadline - self.timeout_s))
            time.sleep(0.01)
        raise NoAnswer(f"a safe stop was asked for on {path}, but the status of instance {self.instance!r} "
                       f"did not show it within {self.timeout_s} s")

    def safe_stop_command(self) -> CommandReply:
        """A safe stop over the `command` service, acknowledged by the daemon; needs a free command slot (Busy
        otherwise): `safe_stop` needs none."""
        return self.request(Command(kind=SAFE_STOP))

    def object_hold(self) -> CommandReply:
        return self.request(Command(kind=OBJECT_HOLD))

    def object_step(self, translation_m) -> CommandReply:
        command = Command(kind=OBJECT_STEP)
        for i in range(3):
            command.translation_m[i] = translation_m[i]
        return self.request(command)

    def object_circle(self, radius_m: float, rev_per_min: float) -> CommandReply:
        return self.request(Command(kind=OBJECT_CIRCLE, radius_m=radius_m, rev_per_min=rev_per_min))

    def move_joints(self, joints_rad, speed_fraction: float, out_of_hold: bool = False) -> CommandReply:
        """Move the arm's joints to `joints_rad` (the arm's joint count of values) at up to `speed_fraction`
        (0–1] of their speed limits and hold them there instead of servoing, until `servo`; refused in a safe
        stop (but, with `out_of_hold`, a cell held by the user: start_held, requested), outside the joint limits
        or with values for joints the arm does not have."""
        if len(joints_rad) > MAX_JOINTS:
            raise ValueError(f"{len(joints_rad)} joint values; the protocol carries {MAX_JOINTS} at most")
        command = Command(kind=MOVE_JOINTS, speed_fraction=speed_fraction, joint_count=len(joints_rad),
                          flags=2 if out_of_hold else 0)
        for i, q in enumerate(joints_rad):
            command.joints_rad[i] = q
        return self.request(command)

    def servo(self) -> CommandReply:
        """End a joint move: servo again from where the arm is."""
        return self.request(Command(kind=SERVO))

    def speed(self, speed_scale: float, while_moving: bool = False) -> CommandReply:
        """Set the dynamics override (0–1]: the reference keeps that share of the joints' speed, acceleration and
        jerk limits and of the tool's caps. Lowering it is always taken; raising it only while the cell is held,
        or with `while_moving`."""
        return self.request(Command(kind=SPEED, speed_fraction=speed_scale, flags=1 if while_moving else 0))

    def _latest(self, service: str, payload):
        # open, never create: a client that created the daemon's services with other sizes would stop the
        # daemon from starting
        try:
            opened = self.node.service_builder(self._service_name(service)).publish_subscribe(payload).open()
        except Exception as error:  # the service exists only while a daemon runs
            raise NoAnswer(f"no vservod of instance {self.instance!r} ({error})") from error
        subscriber = opened.subscriber_builder().create()
        deadline = time.monotonic() + self.timeout_s
        latest = None
        while time.monotonic() < deadline and latest is None:
            while True:
                sample = subscriber.receive()
                if sample is None:
                    break
                latest = payload.from_buffer_copy(sample.payload().contents)
            time.sleep(0.005)
        if latest is None:
            raise NoAnswer(f"nothing on vservo/{self.instance}/{service} within {self.timeout_s} s")
        return latest

    def status(self) -> DaemonStatus:
        """The daemon's latest status."""
        return self._latest("status", DaemonStatus)

    def twist(self) -> CameraTwist:
        """The servo's latest camera twist."""
        return self._latest("camera_twist", CameraTwist)


def _numbers(text: str, count: int):
    values = [float(v) for v in text.split(",")]
    if len(values) != count:
        raise ValueError(f"expected {count} comma-separated numbers, got {len(values)}")
    return values


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--instance", default="default")
    parser.add_argument("command", choices=["target", "pose", "teach", "reload", "safe-stop", "resume", "status",
                                            "twist", "object"])
    parser.add_argument("args", nargs="*")
    options = parser.parse_args(argv)
    try:
        client = Client(options.instance)
        if options.command == "status":
            s = client.status()
            state = STATES[s.state] if s.state < len(STATES) else str(s.state)
            fault = FAULTS[s.fault] if s.fault < len(FAULTS) else str(s.fault)
            print(f"state {state} fault {fault} gains version {s.gains_version} ticks {s.tick_rate_hz:.1f}/s "
                  f"error {s.feature_error_px:.3f} px restarts {[n.restarts for n in s.nodes]}")
            return 0
        if options.command == "twist":
            t = client.twist()
            print(f"frame {t.frame} verdict {t.verdict} gains version {t.gains_version} twist {list(t.twist)}")
            return 0
        if options.command == "target":
            reply = client.set_target(_numbers(options.args[0], 8))
        elif options.command == "pose":
            rpy = [math.radians(v) for v in _numbers(options.args[1], 3)] if len(options.args) > 1 else [0, 0, 0]
            reply = client.set_target_pose(_numbers(options.args[0], 3), rpy)
        elif options.command == "teach":
            reply = client.teach()
        elif options.command == "reload":
            reply = client.reload()
        elif options.command == "safe-stop":
            stopped = client.safe_stop()
            if stopped.held_before:
                print(f"vservo_client: refused: the cell is already in a safe stop ({stopped.fault})",
                      file=sys.stderr)
                return 3
            print(f"safe stop: the cell is in a safe stop (fault {stopped.fault}), confirmed by the status "
                  f"{stopped.confirmed_after_s * 1e3:.0f} ms after the request on {stopped.path}")
            return 0
        elif options.command == "resume":
            reply = client.resume()
        elif options.args[:1] == ["hold"]:
            reply = client.object_hold()
        elif options.args[:1] == ["step"]:
            reply = client.object_step(_numbers(options.args[1], 3))
        elif options.args[:1] == ["circle"]:
            reply = client.object_circle(float(options.args[1]), float(options.args[2]))
        else:
            raise ValueError("object: hold | step x,y,z | circle RADIUS_M REV_PER_MIN")
    except (ValueError, IndexError) as error:
        print(f"vservo_client: {error}", file=sys.stderr)
        return 2
    except (NoAnswer, NotRunning, OtherUser, SchemaMismatch) as error:
        print(f"vservo_client: {error}", file=sys.stderr)
        return 1
    except Busy as error:
        print(f"vservo_client: {error}", file=sys.stderr)
        return 75
    if reply.accepted:
        target = ", ".join(f"{v:.2f}" for v in reply.target_features_px)
        print(f"accepted: {reply.reason_text()}\n  gains version {reply.gains_version}, target [{target}] px")
        return 0
    print(f"vservo_client: refused: {reply.reason_text()}", file=sys.stderr)
    return 3


if __name__ == "__main__":
    sys.exit(main())
