#!/usr/bin/env python3
"""A MuJoCo arm and hand camera for vservo: the reference robot + camera driver.

Copy this file to write a driver for a real arm and camera: replace `Arm` (`step`: send the joint velocities
and wait for the next encoder reading) and `Camera.grab` (take an image), keep the rest. It speaks docs/PROTOCOL.md (schema 13) over
iceoryx2 0.10 shared memory:

- every robot period (1 ms) it publishes `joint_state` and notifies the `joint_state` event;
- it reads the newest `joint_command` each period and follows its JOINT VELOCITY command (`mode` 1,
  `qd_ref_rad_s`) if `vservo_driver.refusal` takes it (the Rust driver side's rule: this driver run, answering the
  last joint state or one of the MAX_COMMAND_AGE_TICKS before it, finite); with no valid command for 20 ms it brings the joints to rest (commanded velocity 0) and reports `driver_status` 1 (holding);
- every vision period it renders the hand camera and publishes it on `camera_image` as 8-bit grayscale,
  stamped with the time of the joint state it shows, and notifies the `camera_image` event.

The arm is the scene's standard-DH arm (vservo's PUMA 560) simulated by MuJoCo, the camera MuJoCo's
offscreen renderer (headless: MUJOCO_GL=egl, Mesa's software EGL; scripts/setup-mujoco.sh installs it).

    mujoco_driver.py --scene scene.json [--instance NAME] [--duration-s S] [--save-image first.pgm]
                     [--fifo-priority N] [--rtp-port PORT]

With --rtp-port the camera's frames are not published on `camera_image` but streamed as RTP raw video
(RFC 4175, I420 with the gray image as its luma) to 127.0.0.1:PORT over UDP, through `gst-launch-1.0`:
a camera on the network, for vservo's GStreamer camera driver (scripts/run-rtp-camera.sh).

The scene comes from `vservoctl scene --config FILE`. SIGINT/SIGTERM stop it (exit code 0).
"""

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time

os.environ.setdefault("MUJOCO_GL", "egl")  # before importing mujoco: headless OpenGL

import mujoco
import numpy as np

from vservo_driver import (COMMAND_TIMEOUT_NS, FOLLOWING, HOLDING, MAX_COMMAND_AGE_TICKS, SCHEMA, VELOCITY,  # noqa: F401
                           MOST_PERIODS_CAUGHT_UP, JointCommand, JointState, camera_image_publisher, cell_modes,
                           command_values, follow_cell_mode, held_cell, make_node, open_notifier, open_topic, periods_passed, refusal, sleep_until, spread_ms)

JOINTS = 6  # the arm's (the PUMA 560's); the messages have room for 7 (joint_count says how many)
VELOCITY_BANDWIDTH_RAD_S = 1000.0  # of the simulated joints' velocity loop
POSITION_CORRECTION_PER_S = 50.0  # how fast the integrated reference pulls a drifted joint back


def set_fifo_priority(priority: int) -> None:
    """SCHED_FIFO for the calling thread. Both threads get it (the camera one below the arm's): a thread that
    holds the GIL must not be preempted by other processes while the arm loop waits for the GIL."""
    sys.setswitchinterval(0.0002)  # the arm loop gets the GIL back within 0.2 ms (default 5 ms)
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError:
        print("mujoco_driver: warning: SCHED_FIFO not permitted; on the normal scheduler", file=sys.stderr)


# --- the scene as MuJoCo XML ---
def rot_x(a):
    return np.array([[1, 0, 0, 0], [0, math.cos(a), -math.sin(a), 0], [0, math.sin(a), math.cos(a), 0], [0, 0, 0, 1]])


