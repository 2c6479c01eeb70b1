#!/usr/bin/env python3
"""A URDF arm and hand camera in PyBullet for vservo: the second reference robot + camera driver.

The same contract as clients/python/mujoco_driver.py (docs/DRIVERS.md; docs/PROTOCOL.md, schema 13, over
iceoryx2 0.10 shared memory), for any arm vservo models from a URDF (the scene's `arm`: `urdf`, `base_link`,
`tip_link`, `joint_names`): nothing in this file is specific to an arm.

- every robot period it publishes `joint_state` and notifies the `joint_state` event;
- it reads the newest `joint_command` at each deadline and follows it if `vservo_driver.refusal` takes it (the
  Rust driver side's rule: this driver run, answering the last joint state or one of the MAX_COMMAND_AGE_TICKS
  before it, finite): JOINT VELOCITY (`mode` 1, `qd_ref_rad_s`) with the scene's robot.command
  "velocity", JOINT POSITION (`mode` 2, `q_ref_rad`) with "position"; with no valid command for 20 ms it brings
  the joints to rest (their reference stops where it is) and reports `driver_status` 1 (holding);
- every vision period it renders the hand camera and publishes it on `camera_image` as 8-bit grayscale,
  stamped with the time of the joint state it shows, and notifies the `camera_image` event.

PyBullet's interfaces used. The arm: `loadURDF(useFixedBase=True)` (inertias computed by PyBullet: the xArm6's
file inertias fail its check) in a DIRECT client, gravity on, `setTimeStep(robot.period_s)` and one
`stepSimulation` per period (a late wake-up steps the periods that passed). Both command modes drive Bullet's
joint motors in POSITION_CONTROL on a reference (`Arm`): in velocity mode the commanded q̇ integrated (as a
real arm's drives servo velocity, without drift; with --velocity-lag-s through a first-order lag, as a UR's
speedj follows), in position mode q_ref; forces = the URDF's effort limits.
Measured: q, q̇ and the applied motor torque from `getJointStates`.
The camera: PyBullet's software TinyRenderer (`getCameraImage(renderer=ER_TINY_RENDERER)`, no GUI, no OpenGL)
with the view and projection matrices made from the scene's pinhole (fx, fy, principal point; TinyRenderer
samples pixel centres half a pixel off OpenGL's convention, corrected in the projection) and flat colours
(ambient light only): board 230, marks 20, background 255 (TinyRenderer's). The camera sees the board only,
not the arm: TinyRenderer does not clip triangles at the near plane, and a camera at the flange, inside the
tool link's mesh, takes it minutes a frame. PyBullet holds the GIL while it renders (50–70 ms at
640 × 480 with the board filling the view), so the camera is a process of its own (multiprocessing, spawned; its own DIRECT client with the
same URDF and board), named `pybullet-camera`: it reads the newest joint state the arm loop shares with it,
renders and publishes on `camera_image` itself. It dies with the driver (PR_SET_PDEATHSIG).

    pybullet_driver.py --scene scene.json --urdf FILE [--instance NAME] [--duration-s S] [--save-image first.pgm]
                       [--fifo-priority N] [--velocity-lag-s S] [--collision-log FILE]

The scene comes from `vservoctl scene --config FILE`; --urdf is the URDF to simulate (meshes found through
pybullet_data's path and the file's directory). The scene's obstacles (`[[scene.obstacles]]`) stand in the arm's
physics and the camera's box rides on the tool (`pybullet_obstacles.py`); --collision-log writes PyBullet's own
contacts and closest points to them every 10 ms. SIGINT/SIGTERM stop it (exit code 0).
"""

import argparse
import ctypes
import json
import math
import multiprocessing
import os
import signal
import sys
import time

import numpy as np
import pybullet
import pybullet_data


from vservo_driver import (COMMAND_TIMEOUT_NS, FOLLOWING, HOLDING, MAX_COMMAND_AGE_TICKS, NONE, POSITION,  # noqa: F401
                           SCHEMA, VELOCITY, JointCommand, JointState, cell_modes, command_values, follow_cell_mode,
                           held_cell, make_node,
                           open_notifier, open_topic, periods_passed, camera_image_publisher, refusal, sleep_until,
                           spread_ms, MOST_PERIODS_CAUGHT_UP)
