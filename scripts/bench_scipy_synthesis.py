#!/usr/bin/env python3
"""For scale beside `cargo bench -p vservo-control`: the same gain synthesis in numpy/scipy.

    python3 -m venv /tmp/sci && /tmp/sci/bin/pip install numpy scipy
    /tmp/sci/bin/python scripts/bench_scipy_synthesis.py

Times the whole synthesis for the paper's four points (image Jacobian, SVD, Q_c, DARE, K) and
scipy.linalg.solve_discrete_are alone; prints medians of 15 repeats.
"""

import statistics
import timeit

import numpy as np
from scipy.linalg import solve_discrete_are

F_PX, CX, CY, PERIOD_S = 500.0, 256.0, 256.0, 0.085
XI_D = np.array([151, 168, 318, 178, 339, 75, 172, 70], dtype=float)
Z_D = np.full(4, 0.5)
Q = 300.0 * np.eye(8)
R_SI = np.diag([1.0, 1.0, 1.0, 6.0, 6.0, 6.0]) * 1e6


def synthesis():
    rows = []
    for i in range(4):
        x, y, z = XI_D[2 * i] - CX, XI_D[2 * i + 1] - CY, Z_D[i]
        rows.append([-F_PX / z, 0, x / z, x * y / F_PX, -(x * x + F_PX * F_PX) / F_PX, y])
        rows.append([0, -F_PX / z, y / z, (y * y + F_PX * F_PX) / F_PX, -x * y / F_PX, -x])
    b = PERIOD_S * np.array(rows)
    u, sigma, vt = np.linalg.svd(b)
    s1 = u[:, :6].T
    b_c = np.diag(sigma) @ vt
    q_c = s1 @ Q @ s1.T
    p = solve_discrete_are(np.eye(6), b_c, q_c, R_SI)
    k_c = np.linalg.solve(R_SI + b_c.T @ p @ b_c, b_c.T @ p)
    return k_c @ s1


b_c = np.diag([198.8, 192.5, 32.2, 17.0, 2.31, 1.98])
q_c = 300.0 * np.eye(6)
for name, call in [("whole synthesis", synthesis), ("solve_discrete_are alone", lambda: solve_discrete_are(np.eye(6), b_c, q_c, R_SI))]:
    number = 200
    runs = timeit.repeat(call, number=number, repeat=15)
    print(f"{name:26s} median {statistics.median(runs) / number * 1e6:8.1f} µs")