def rot_z(a):
    return np.array([[math.cos(a), -math.sin(a), 0, 0], [math.sin(a), math.cos(a), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])


def translate(x, y, z):
    t = np.eye(4)
    t[:3, 3] = [x, y, z]
    return t


def dh_link(row):
    """Frame i-1 → frame i at q_i = 0 (standard DH): Rz(θ_offset)·Tz(d)·Tx(a)·Rx(α)."""
    return rot_z(row["theta_offset_rad"]) @ translate(0, 0, row["d_m"]) @ translate(row["a_m"], 0, 0) @ rot_x(row["alpha_rad"])


def placement(t):
    """MJCF pos and quat attributes of a 4×4 pose."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(t[:3, :3]).flatten())
    return 'pos="%.9g %.9g %.9g" quat="%.12g %.12g %.12g %.12g"' % (*t[:3, 3], *quat)


def gray(level):
    return "%.6f %.6f %.6f 1" % ((level / 255.0,) * 3)


class Lens:
    """The configured camera made from MuJoCo's, which renders a pinhole with square pixels and its principal point at
    the image centre (`fovy`).

    With fx = fy, the principal point at the image centre (±0.5 px) and no distortion MuJoCo renders the camera's
    image directly. Otherwise MuJoCo renders a square-pixel pinhole canvas of focal length fy, centred and large
    enough to hold what every pixel of the camera sees, and each pixel of the camera's image takes the canvas at the
    point it sees: its centre undistorted (OpenCV's k1, k2, p1, p2, k3, inverted by Newton's method, numpy, once at
    start), read bilinearly. The image is then the camera's as its lens makes it; vservo undistorts the marks.
    """

    def __init__(self, cam):
        self.width, self.height = cam["width_px"], cam["height_px"]
        fx, fy = cam.get("fx_px", cam["focal_px"]), cam.get("fy_px", cam["focal_px"])
        cx, cy = cam["principal_point_px"]
        self.coefficients = [float(k) for k in cam.get("distortion", [0.0] * 5)]
        self.direct = (fx == fy and not any(self.coefficients)
                       and abs(cx - self.width / 2) <= 0.5 and abs(cy - self.height / 2) <= 0.5)
        self.focal_px = fy
        if self.direct:
            self.canvas_width, self.canvas_height = self.width, self.height
            return
        u, v = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        x, y = self.undistort((u - cx) / fx, (v - cy) / fy)
        half_w = int(math.ceil(np.abs(x).max() * fy)) + 2
        half_h = int(math.ceil(np.abs(y).max() * fy)) + 2
        self.canvas_width, self.canvas_height = 2 * half_w, 2 * half_h
        # where each pixel's centre falls on the canvas, as array indices (pixel i covers [i, i + 1))
        self.source_x = half_w + fy * x - 0.5
        self.source_y = half_h + fy * y - 0.5

    def fovy_deg(self):
        return math.degrees(2 * math.atan(self.canvas_height / 2 / self.focal_px))

    def distort(self, x, y):
        k1, k2, p1, p2, k3 = self.coefficients
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return (x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y)

    def undistort(self, xd, yd):
        """The normalised points the lens images at (xd, yd): Newton's method with a numerical Jacobian, to 1e-12."""
        x, y = xd.copy(), yd.copy()
        h = 1e-7
        for _ in range(30):
            fx_, fy_ = self.distort(x, y)
            rx, ry = fx_ - xd, fy_ - yd
            if max(np.abs(rx).max(), np.abs(ry).max()) < 1e-12:
                return x, y
            ax, ay = self.distort(x + h, y)
            bx, by = self.distort(x, y + h)
            j11, j21, j12, j22 = (ax - fx_) / h, (ay - fy_) / h, (bx - fx_) / h, (by - fy_) / h
            det = j11 * j22 - j12 * j21
            x, y = x - (j22 * rx - j12 * ry) / det, y - (-j21 * rx + j11 * ry) / det
        raise SystemExit("mujoco_driver: the configured lens cannot be undistorted over the image")

    def image(self, canvas):
        """The camera's image (height × width, u8) from MuJoCo's render."""
        if self.direct:
            return canvas
        x0, y0 = np.floor(self.source_x), np.floor(self.source_y)
        tx, ty = self.source_x - x0, self.source_y - y0
        x0 = np.clip(x0.astype(int), 0, self.canvas_width - 2)
        y0 = np.clip(y0.astype(int), 0, self.canvas_height - 2)
        c = canvas.astype(np.float32)
        top = c[y0, x0] * (1 - tx) + c[y0, x0 + 1] * tx
        bottom = c[y0 + 1, x0] * (1 - tx) + c[y0 + 1, x0 + 1] * tx
        return np.clip(top * (1 - ty) + bottom * ty + 0.5, 0, 255).astype(np.uint8)


def tag_boxes(tag) -> str:
    """A tag's black cells as thin black boxes on the board (the white ones are the board), each row's runs of
    black cells one box."""
    cell = tag["size_m"] / 8
    (cx, cy) = tag["centre_in_board_m"]
    boxes = []
    for row, cells in enumerate(tag["black_cells"]):
        column = 0
        while column < len(cells):
            if not cells[column]:
                column += 1
                continue
            start = column
            while column < len(cells) and cells[column]:
                column += 1
            centre = (start + column - 1) / 2
            boxes.append(f'<geom type="box" size="{(column - start) * cell / 2:.9g} {cell / 2:.9g} 0.00005" '
                         f'pos="{cx + (centre - 3.5) * cell:.9g} {cy + (row - 3.5) * cell:.9g} -0.00005" material="mark" '
                         f'mass="0"/>')
    return "".join(boxes)


def board_body(board, parent_from_board) -> str:
    """The board (a body at parent_from_board, massless): its white face is the board plane z = 0, the box behind
    it (+z), the marks on it, 0.1 mm towards the camera."""
    (xlo, ylo), (xhi, yhi) = board["extent_m"]
    thickness = 0.005
    marks = "".join(f'<geom type="cylinder" size="{board["mark_diameter_m"] / 2:.9g} 0.00005" pos="{x:.9g} {y:.9g} -0.00005" '
                    f'material="mark" mass="0"/>' for x, y in board["marks_in_board_m"])
    # an AprilTag target (or a bundle of tags), and the calibration board printed around it (its tags include
    # the target's)
    grid = (board.get("calibration_grid") or {}).get("tags", [])
    tags = grid or board.get("target_tags") or ([board["apriltag"]] if board.get("apriltag") else [])
    if tags:
        marks = "".join(tag_boxes(tag) for tag in tags)
    return (f'<body name="board" {placement(parent_from_board)}>'
            f'<geom type="box" size="{(xhi - xlo) / 2:.9g} {(yhi - ylo) / 2:.9g} {thickness / 2}" '
            f'pos="{(xhi + xlo) / 2:.9g} {(yhi + ylo) / 2:.9g} {thickness / 2}" material="board" mass="0"/>'
            f'{marks}</body>')


def build_mjcf(scene) -> str:
    """The arm (body i is DH frame i-1 turned by q_i about its z), the camera, the board with its marks.

    The camera (named "camera") rides on DH frame 6 at tool_from_camera, or with the scene's camera_mount "world"
    stands in the world at base_from_camera, the board then a body of DH frame 6 at tool_from_board.

    Gray levels as vservo's simulated camera draws them: board 230, marks 20, background 110 (a flat skybox).
    No lights: MuJoCo then shows a surface at (0.3 + emission) × rgba (0.3 of ambient, measured with MuJoCo
    4.0), so emission 0.7 shows each surface at exactly its rgba, with no shading or shadows.
    The links are capsules along the DH offsets, with MuJoCo's inertias for them at a density of 1000 kg/m³:
    plausible, NOT the PUMA 560's true masses and inertias (vservo's own plant has those).
    """
    fixed = scene.get("camera_mount", "hand") == "world"
    arm, cam, board = scene["arm"], scene["camera"], scene["board"]
    lens = Lens(cam)
    fovy_deg = lens.fovy_deg()
    bodies, parent_from_body = [], np.eye(4)
    for i, (row, (lo, hi)) in enumerate(zip(arm["dh"], arm["joint_limits_rad"])):
        radius = 0.05 if i < 3 else 0.035
        end = dh_link(row)[:3, 3]
        elbow = (0, 0, row["d_m"])  # the link runs along z by d, then along the new x by a
        geoms = f'<geom type="sphere" size="{radius * 1.2}"/>'
        for a, b in ((np.zeros(3), elbow), (elbow, end)):
            if np.linalg.norm(np.subtract(b, a)) > 1e-6:
                geoms += '<geom type="capsule" size="%g" fromto="%g %g %g %g %g %g"/>' % (radius, *a, *b)
        if i == 5 and fixed:  # the board, fixed to DH frame 6
            geoms += board_body(board, dh_link(row) @ np.array(scene["tool_from_board"]))
        elif i == 5:  # the camera, fixed to DH frame 6; MuJoCo's camera looks along its −z with y up: Rx(180°)
            tool_from_mujoco_camera = dh_link(row) @ np.array(scene["tool_from_camera"]) @ rot_x(math.pi)
            geoms += (f'<camera name="camera" {placement(tool_from_mujoco_camera)} fovy="{fovy_deg:.9g}"/>'
                      f'<geom type="box" size="0.02 0.02 0.02" {placement(tool_from_mujoco_camera)}/>')
        bodies.append(f'<body name="link{i + 1}" {placement(parent_from_body)} gravcomp="1">'
                      f'<joint name="q{i + 1}" range="{lo:.9g} {hi:.9g}"/>{geoms}')
        parent_from_body = dh_link(row)
    if fixed:  # MuJoCo's camera looks along its −z with y up: Rx(180°)
        world_camera = np.array(scene["base_from_camera"]) @ rot_x(math.pi)
        standing = f'<camera name="camera" {placement(world_camera)} fovy="{fovy_deg:.9g}"/>'
    else:
        standing = board_body(board, np.array(scene["base_from_board"]))
    actuators = "".join(f'<position joint="q{i}" kp="1"/><velocity joint="q{i}" kv="1"/>' for i in range(1, 7))
    return f"""
<mujoco model="vservo-cell">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{scene["robot"]["period_s"]}" integrator="implicitfast"/>
  <visual>
    <global offwidth="{lens.canvas_width}" offheight="{lens.canvas_height}"/>
    <headlight active="0" ambient="0 0 0" diffuse="0 0 0" specular="0 0 0"/>
    <quality shadowsize="0" numslices="64" offsamples="4"/>
    <map haze="0"/>
  </visual>
  <asset>
    <texture name="sky" type="skybox" builtin="flat" rgb1="{gray(110)[:-2]}" rgb2="{gray(110)[:-2]}" width="8" height="8"/>
    <material name="board" rgba="{gray(230)}" emission="0.7" specular="0" shininess="0" reflectance="0"/>
    <material name="mark" rgba="{gray(20)}" emission="0.7" specular="0" shininess="0" reflectance="0"/>
    <material name="arm" rgba="{gray(160)}" emission="0.7" specular="0" shininess="0" reflectance="0"/>
  </asset>
  <default>
    <geom contype="0" conaffinity="0" material="arm"/>
    <joint type="hinge" axis="0 0 1" armature="0.05" limited="true"/>
  </default>
  <worldbody>
    {"".join(bodies)}{"</body>" * len(bodies)}
    {standing}
  </worldbody>
  <actuator>{actuators}</actuator>
</mujoco>"""


class Arm:
    """The simulated arm under joint velocity commands.

    A real arm in velocity mode tracks q̇ closely: its drives close a fast velocity loop and compensate gravity.
    MuJoCo does the same with: gravity compensation (`gravcomp`), the commanded q̇ integrated into a position
    reference q_ref, and per joint a stiff position actuator on q_ref plus a velocity actuator on q̇ (the
    velocity feed-forward): τ = kp (q_ref − q) + kv (q̇_cmd − q̇). A velocity actuator alone would let the
    joints drift under the coupling torques; the integrated reference removes that drift and the feed-forward
    removes the lag. kv makes each joint's velocity loop a first-order lag of about 1 ms (kv = inertia at the
    start pose × VELOCITY_BANDWIDTH_RAD_S; MuJoCo's implicit integrator keeps so high a kv stable at a 1 ms
    step), kp = kv × POSITION_CORRECTION_PER_S. Measured on a step to 0.5 rad/s: within 5 % after 3 ms, ~7 %
    overshoot while the lag of the first milliseconds is made up (20 ms), then errors ~1e-5 rad and rad/s.
    """

    def __init__(self, model, scene):
        self.model, self.data = model, mujoco.MjData(model)
        self.data.qpos[:6] = scene["start_joints_rad"]
        mujoco.mj_forward(model, self.data)
        full = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, self.data, full)
        inertia = np.diag(full)[:6]  # each joint's inertia (with armature) at the start pose
        kv = inertia * VELOCITY_BANDWIDTH_RAD_S
        kp = kv * POSITION_CORRECTION_PER_S
        model.actuator_gainprm[0::2, 0], model.actuator_biasprm[0::2, 1] = kp, -kp  # position actuators
        model.actuator_gainprm[1::2, 0], model.actuator_biasprm[1::2, 2] = kv, -kv  # velocity actuators
        self.limits = np.array(scene["arm"]["joint_limits_rad"])
        self.velocity_limits = np.array(scene["arm"]["velocity_limits_rad_s"])
        self.q_ref = self.data.qpos[:6].copy()

    def step(self, qd_command):
        """One physics step with the commanded joint velocities (clipped to the velocity limits)."""
        qd = np.clip(qd_command, -self.velocity_limits, self.velocity_limits)
        self.data.ctrl[0::2], self.data.ctrl[1::2] = self.q_ref, qd
        mujoco.mj_step(self.model, self.data)
        self.q_ref = np.clip(self.q_ref + qd * self.model.opt.timestep, self.limits[:, 0], self.limits[:, 1])

    def faults(self):
        q, qd = self.data.qpos[:6], self.data.qvel[:6]
        bits = 0
        for i in range(6):
            if q[i] <= self.limits[i, 0] or q[i] >= self.limits[i, 1]:
                bits |= 1 << i
            if abs(qd[i]) > self.velocity_limits[i]:
                bits |= 1 << (8 + i)
        return bits  # no torque limits in the scene: bits 16–21 stay clear