from vservo_driver import MAX_JOINTS as PROTOCOL_JOINTS
from pybullet_obstacles import Obstacles
DEFAULT_EFFORT = 1000.0  # N·m (N) for a joint whose URDF gives no effort limit
BOARD_GRAY, MARK_GRAY = 230, 20  # as vservo's simulated camera and the MuJoCo driver draw them
NEAR_M, FAR_M = 0.01, 10.0
CAMERA_PROCESS_NAME = b"pybullet-camera"  # the camera process's name (comm, 15 bytes at most)


_libc = ctypes.CDLL(None, use_errno=True)  # prctl, for the camera process


def monotonic_ns() -> int:
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


_stopping = [False]  # set by SIGINT/SIGTERM (a plain flag: a handler must take no lock the loop may hold)


def on_stop_signal(*_):
    _stopping[0] = True


def fail(message: str):
    raise SystemExit(f"pybullet_driver: {message}")


# --- poses ---
def pose_matrix(position, quaternion):
    """4×4 from PyBullet's position and quaternion (x, y, z, w)."""
    t = np.eye(4)
    t[:3, :3] = np.reshape(pybullet.getMatrixFromQuaternion(quaternion), (3, 3))
    t[:3, 3] = position
    return t


def position_quaternion(t):
    """PyBullet's position and quaternion (x, y, z, w) of a 4×4 pose (Shepperd's method: exact at 180° too)."""
    r = t[:3, :3]
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2 * math.sqrt(1 + trace)
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * math.sqrt(max(0.0, 1 + r[i, i] - r[j, j] - r[k, k]))
        q = [0.0] * 4
        q[i], q[j], q[k], q[3] = s / 4, (r[j, i] + r[i, j]) / s, (r[k, i] + r[i, k]) / s, (r[k, j] - r[j, k]) / s
    return list(t[:3, 3]), q


# --- the cell in a PyBullet client ---
class Cell:
    """The arm (the URDF, fixed base) in a DIRECT client of its own.

    The scene's base frame is `arm.base_link`'s frame: the URDF root, or a link fixed to it (its pose at load);
    the board stands at world_from_base · base_from_board (board_world). `joints` are the PyBullet indices of the
    scene's `joint_names` (the moving joints from base_link to tip_link, in order), `tip` the tip link's index.
    """

    def __init__(self, scene, urdf):
        self.client = pybullet.connect(pybullet.DIRECT)
        c = self.client
        pybullet.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        self.body = pybullet.loadURDF(os.path.abspath(urdf), useFixedBase=True, physicsClientId=c)
        arm = scene["arm"]
        names = list(arm["joint_names"])
        if len(names) > PROTOCOL_JOINTS:
            fail(f"the arm has {len(names)} joints; the protocol (schema {SCHEMA}) carries {PROTOCOL_JOINTS}")
        if len(scene["start_joints_rad"]) != len(names):
            fail(f"scene: {len(scene['start_joints_rad'])} start_joints_rad for {len(names)} joint_names")
        info = [pybullet.getJointInfo(self.body, j, physicsClientId=c) for j in
                range(pybullet.getNumJoints(self.body, physicsClientId=c))]
        root = pybullet.getBodyInfo(self.body, physicsClientId=c)[0].decode()
        link = {i[12].decode(): i[0] for i in info}  # link name → index (the child link of joint index)
        link[root] = -1

        def index_of(key):
            if arm[key] not in link:
                fail(f"{urdf}: no link {arm[key]!r} (scene arm.{key}); its links: {', '.join(link)}")
            return link[arm[key]]

        self.tip, base = index_of("tip_link"), index_of("base_link")
        chain = []  # joint indices from the root to the tip
        j = self.tip
        while j != -1:
            chain.insert(0, j)
            j = info[j][16]
        if base != -1 and base not in chain:
            fail(f"{urdf}: tip link {arm['tip_link']!r} is not below base link {arm['base_link']!r}")
        to_base = chain[:chain.index(base) + 1] if base != -1 else []
        moving_to_base = [info[j][1].decode() for j in to_base if info[j][2] != pybullet.JOINT_FIXED]
        if moving_to_base:
            fail(f"{urdf}: base link {arm['base_link']!r} moves with joints {moving_to_base}: it must be the "
                 f"root {root!r} or fixed to it")
        moving = [j for j in chain[len(to_base):] if info[j][2] != pybullet.JOINT_FIXED]
        found = [info[j][1].decode() for j in moving]
        if found != names:
            missing = [n for n in names if n not in found]
            fail(f"{urdf}: the moving joints from {arm['base_link']!r} to {arm['tip_link']!r} are {found}; the "
                 f"scene's joint_names are {names}" + (f" ({missing} not on that chain)" if missing else ""))
        for j in moving:
            if info[j][2] not in (pybullet.JOINT_REVOLUTE, pybullet.JOINT_PRISMATIC):
                fail(f"{urdf}: joint {info[j][1].decode()!r} is neither revolute nor prismatic")
        self.joints = moving
        self.n = len(moving)
        urdf_limits = np.array([[info[j][8], info[j][9]] if info[j][8] < info[j][9] else [-math.inf, math.inf]
                                for j in moving])
        self.limits = np.array(arm.get("joint_limits_rad", urdf_limits), dtype=float).reshape(self.n, 2)
        urdf_speeds = [info[j][11] if info[j][11] > 0 else math.inf for j in moving]
        self.velocity_limits = np.array(arm.get("velocity_limits_rad_s", urdf_speeds), dtype=float)
        self.effort_from_urdf = np.array([info[j][10] > 0 for j in moving])
        self.efforts = np.array([info[j][10] if info[j][10] > 0 else DEFAULT_EFFORT for j in moving])
        # the other moving joints (fingers, …) are held where they are
        self.others = [i[0] for i in info if i[2] != pybullet.JOINT_FIXED and i[0] not in moving]
        self.set_joints(scene["start_joints_rad"])
        if base == -1:  # PyBullet's base pose is the root's inertial frame: the link frame is that · inertial⁻¹
            dynamics = pybullet.getDynamicsInfo(self.body, -1, physicsClientId=c)
            world_from_inertial = pose_matrix(*pybullet.getBasePositionAndOrientation(self.body, physicsClientId=c))
            self.world_from_base = world_from_inertial @ np.linalg.inv(pose_matrix(dynamics[3], dynamics[4]))
        else:
            state = pybullet.getLinkState(self.body, base, computeForwardKinematics=True, physicsClientId=c)
            self.world_from_base = pose_matrix(state[4], state[5])

    def set_joints(self, q):
        for j, value in zip(self.joints, q):
            pybullet.resetJointState(self.body, j, value, 0.0, physicsClientId=self.client)

    def world_from_tip(self):
        """The tip link's URDF frame (not its inertial frame)."""
        state = pybullet.getLinkState(self.body, self.tip, computeForwardKinematics=True, physicsClientId=self.client)
        return pose_matrix(state[4], state[5])


