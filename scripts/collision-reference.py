#!/usr/bin/env python3
"""Reference distances for vservo's collision model (crates/vservo-collision), computed with PyPI `coal` 3.x
(FCL's successor from the Pinocchio team), independently of vservo: the URDF read with xml.etree, forward
kinematics written here, meshes loaded by coal's assimp loader and kept as qhull's convex hulls
(BVHModel.buildConvexHull), distances from coal.distance (signed: negative is the depth of an overlap).

    collision-reference.py REQUEST.json > ANSWER.json

REQUEST: {"urdf": PATH, "joints": [NAME, ...], "configs": [[RAD, ...], ...],
          "obstacles": [{"name": N, "box": {"size_m": [X, Y, Z], "centre_m": [X, Y, Z]}}
                        or {"name": N, "halfspace": {"normal": [X, Y, Z], "offset_m": D}} (n·x ≤ D), ...]}
The joints named take the config's values; every other joint is at 0.
ANSWER: {"pairs": [[LINK, LINK or OBSTACLE], ...], "distances_m": [[one per pair] per config],
         "seconds_per_query": S}: every pair of links with collision geometry that no fixed joint joins, and every
such link with every obstacle.
"""
import json
import math
import os
import re
import sys
import time
import xml.etree.ElementTree as ET

import coal
import numpy as np