class Camera(threading.Thread):
    """Renders the hand camera every vision period on its own MjData copy and publishes the image.

    Rendering (20–90 ms with Mesa's software EGL) runs in this thread: MuJoCo releases the GIL while it renders,
    so the arm loop keeps its 1 ms period. The OpenGL context and the iceoryx2 ports belong to this thread.
    """

    def __init__(self, model, scene, instance, latest_state, stop, save_image, fifo_priority, rtp_port=None):
        super().__init__(name="camera")
        self.fifo_priority, self.rtp_port = fifo_priority, rtp_port
        self.model, self.scene, self.instance = model, scene, instance
        self.latest_state, self.stop, self.save_image = latest_state, stop, save_image
        self.render_ms, self.ready = [], threading.Event()
        self.noise_sigma_gray = 0.0  # --camera-noise sets it
        self.noise = np.random.default_rng(1)

    def grab(self, renderer, data, q):
        """The image (height × width, u8) the hand camera sees with the arm at q."""
        data.qpos[:6] = q
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_camlight(self.model, data)
        renderer.update_scene(data, camera="camera")
        image = self.lens.image(renderer.render()[:, :, 0])  # every surface is gray: red = green = blue
        if self.noise_sigma_gray > 0:  # the configured camera's noise (`vision.render.noise_sigma_gray`)
            noisy = image + self.noise.normal(0.0, self.noise_sigma_gray, image.shape)
            image = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
        return image

    def run(self):
        width, height = self.scene["camera"]["width_px"], self.scene["camera"]["height_px"]
        self.lens = Lens(self.scene["camera"])
        renderer = mujoco.Renderer(self.model, self.lens.canvas_height, self.lens.canvas_width)
        data = mujoco.MjData(self.model)
        period_ns = round(self.scene["timing"]["vision_period_s"] * 1e9)
        if self.rtp_port is not None:
            sender, publish = self.rtp_sender(width, height, period_ns)
        else:
            sender, publish = None, self.camera_image_publisher(width, height)
        self.grab(renderer, data, self.latest_state()[0])  # the first render sets up OpenGL (~0.2 s, holding
        self.ready.set()  # the GIL): done before the arm loop starts
        if self.fifo_priority > 0:  # after the OpenGL set-up: Mesa's render threads stay on the normal scheduler
            set_fifo_priority(self.fifo_priority)
        deadline, frame = time.monotonic_ns(), 0
        while not self.stop.is_set():
            q, stamp_ns = self.latest_state()
            started = time.perf_counter()
            image = self.grab(renderer, data, q)
            self.render_ms.append(1e3 * (time.perf_counter() - started))
            publish(image, frame, stamp_ns)
            if frame == 0 and self.save_image:
                with open(self.save_image, "wb") as pgm:
                    pgm.write(b"P5\n%d %d\n255\n" % (width, height) + image.tobytes())
            frame += 1
            deadline += period_ns
            deadline = max(deadline, time.monotonic_ns() - period_ns // 2)  # a late frame is not made up for
            sleep_until(deadline)
        if sender is not None:
            sender.stdin.close()
            sender.terminate()
            sender.wait()

    def camera_image_publisher(self, width, height):
        """Publishes a frame on `camera_image`, stamped with the joint state it shows."""
        return camera_image_publisher(make_node(self.instance, "mujoco_driver"), self.instance, width, height)

    def rtp_sender(self, width, height, period_ns):
        """Streams each frame as RTP raw video to 127.0.0.1:rtp_port: gray → I420 (its luma, exactly) →
        rtpvrawpay (GStreamer 1.22's takes no GRAY8) → UDP. The stamp does not travel: the receiver stamps
        the frame's arrival."""
        rate = f"{10**9}/{period_ns}"
        sender = subprocess.Popen(
            ["gst-launch-1.0", "-q", "fdsrc", "fd=0", "!", "rawvideoparse", "format=gray8", f"width={width}",
             f"height={height}", f"framerate={rate}", "!", "videoconvert", "!", "video/x-raw,format=I420", "!",
             "rtpvrawpay", "mtu=60000", "!", "udpsink", "host=127.0.0.1", f"port={self.rtp_port}", "sync=false"],
            stdin=subprocess.PIPE)

        def publish(image, frame, stamp_ns):
            sender.stdin.write(np.ascontiguousarray(image).tobytes())
            sender.stdin.flush()

        return sender, publish


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", required=True, help="scene JSON (vservoctl scene --config FILE)")
    parser.add_argument("--instance", default="default")
    parser.add_argument("--duration-s", type=float, default=math.inf)
    parser.add_argument("--save-image", help="write the first camera image here (PGM)")
    parser.add_argument("--fifo-priority", type=int, default=0, help="SCHED_FIFO priority of the arm loop (0: none)")
    parser.add_argument("--rtp-port", type=int, help="stream the camera as RTP raw video to 127.0.0.1:PORT instead")
    parser.add_argument("--camera-noise", action="store_true",
                        help="add the configured camera's Gaussian noise (the scene's camera.noise_sigma_gray) to each frame")
    options = parser.parse_args(argv)
    with open(options.scene) as file:
        scene = json.load(file)
    if scene["robot"]["command"] != "velocity":
        print("mujoco_driver: this driver takes joint velocity commands only", file=sys.stderr)
        return 2
    if scene["arm"].get("dh") is None:
        print("mujoco_driver: this driver builds a standard-DH arm; the scene's arm comes from a URDF "
              f"({scene['arm'].get('urdf')}): run clients/python/pybullet_driver.py", file=sys.stderr)
        return 2
    model = mujoco.MjModel.from_xml_string(build_mjcf(scene))
    arm = Arm(model, scene)

    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())

    node, instance = make_node(options.instance, "mujoco_driver"), options.instance
    state_publisher = open_topic(node, instance, "joint_state", JointState, 1, 64).publisher_builder().create()
    state_notifier = open_notifier(node, instance, "joint_state")
    commands = open_topic(node, instance, "joint_command", JointCommand, 0, 64).subscriber_builder().create()
    # a held cell's commands may only bring the arm to rest (vservo_driver.HeldCell)
    modes, held = cell_modes(node, instance), held_cell(scene, JOINTS)

    lock, shared = threading.Lock(), {"q": arm.data.qpos[:6].copy(), "stamp_ns": time.monotonic_ns()}

    def latest_state():
        with lock:
            return shared["q"], shared["stamp_ns"]

    camera = Camera(model, scene, instance, latest_state, stop, options.save_image, max(0, options.fifo_priority - 1),
                    options.rtp_port)
    if options.camera_noise:
        camera.noise_sigma_gray = float(scene["camera"].get("noise_sigma_gray", 0.0))
    period_ns = round(scene["robot"]["period_s"] * 1e9)
    camera.start()
    while not camera.ready.wait(0.1):
        if not camera.is_alive():
            return 1  # the camera failed to start (its error is printed)
    if options.fifo_priority > 0:
        set_fifo_priority(options.fifo_priority)
    epoch = start = time.monotonic_ns()
    tick, qd_command, last_valid_ns, status, gaps = 0, np.zeros(6), -COMMAND_TIMEOUT_NS, HOLDING, []
    NONE = (1 << 64) - 1  # no command applied
    command_tick, applied_tick = NONE, NONE  # the command in force answered; the one the last step applied
    state = JointState(schema=SCHEMA, driver_epoch=epoch, period_ns=period_ns, command_mode=VELOCITY,
                       joint_count=JOINTS)
    last_publish = None
    while not stop.is_set():
        # 1. the newest valid command: velocity mode, this run of the driver, answering a recent joint state
        now = time.monotonic_ns()
        follow_cell_mode(modes, held)
        while (sample := commands.receive()) is not None:
            c = JointCommand.from_buffer_copy(sample.payload().contents)
            # the last state published is the one before this tick's
            published = tick - 1 if tick > 0 else None
            values = command_values(c, VELOCITY, JOINTS)
            if (refusal(c, epoch=epoch, mode=VELOCITY, joint_count=JOINTS, last_tick=published) is None
                    and held.refusal(values) is None):
                held.took(values)
                qd_command = np.array(values)
                last_valid_ns, command_tick = now, c.answers_tick
        status = FOLLOWING if now - last_valid_ns <= COMMAND_TIMEOUT_NS else HOLDING
        if status == HOLDING:
            qd_command, command_tick = np.zeros(6), NONE  # bring the joints to rest

        # 2. publish the joint state, notify, and hand it to the camera
        state.tick, state.stamp_ns, state.faults, state.driver_status = tick, time.monotonic_ns(), arm.faults(), status
        state.applied_command_tick, applied_tick = applied_tick, command_tick  # this state reports the last step
        state.q_rad[:JOINTS], state.qd_rad_s[:JOINTS] = arm.data.qpos[:6], arm.data.qvel[:6]
        state.torque_nm[:JOINTS] = arm.data.qfrc_actuator[:6] + arm.data.qfrc_gravcomp[:6]  # drive torque incl. gravity
        state_publisher.send_copy(state)
        state_notifier.notify()
        with lock:
            shared["q"], shared["stamp_ns"] = arm.data.qpos[:6].copy(), state.stamp_ns
        if last_publish is not None:
            gaps.append(state.stamp_ns - last_publish)
        last_publish = state.stamp_ns
        if state.stamp_ns - start >= options.duration_s * 1e9:
            break

        # 3. sleep to the next deadline, then advance the physics by the periods that passed (normally one)
        sleep_until(start + (tick + 1) * period_ns)
        periods = periods_passed(start, tick, period_ns, time.monotonic_ns())
        for _ in range(min(periods, MOST_PERIODS_CAUGHT_UP)):
            arm.step(qd_command)
        tick += periods

    stop.set()
    camera.join()
    if gaps:
        render = np.array(camera.render_ms[1:] or [math.nan])
        print(f"mujoco_driver: {tick} ticks, {len(camera.render_ms)} frames; joint state gap p50/p99/max "
              f"{spread_ms(gaps)} ms; render mean/max {render.mean():.1f}/{render.max():.1f} ms", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