def board_world(scene, world_from_base):
    """A DIRECT client with the board alone: its white face is its plane z = 0, the box behind it (+z), the marks
    0.1 mm in front (−z), as the MuJoCo driver builds it (the camera looks at the board along the board's +z).
    Returns the client and the board's bodies (its face and marks, each at the board's pose), which a fixed
    camera's renderer moves with the tool."""
    board, c = scene["board"], pybullet.connect(pybullet.DIRECT)
    bodies = []
    (xlo, ylo), (xhi, yhi) = board["extent_m"]
    thickness, film = 0.005, 0.0001
    world_from_board = world_from_base @ np.array(scene["base_from_board"])
    position, orientation = position_quaternion(world_from_board)
    face = pybullet.createVisualShape(pybullet.GEOM_BOX,
                                      halfExtents=[(xhi - xlo) / 2, (yhi - ylo) / 2, thickness / 2],
                                      visualFramePosition=[(xhi + xlo) / 2, (yhi + ylo) / 2, thickness / 2],
                                      rgbaColor=gray(BOARD_GRAY), physicsClientId=c)
    bodies.append(pybullet.createMultiBody(0, -1, face, position, orientation, physicsClientId=c))
    tags = board.get("target_tags") or ([board["apriltag"]] if board.get("apriltag") else [])
    marks = []  # (centres, shape): the tags' black cells as thin black boxes (the white ones are the board)
    for tag in tags:
        cell = tag["size_m"] / 8
        cx, cy = tag["centre_in_board_m"]
        centres = [(cx + (column - 3.5) * cell, cy + (row - 3.5) * cell)
                   for row, cells in enumerate(tag["black_cells"]) for column, black in enumerate(cells) if black]
        marks.append((centres, dict(shapeType=pybullet.GEOM_BOX, halfExtents=[cell / 2, cell / 2, film / 2])))
    if not tags:
        marks.append(([tuple(m) for m in board["marks_in_board_m"]],
                      dict(shapeType=pybullet.GEOM_CYLINDER, radius=board["mark_diameter_m"] / 2, length=film)))
    for centres, shape in marks:
        for x, y in centres:
            mark = pybullet.createVisualShape(visualFramePosition=[x, y, -film / 2], rgbaColor=gray(MARK_GRAY),
                                              physicsClientId=c, **shape)
            bodies.append(pybullet.createMultiBody(0, -1, mark, position, orientation, physicsClientId=c))
    return c, bodies


