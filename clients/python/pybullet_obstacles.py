"""What stands around the arm in the PyBullet reference driver's physics (the scene's `collision`: vservoctl
scene's `[[scene.obstacles]]` and the camera's box), and PyBullet's own view of how near the arm comes to it.

`Obstacles(scene, cell)` adds each obstacle as a static body of its shape at its pose in the base frame (a box's
full edges, a cylinder's or capsule's length along its z, a plane's solid side below its xy plane), and the camera
and its mount as a box that `follow` puts where the tool carries it each period (a hand camera). `watch()` says
PyBullet's contact points between the arm (or the camera's box) and the obstacles, and its closest points within
1 m: the nearest pair and its distance, for `pybullet_driver.py --collision-log`.
"""

import math

import numpy as np
import pybullet

# how far PyBullet looks for closest points (m)
WATCHED_WITHIN_M = 1.0


def _quaternion(r):
    """A rotation matrix as PyBullet's quaternion (x, y, z, w)."""
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2 * math.sqrt(1 + trace)
        return [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, s / 4]
    i = int(np.argmax(np.diag(r)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * math.sqrt(max(0.0, 1 + r[i, i] - r[j, j] - r[k, k]))
    q = [0.0] * 4
    q[i], q[j], q[k], q[3] = s / 4, (r[j, i] + r[i, j]) / s, (r[k, i] + r[i, k]) / s, (r[k, j] - r[j, k]) / s
    return q


def _shape(solid, client):
    """A PyBullet collision shape for an obstacle's solid, and the pose of it within the solid's frame."""
    kind = solid["shape"]
    if kind == "box":
        half = [v / 2 for v in solid["size_m"]]
        return pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half, physicsClientId=client), np.eye(4)
    if kind == "cylinder":
        return pybullet.createCollisionShape(pybullet.GEOM_CYLINDER, radius=solid["radius_m"],
                                             height=solid["length_m"], physicsClientId=client), np.eye(4)
    if kind == "capsule":
        return pybullet.createCollisionShape(pybullet.GEOM_CAPSULE, radius=solid["radius_m"],
                                             height=solid["length_m"], physicsClientId=client), np.eye(4)
    if kind == "sphere":
        return pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=solid["radius_m"],
                                             physicsClientId=client), np.eye(4)
    if kind == "plane":
        return pybullet.createCollisionShape(pybullet.GEOM_PLANE, planeNormal=[0, 0, 1],
                                             physicsClientId=client), np.eye(4)
    raise ValueError(f"an obstacle of shape {kind!r}")


class Obstacles:
    """The scene's obstacles and the camera's box as PyBullet bodies in the arm's client."""

    def __init__(self, scene, cell):
        self.cell, c = cell, cell.client
        collision = scene.get("collision") or {}
        self.names, self.bodies = [], []
        for obstacle in collision.get("obstacles", []):
            shape, _ = _shape(obstacle["solid"], c)
            world = cell.world_from_base @ np.array(obstacle["base_from_obstacle"], dtype=float)
            body = pybullet.createMultiBody(0, shape, -1, list(world[:3, 3]), _quaternion(world[:3, :3]),
                                            physicsClientId=c)
            self.names.append(obstacle["name"])
            self.bodies.append(body)
        self.camera = None
        box, centre = collision.get("camera_box_m"), collision.get("camera_box_centre_m")
        if box is not None and scene.get("camera_mount") == "hand":
            shape = pybullet.createCollisionShape(pybullet.GEOM_BOX, halfExtents=[v / 2 for v in box],
                                                  physicsClientId=c)
            self.tip_from_box = np.array(scene["tool_from_camera"], dtype=float)
            self.tip_from_box = self.tip_from_box @ np.block([[np.eye(3), np.array(centre).reshape(3, 1)],
                                                              [np.zeros((1, 3)), np.ones((1, 1))]])
            self.camera = pybullet.createMultiBody(0, shape, -1, [0, 0, 0], [0, 0, 0, 1], physicsClientId=c)
            # it is not the arm's: no contact with its links pushes the arm (two static bodies, it and an obstacle,
            # make no contact either: its distance to them is read from closest points)
            for link in range(-1, pybullet.getNumJoints(cell.body, physicsClientId=c)):
                pybullet.setCollisionFilterPair(cell.body, self.camera, link, -1, 0, physicsClientId=c)
            self.follow()

    def follow(self):
        """Puts the camera's box where the tool carries it now."""
        if self.camera is None:
            return
        world = self.cell.world_from_tip() @ self.tip_from_box
        pybullet.resetBasePositionAndOrientation(self.camera, list(world[:3, 3]), _quaternion(world[:3, :3]),
                                                 physicsClientId=self.cell.client)

    def _link_name(self, body, link):
        if body == self.camera:
            return "camera"
        if link == -1:
            return pybullet.getBodyInfo(body, physicsClientId=self.cell.client)[0].decode()
        return pybullet.getJointInfo(body, link, physicsClientId=self.cell.client)[12].decode()

    def watch(self):
        """PyBullet's contact points between the arm or the camera's box and the obstacles (how many), and the
        nearest closest point within 1 m: (contacts, distance m or None, the arm's link, the obstacle)."""
        c = self.cell.client
        pybullet.performCollisionDetection(physicsClientId=c)
        contacts, nearest = 0, (None, None, None)
        movers = [self.cell.body] + ([self.camera] if self.camera is not None else [])
        # the arm's root stands where it is (on the floor, say): as vservo's guard, it is not watched
        moves = lambda mover, link: mover != self.cell.body or link != -1  # noqa: E731
        for name, obstacle in zip(self.names, self.bodies):
            for mover in movers:
                touching = pybullet.getContactPoints(bodyA=mover, bodyB=obstacle, physicsClientId=c)
                contacts += sum(1 for point in touching if moves(mover, point[3]))
                for point in pybullet.getClosestPoints(mover, obstacle, WATCHED_WITHIN_M, physicsClientId=c):
                    if not moves(mover, point[3]):
                        continue
                    # the camera's box is static: its touching shows in its distance
                    contacts += int(mover == self.camera and point[8] <= 0.0)
                    if nearest[0] is None or point[8] < nearest[0]:
                        nearest = (point[8], self._link_name(mover, point[3]), name)
        return contacts, nearest[0], nearest[1], nearest[2]
