#!/usr/bin/env python3
"""Reference values of the PUMA 560 model from Peter Corke's Robotics Toolbox for Python.

Writes crates/vservo-arm/tests/fixtures/puma560_rtb.json, which the arm model's tests compare against
(agreement to 1e-9).

    python3 -m venv /tmp/rtb && /tmp/rtb/bin/pip install roboticstoolbox-python==1.5.0
    /tmp/rtb/bin/python scripts/gen_puma560_fixtures.py

"rigid" is the model with motor armature and friction removed (Jm = B = Tc = 0), "full" the toolbox's
model as shipped (armature G²Jm and viscous/Coulomb friction at the motor, reflected through G).
"""

import copy
import json
import pathlib

import numpy as np
import roboticstoolbox as rtb

OUT = pathlib.Path(__file__).resolve().parent.parent / "crates/vservo-arm/tests/fixtures/puma560_rtb.json"

full = rtb.models.DH.Puma560()
rigid = copy.deepcopy(full)
for link in rigid.links:
    link.Jm = 0.0
    link.B = 0.0
    link.Tc = [0.0, 0.0]

CONFIGS = ["lun", "luf", "ldn", "ldf", "run", "ruf", "rdn", "rdf"]

rng = np.random.default_rng(560)
cases = [
    ("qz", full.qz, np.zeros(6), np.zeros(6)),
    ("qr", full.qr, rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6)),
    ("qs", full.qs, rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6)),
    ("qn", full.qn, np.zeros(6), np.zeros(6)),
    ("qn-moving", full.qn, rng.uniform(-1, 1, 6), rng.uniform(-2, 2, 6)),
]
lo, hi = full.qlim[0], full.qlim[1]
for k in range(8):
    q = rng.uniform(lo, hi)
    # keep the wrist away from its singularity so that the IK set is well defined
    while abs(np.sin(q[4])) < 0.2:
        q = rng.uniform(lo, hi)
    cases.append((f"random-{k}", q, rng.uniform(-1.5, 1.5, 6), rng.uniform(-3, 3, 6)))


def mat(m):
    return [[float(x) for x in row] for row in np.asarray(m)]


def vec(v):
    return [float(x) for x in np.asarray(v).ravel()]


records = []
for name, q, qd, qdd in cases:
    q = np.asarray(q, dtype=float)
    T = full.fkine(q)
    ik = []
    for config in CONFIGS:
        sol = full.ikine_a(T, config)
        ik.append({"config": config, "q": vec(sol.q) if sol.success else None})
    records.append(
        {
            "name": name,
            "q": vec(q),
            "qd": vec(qd),
            "qdd": vec(qdd),
            "fkine": mat(T.A),
            "link_frames": [mat(A.A) for A in full.fkine_all(q)[1:]],
            "jacob0": mat(full.jacob0(q)),
            "jacobe": mat(full.jacobe(q)),
            "manipulability": float(full.manipulability(q)),
            "rigid": {
                "inertia": mat(rigid.inertia(q)),
                "gravload": vec(rigid.gravload(q)),
                "coriolis": mat(rigid.coriolis(q, qd)),
                "rne": vec(rigid.rne(q, qd, qdd)),
                "accel": vec(rigid.accel(q, qd, rigid.rne(q, qd, qdd))),
            },
            "full": {
                "inertia": mat(full.inertia(q)),
                "rne": vec(full.rne(q, qd, qdd)),
                # the torque that produces qdd in the full model, fed back through forward dynamics
                "accel_of_rne": vec(full.accel(q, qd, full.rne(q, qd, qdd))),
            },
            "ik": ik,
        }
    )

OUT.parent.mkdir(parents=True, exist_ok=True)
OUT.write_text(
    json.dumps(
        {
            "source": f"roboticstoolbox-python {rtb.__version__}, models.DH.Puma560, gravity {vec(full.gravity)}",
            "cases": records,
        },
        indent=1,
    )
)
print(f"wrote {len(records)} cases to {OUT}")