def gray(level):
    return [level / 255.0] * 3 + [1.0]


def check_camera(scene):
    cam = scene["camera"]
    if any(float(k) != 0.0 for k in cam.get("distortion", [])):
        fail(f"the scene's camera has lens distortion {cam['distortion']}: this driver renders a pinhole only")
    return cam


class Renderer:
    """The camera: on the hand, world_from_camera = world_from_tip · tool_from_camera; fixed in the world
    (scene camera_mount "world"), world_from_base · base_from_camera, the board moved with the tool to
    world_from_tip · tool_from_board before each image. Camera x right, y down, z along the optical axis
    (docs/ARCHITECTURE.md), pixel (u, v) covering [u, u+1) × [v, v+1)."""

    def __init__(self, scene, urdf):
        cam = check_camera(scene)
        self.cell = Cell(scene, urdf)  # for the camera's pose, or the board's
        self.client, self.board_bodies = board_world(scene, self.cell.world_from_base)  # what it sees
        self.fixed = scene.get("camera_mount", "hand") == "world"
        if self.fixed:
            self.world_from_fixed_camera = self.cell.world_from_base @ np.array(scene["base_from_camera"], dtype=float)
            self.tool_from_board = np.array(scene["tool_from_board"], dtype=float)
        else:
            self.tool_from_camera = np.array(scene["tool_from_camera"], dtype=float)
        self.width, self.height = cam["width_px"], cam["height_px"]
        fx, fy = cam.get("fx_px", cam.get("focal_px")), cam.get("fy_px", cam.get("focal_px"))
        cx, cy = cam["principal_point_px"]
        # TinyRenderer covers pixel i at i + ½ of OpenGL's window coordinates, rows flipped (measured:
        # scripts/pybullet-render-check.py): shift the principal point by half a pixel to match
        cx, cy = cx - 0.5, cy + 0.5
        w, h, n, f = self.width, self.height, NEAR_M, FAR_M
        # OpenGL's eye frame is the camera's turned about x by 180° (y up, looking along −z); clip = P · eye
        projection = np.array([[2 * fx / w, 0, 1 - 2 * cx / w, 0],
                               [0, 2 * fy / h, 2 * cy / h - 1, 0],
                               [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)],
                               [0, 0, -1, 0]])
        self.projection = projection.T.flatten().tolist()  # column-major, as OpenGL and PyBullet take it

    def world_from_camera(self, q):
        """Where the camera is with the arm at q; a fixed camera's board is moved to the tool there."""
        self.cell.set_joints(q)
        if not self.fixed:
            return self.cell.world_from_tip() @ self.tool_from_camera
        position, orientation = position_quaternion(self.cell.world_from_tip() @ self.tool_from_board)
        for body in self.board_bodies:
            pybullet.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=self.client)
        return self.world_from_fixed_camera

    def image(self, q):
        """The image (height × width, u8) the camera sees with the arm at q."""
        eye_from_world = np.diag([1.0, -1.0, -1.0, 1.0]) @ np.linalg.inv(self.world_from_camera(q))
        _, _, rgba, _, _ = pybullet.getCameraImage(
            self.width, self.height, eye_from_world.T.flatten().tolist(), self.projection,
            renderer=pybullet.ER_TINY_RENDERER, shadow=0, lightAmbientCoeff=1.0, lightDiffuseCoeff=0.0,
            lightSpecularCoeff=0.0, flags=pybullet.ER_NO_SEGMENTATION_MASK, physicsClientId=self.client)
        rgb = np.reshape(np.asarray(rgba, dtype=np.uint8), (self.height, self.width, 4))[:, :, :3].astype(np.uint16)
        return ((rgb[:, :, 0] * 77 + rgb[:, :, 1] * 150 + rgb[:, :, 2] * 29 + 128) >> 8).astype(np.uint8)


