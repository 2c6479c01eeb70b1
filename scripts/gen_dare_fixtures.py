#!/usr/bin/env python3
"""Independent reference values for vservo-control's gain design, computed with numpy and scipy.

Writes crates/vservo-control/tests/fixtures/dare_scipy.json:
- "paper": the paper's design for the default configuration (docs/REPRODUCTION.md): B = T·J⁺(ξ_d, Z_d), its SVD,
  Q_c, the DARE solution P from scipy.linalg.solve_discrete_are, K_c and K; also the delay-augmented
  design for a one-frame delay;
- "general": DAREs with A ≠ I (random, stabilizable), solved by scipy.

    python3 -m venv /tmp/sci && /tmp/sci/bin/pip install numpy scipy
    /tmp/sci/bin/python scripts/gen_dare_fixtures.py
"""

import json
import pathlib

import numpy as np
import scipy
from scipy.linalg import solve_discrete_are

OUT = pathlib.Path(__file__).resolve().parent.parent / "crates/vservo-control/tests/fixtures/dare_scipy.json"

F_PX, CX, CY = 500.0, 256.0, 256.0
PERIOD_S = 0.085
XI_D = np.array([151, 168, 318, 178, 339, 75, 172, 70], dtype=float)
Z_D = np.full(4, 0.5)
Q = 300.0 * np.eye(8)
R_MM = np.diag([1.0, 1.0, 1.0, 6.0, 6.0, 6.0])
R_SI = R_MM * 1000.0**2  # R is written for mm/s and mrad/s


def image_jacobian(xi, z):
    rows = []
    for i in range(4):
        x, y = xi[2 * i] - CX, xi[2 * i + 1] - CY
        f, zi = F_PX, z[i]
        rows.append([-f / zi, 0, x / zi, x * y / f, -(x * x + f * f) / f, y])
        rows.append([0, -f / zi, y / zi, (y * y + f * f) / f, -x * y / f, -x])
    return np.array(rows)


def lq_gain(a, b, q, r):
    p = solve_discrete_are(a, b, q, r)
    k = np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)
    return p, k


B = PERIOD_S * image_jacobian(XI_D, Z_D)
U, sigma, Vt = np.linalg.svd(B)  # full U: 8 x 8
S1 = U[:, :6].T
Bc = np.diag(sigma) @ Vt
Qc = S1 @ Q @ S1.T
P, Kc = lq_gain(np.eye(6), Bc, Qc, R_SI)
K = Kc @ S1

# delay-augmented, one frame: x = [xi_c(k-1); u(k-1)]
A_aug = np.block([[np.eye(6), Bc], [np.zeros((6, 6)), np.zeros((6, 6))]])
B_aug = np.vstack([np.zeros((6, 6)), np.eye(6)])
Q_aug = np.block([[Qc, np.zeros((6, 6))], [np.zeros((6, 6)), np.zeros((6, 6))]])
P_aug, K_aug = lq_gain(A_aug, B_aug, Q_aug, R_SI)

rng = np.random.default_rng(1996)
general = []
for n, m in [(3, 1), (4, 2), (6, 3), (12, 6)]:
    a = rng.normal(size=(n, n)) * 0.6
    b = rng.normal(size=(n, m))
    g = rng.normal(size=(n, n))
    q = g @ g.T + 0.1 * np.eye(n)
    h = rng.normal(size=(m, m))
    r = h @ h.T + 0.5 * np.eye(m)
    p, k = lq_gain(a, b, q, r)
    general.append({"a": a.tolist(), "b": b.tolist(), "q": q.tolist(), "r": r.tolist(), "p": p.tolist(), "k": k.tolist()})

OUT.parent.mkdir(parents=True, exist_ok=True)
OUT.write_text(
    json.dumps(
        {
            "source": f"numpy {np.__version__}, scipy {scipy.__version__} solve_discrete_are",
            "paper": {
                "b": B.tolist(),
                "singular_values": sigma.tolist(),
                "q_c": Qc.tolist(),
                "p": P.tolist(),
                "k_c": Kc.tolist(),
                "k": K.tolist(),
                "eig_abs": sorted(np.abs(np.linalg.eigvals(np.eye(8) - B @ K)).tolist(), reverse=True),
                "delay1_p": P_aug.tolist(),
                "delay1_k": K_aug.tolist(),
            },
            "general": general,
        },
        indent=1,
    )
)
print(f"wrote {OUT}")
