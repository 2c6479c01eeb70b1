#!/usr/bin/env python3
"""For scale beside `cargo bench -p vservo-arm`: the Robotics Toolbox for Python's PUMA 560 on the same state.

    /tmp/rtb/bin/python scripts/bench_rtb_dynamics.py

Prints the median wall time per call of fkine, jacob0, rne (the toolbox's C implementation), inertia, accel and
ikine_a over repeated runs.
"""

import statistics
import timeit

import numpy as np
import roboticstoolbox as rtb

puma = rtb.models.DH.Puma560()
q = np.array([0.3, 0.9, -2.6, 0.4, 0.7, -0.2])
qd = np.array([0.5, -0.4, 0.3, 1.0, -0.8, 0.6])
qdd = np.array([1.0, 2.0, -1.5, 3.0, 0.5, -2.0])
tau = puma.rne(q, qd, qdd)
pose = puma.fkine(q)

calls = {
    "fkine": lambda: puma.fkine(q),
    "jacob0": lambda: puma.jacob0(q),
    "rne": lambda: puma.rne(q, qd, qdd),
    "inertia": lambda: puma.inertia(q),
    "accel": lambda: puma.accel(q, qd, tau),
    "ikine_a (one config)": lambda: puma.ikine_a(pose, "ruf"),
}
for name, call in calls.items():
    number = 200
    runs = timeit.repeat(call, number=number, repeat=15)
    print(f"{name:22s} median {statistics.median(runs) / number * 1e6:9.2f} µs")