def write_pgm(path, image):
    with open(path, "wb") as pgm:
        pgm.write(b"P5\n%d %d\n255\n" % (image.shape[1], image.shape[0]) + image.tobytes())


def camera_process(scene, urdf, instance, shared, stop, ready, save_image):
    """The camera, a process of its own: every vision period it renders the newest joint state the arm loop
    shared and publishes the frame on `camera_image`, stamped with that state's time."""
    _libc.prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG: dies with the driver, even a SIGKILLed one
    _libc.prctl(15, CAMERA_PROCESS_NAME)  # PR_SET_NAME: what ps, and vservod's "written by", show
    if os.getppid() == 1:
        return
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, on_stop_signal)
    stopped = lambda: _stopping[0] or stop.is_set()  # noqa: E731
    q_shared, stamp_shared, lock = shared
    renderer = Renderer(scene, urdf)
    width, height = renderer.width, renderer.height
    renderer.image(scene["start_joints_rad"])  # the first render sets TinyRenderer up
    node = make_node(instance, "pybullet_driver", stopped)
    if node is None:
        return
    publish = camera_image_publisher(node, instance, width, height)
    ready.set()
    period_ns = round(scene["timing"]["vision_period_s"] * 1e9)
    deadline, frame, render_ms = monotonic_ns(), 0, []
    while not stopped():
        with lock:
            q, stamp_ns = list(q_shared), stamp_shared.value
        if stamp_ns == 0:  # no joint state published yet
            time.sleep(0.001)
            continue
        started = time.perf_counter()
        image = renderer.image(q)
        render_ms.append(1e3 * (time.perf_counter() - started))
        publish(image, frame, stamp_ns)
        if frame == 0 and save_image:
            write_pgm(save_image, image)
        frame += 1
        deadline = max(deadline + period_ns, monotonic_ns() - period_ns // 2)  # a late frame is not made up for
        sleep_until(deadline)
    if render_ms:
        r = np.array(render_ms)
        print(f"pybullet_driver: camera: {frame} frames, render mean/p99/max {r.mean():.1f}/"
              f"{np.percentile(r, 99):.1f}/{r.max():.1f} ms", file=sys.stderr)


class Arm:
    """The arm in PyBullet's physics under joint velocity or position commands.

    Each joint follows a position reference q_ref: in velocity mode the commanded q̇ (clipped to the velocity
    limits; through the first-order lag `velocity_lag_s` when one is given) integrated, as a real arm's drives servo a velocity command without drift; in position mode the
    commanded q_ref; holding, q_ref stays where it is. Both through `setJointMotorControl2(POSITION_CONTROL,
    targetPosition=q_ref (clipped to the joint limits), targetVelocity=0, positionGain=1, velocityGain=1,
    force=the URDF's effort limit, maxVelocity=the velocity limit)`: Bullet's joint motor is a constraint asking
    for the velocity (q_ref − q) / period, so each joint lands on its reference at the end of the step if its
    effort and velocity limits allow.
    Measured on the xArm6 with gravity, a 0.2 s ramp to 0.1–0.2 rad/s: q on the reference to 1e-5 rad after
    2 s (VELOCITY_CONTROL on q̇ alone drifted 1.7 mrad in that time, q̇ off by up to 1 %).
    """

    def __init__(self, scene, urdf, velocity_lag_s=0.0):
        self.cell = Cell(scene, urdf)
        # a velocity-commanded arm's drives: the reference's speed follows the command through a first-order
        # lag of this time constant (0: at once)
        self.velocity_decay = math.exp(-scene["robot"]["period_s"] / velocity_lag_s) if velocity_lag_s > 0 else 0.0
        self.p = dict(physicsClientId=self.cell.client)
        pybullet.setGravity(0, 0, -9.81, **self.p)
        self.period_s = scene["robot"]["period_s"]
        pybullet.setTimeStep(self.period_s, **self.p)
        c = self.cell
        if c.others:
            held = [s[0] for s in pybullet.getJointStates(c.body, c.others, **self.p)]
            pybullet.setJointMotorControlArray(c.body, c.others, pybullet.POSITION_CONTROL, targetPositions=held,
                                               forces=[DEFAULT_EFFORT] * len(c.others), **self.p)
        self.measure()
        self.q_ref = self.q.copy()
        self.qd_ref = np.zeros(self.cell.n)

    def measure(self):
        states = pybullet.getJointStates(self.cell.body, self.cell.joints, **self.p)
        self.q = np.array([s[0] for s in states])
        self.qd = np.array([s[1] for s in states])
        self.torque = np.array([s[3] for s in states])

    def step(self, mode, command):
        """One period: the reference moves by the command (velocity: q̇; position: q_ref; None: holding) and the
        physics steps."""
        c = self.cell
        if mode == VELOCITY:
            commanded = np.zeros(c.n) if command is None else np.clip(command, -c.velocity_limits, c.velocity_limits)
            self.qd_ref = self.velocity_decay * self.qd_ref + (1.0 - self.velocity_decay) * commanded
            self.q_ref = self.q_ref + self.qd_ref * self.period_s
        elif mode == POSITION and command is not None:
            self.q_ref = np.asarray(command, dtype=float)
        self.q_ref = np.clip(self.q_ref, c.limits[:, 0], c.limits[:, 1])
        for joint, target, force, speed in zip(c.joints, self.q_ref, c.efforts, c.velocity_limits):
            limit = {"maxVelocity": speed} if math.isfinite(speed) else {}
            pybullet.setJointMotorControl2(c.body, joint, pybullet.POSITION_CONTROL, targetPosition=target,
                                           targetVelocity=0.0, positionGain=1.0, velocityGain=1.0, force=force,
                                           **limit, **self.p)
        pybullet.stepSimulation(**self.p)
        self.measure()

    def faults(self):
        c, bits = self.cell, 0
        for i in range(c.n):
            if self.q[i] <= c.limits[i, 0] or self.q[i] >= c.limits[i, 1]:
                bits |= 1 << i
            if abs(self.qd[i]) > c.velocity_limits[i] * (1 + 1e-6):  # the solver's rounding is no fault
                bits |= 1 << (8 + i)
            if c.effort_from_urdf[i] and abs(self.torque[i]) >= c.efforts[i] * (1 - 1e-6):
                bits |= 1 << (16 + i)
        return bits


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", required=True, help="scene JSON (vservoctl scene --config FILE)")
    parser.add_argument("--urdf", required=True, help="the arm's URDF (the one the scene's arm.urdf models)")
    parser.add_argument("--instance", default="default")
    parser.add_argument("--duration-s", type=float, default=math.inf)
    parser.add_argument("--save-image", help="write the first camera image here (PGM)")
    parser.add_argument("--fifo-priority", type=int, default=0, help="SCHED_FIFO priority of the arm loop (0: none)")
    parser.add_argument("--collision-log", help="every 10 ms a JSON line of PyBullet's contacts and closest points "
                                                "between the arm (and the camera's box) and the scene's obstacles")
    parser.add_argument("--velocity-lag-s", type=float, default=0.0,
                        help="velocity mode: the joints' speed follows the command through a first-order lag of "
                             "this time constant (s; 0: at once), as a velocity-commanded arm's drives do")
    options = parser.parse_args(argv)
    with open(options.scene) as file:
        scene = json.load(file)
    modes = {"velocity": VELOCITY, "position": POSITION}
    if scene["robot"]["command"] not in modes:
        fail(f"the scene's robot.command is {scene['robot']['command']!r}: this driver takes velocity or position")
    mode = modes[scene["robot"]["command"]]
    check_camera(scene)
    if not 0.0 <= options.velocity_lag_s <= 1.0:
        fail(f"--velocity-lag-s {options.velocity_lag_s}: expected 0 to 1 s")
    arm = Arm(scene, options.urdf, options.velocity_lag_s)
    n, instance = arm.cell.n, options.instance
    obstacles = Obstacles(scene, arm.cell)
    collision_log = open(options.collision_log, "w") if options.collision_log else None

    context = multiprocessing.get_context("spawn")
    stop = context.Event()  # the driver's stop, for the camera
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, on_stop_signal)
    q_shared, stamp_shared = context.RawArray(ctypes.c_double, n), context.RawValue(ctypes.c_uint64)
    lock = context.Lock()
    q_shared[:] = arm.q  # stamp 0: no joint state yet
    ready = context.Event()
    camera = context.Process(target=camera_process, name="camera", daemon=True,
                             args=(scene, options.urdf, instance, (q_shared, stamp_shared, lock), stop, ready,
                                   options.save_image))
    camera.start()
    node = make_node(instance, "pybullet_driver", lambda: _stopping[0] or not camera.is_alive())
    while node is not None and camera.is_alive() and not _stopping[0] and not ready.wait(0.1):
        pass
    if node is None or not ready.is_set() or _stopping[0]:
        stop.set()
        camera.join()
        return 1 if camera.exitcode else 0  # the camera failed to start (its error is printed), or stopped
    state_publisher = open_topic(node, instance, "joint_state", JointState, 1, 64).publisher_builder().create()
    state_notifier = open_notifier(node, instance, "joint_state")
    commands = open_topic(node, instance, "joint_command", JointCommand, 0, 64).subscriber_builder().create()
    # a held cell's velocity commands may only bring the arm to rest (vservo_driver.HeldCell)
    modes, held = cell_modes(node, instance), held_cell(scene, n)
    if options.fifo_priority > 0:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(options.fifo_priority))
        except PermissionError:
            print("pybullet_driver: warning: SCHED_FIFO not permitted; on the normal scheduler", file=sys.stderr)

    period_ns = round(scene["robot"]["period_s"] * 1e9)
    epoch = start = monotonic_ns()
    tick, last_valid_ns, command, gaps, late = 0, -COMMAND_TIMEOUT_NS, None, [], []
    state = JointState(schema=SCHEMA, driver_epoch=epoch, period_ns=period_ns, command_mode=mode, joint_count=n)
    applied_tick = NONE  # the command the last step applied (none before the first)
    last_publish = None
    while True:
        # 1. publish the joint state, notify, and share it with the camera
        state.tick, state.stamp_ns, state.faults = tick, monotonic_ns(), arm.faults()
        state.driver_status = FOLLOWING if applied_tick != NONE else HOLDING
        state.applied_command_tick = applied_tick
        state.q_rad[:n], state.qd_rad_s[:n], state.torque_nm[:n] = arm.q, arm.qd, arm.torque
        state_publisher.send_copy(state)
        state_notifier.notify()
        with lock:
            q_shared[:], stamp_shared.value = arm.q, state.stamp_ns
        if last_publish is not None:
            gaps.append(state.stamp_ns - last_publish)
        last_publish = state.stamp_ns
        if _stopping[0] or state.stamp_ns - start >= options.duration_s * 1e9:
            break

        # 2. at the next deadline: the newest valid command (our mode, this run of the driver, answering a recent
        # joint state: normally the one just published), else hold
        deadline = start + (tick + 1) * period_ns
        sleep_until(deadline)
        woke = monotonic_ns()
        late.append(woke - deadline)
        follow_cell_mode(modes, held)
        while (sample := commands.receive()) is not None:
            c = JointCommand.from_buffer_copy(sample.payload().contents)
            values = command_values(c, mode, n)
            if (refusal(c, epoch=epoch, mode=mode, joint_count=n, last_tick=tick) is None
                    and (mode != VELOCITY or held.refusal(values) is None)):
                held.took(values)
                command = np.array(values)
                last_valid_ns, applied_tick = woke, c.answers_tick
        if woke - last_valid_ns > COMMAND_TIMEOUT_NS:
            command, applied_tick = None, NONE  # bring the joints to rest

        # 3. advance the physics by the periods that passed (normally one)
        periods = periods_passed(start, tick, period_ns, woke)
        for _ in range(min(periods, MOST_PERIODS_CAUGHT_UP)):
            arm.step(mode, command)
            obstacles.follow()
        tick += periods
        if collision_log is not None and tick % max(1, round(0.01 / scene["robot"]["period_s"])) < periods:
            contacts, distance_m, link, obstacle = obstacles.watch()
            collision_log.write(json.dumps({"t_s": (monotonic_ns() - start) / 1e9, "contacts": contacts,
                                            "closest_m": distance_m, "link": link, "obstacle": obstacle,
                                            "q_rad": list(arm.q)}) + "\n")

    if collision_log is not None:
        collision_log.close()
    stop.set()
    camera.join(5)
    if camera.is_alive():
        camera.terminate()
    if gaps:
        print(f"pybullet_driver: {tick} ticks; joint state gap p50/p99/max {spread_ms(gaps)} ms; wake-up lateness "
              f"p50/p99/max {spread_ms(late)} ms", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