def rpy_to_R(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def axis_angle_R(axis, a):
    x, y, z = axis / np.linalg.norm(axis)
    c, s, C = math.cos(a), math.sin(a), 1 - math.cos(a)
    return np.array([
        [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
        [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
        [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
    ])


def hom(R=None, t=None):
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if t is not None:
        T[:3, 3] = t
    return T


def origin_T(elem):
    o = elem.find("origin") if elem is not None else None
    if o is None:
        return np.eye(4)
    xyz = [float(v) for v in o.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in o.get("rpy", "0 0 0").split()]
    return hom(rpy_to_R(*rpy), xyz)


def parse_xml(path):
    """Tolerates undeclared namespace prefixes (airo-models' UR5e writes drake:… without declaring it)."""
    text = open(path, encoding="utf-8").read()
    prefixes = set(re.findall(r"[\s<]([A-Za-z_][\w.-]*):[A-Za-z_][\w.-]*", text)) - {"xmlns", "xml", "package", "file", "http", "https"}
    decl = "".join(f' xmlns:{p}="urn:{p}"' for p in sorted(prefixes) if f"xmlns:{p}=" not in text)
    return ET.fromstring(re.sub(r"<robot\b", "<robot" + decl, text, count=1))


def resolve_mesh(filename, urdf_dir):
    if filename.startswith("file://"):
        return filename[len("file://"):]
    if filename.startswith("package://"):
        rest = filename[len("package://"):]
        rel = rest.partition("/")[2]
        d = urdf_dir
        while True:
            for cand in (os.path.join(d, rel), os.path.join(d, rest)):
                if os.path.exists(cand):
                    return cand
            if os.path.dirname(d) == d:
                raise FileNotFoundError(filename)
            d = os.path.dirname(d)
    return os.path.join(urdf_dir, filename)


class Robot:
    def __init__(self, urdf_path):
        root = parse_xml(urdf_path)
        urdf_dir = os.path.dirname(os.path.abspath(urdf_path))
        self.joints, self.child_joint, kids = {}, {}, {}
        for j in root.findall("joint"):
            axis = j.find("axis")
            jd = dict(name=j.get("name"), type=j.get("type"), parent=j.find("parent").get("link"),
                      child=j.find("child").get("link"), T=origin_T(j),
                      axis=np.array([float(v) for v in axis.get("xyz").split()]) if axis is not None
                      else np.array([1.0, 0, 0]))
            self.joints[jd["name"]] = jd
            self.child_joint[jd["child"]] = jd
            kids.setdefault(jd["parent"], []).append(jd["child"])
        links = [l.get("name") for l in root.findall("link")]
        self.root = next(l for l in links if l not in self.child_joint)
        self.order, stack = [], [self.root]
        while stack:
            l = stack.pop()
            self.order.append(l)
            stack.extend(reversed(kids.get(l, [])))
        # links joined by fixed joints are one rigid body
        self.body = {}
        for l in self.order:
            j = self.child_joint.get(l)
            self.body[l] = self.body[j["parent"]] if j is not None and j["type"] == "fixed" else l
        loader = coal.MeshLoader()
        self.geoms = {}
        for l in root.findall("link"):
            out = []
            for c in l.findall("collision"):
                g = c.find("geometry")[0]
                if g.tag == "box":
                    geo = coal.Box(*(float(v) for v in g.get("size").split()))
                elif g.tag == "cylinder":
                    geo = coal.Cylinder(float(g.get("radius")), float(g.get("length")))
                elif g.tag == "sphere":
                    geo = coal.Sphere(float(g.get("radius")))
                elif g.tag == "mesh":
                    scale = np.array([float(v) for v in g.get("scale", "1 1 1").split()])
                    bvh = loader.load(resolve_mesh(g.get("filename"), urdf_dir), scale)
                    # the real hull (qhull); buildConvexRepresentation would keep the mesh's own vertices
                    bvh.buildConvexHull(False, "Qt")
                    geo = bvh.convex
                else:
                    raise ValueError(f"{l.get('name')}: {g.tag} is not read here")
                geo.computeLocalAABB()
                out.append((geo, origin_T(c)))
            if out:
                self.geoms[l.get("name")] = out

    def fk(self, values):
        T = {self.root: np.eye(4)}
        for l in self.order[1:]:
            j = self.child_joint[l]
            M = j["T"]
            v = values.get(j["name"], 0.0)
            if j["type"] in ("revolute", "continuous"):
                M = M @ hom(axis_angle_R(j["axis"], v))
            elif j["type"] == "prismatic":
                M = M @ hom(t=j["axis"] / np.linalg.norm(j["axis"]) * v)
            T[l] = T[j["parent"]] @ M
        return T


def coal_T(T):
    return coal.Transform3s(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]))


def main():
    request = json.load(open(sys.argv[1]))
    robot = Robot(request["urdf"])
    links = [l for l in robot.order if l in robot.geoms]
    pairs = [(a, b) for i, a in enumerate(links) for b in links[i + 1:] if robot.body[a] != robot.body[b]]
    obstacles = []
    for o in request.get("obstacles", []):
        if "box" in o:
            geo, T = coal.Box(*o["box"]["size_m"]), hom(t=o["box"]["centre_m"])
        else:
            geo, T = coal.Halfspace(np.array(o["halfspace"]["normal"], dtype=float), o["halfspace"]["offset_m"]), np.eye(4)
        geo.computeLocalAABB()
        obstacles.append((o["name"], geo, T))
    pairs += [(l, name) for l in links for name, _, _ in obstacles]
    shapes = {name: [(geo, T)] for name, geo, T in obstacles}
    queries, seconds = 0, 0.0
    rows = []
    for q in request["configs"]:
        Tw = robot.fk(dict(zip(request["joints"], q)))
        placed = {l: [(g, coal_T(Tw[l] @ Tg)) for g, Tg in robot.geoms[l]] for l in links}
        placed.update({name: [(g, coal_T(T)) for g, T in shapes[name]] for name in shapes})
        row = []
        for a, b in pairs:
            best = math.inf
            for g1, T1 in placed[a]:
                for g2, T2 in placed[b]:
                    req, res = coal.DistanceRequest(), coal.DistanceResult()
                    began = time.perf_counter()
                    d = coal.distance(g1, T1, g2, T2, req, res)
                    seconds += time.perf_counter() - began
                    queries += 1
                    best = min(best, d)
            row.append(best)
        rows.append(row)
    json.dump({"pairs": pairs, "distances_m": rows, "seconds_per_query": seconds / max(queries, 1)}, sys.stdout)


if __name__ == "__main__":
    main()
