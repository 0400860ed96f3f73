"""The engine solves an exercise it has never seen: a robot file and an exercise file written here,
for a robot and numbers that are not shipped, solved by `python -m app solve FILE --json` without
any code change. Expected values are derived independently in this test with plain sympy."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import sympy as sp

ROOT = Path(__file__).resolve().parents[1]

# A planar RP in a vertical plane whose prismatic axis makes a constant angle gamma with link 1,
# with the slider's CoM offset by e along the axis: not in the shipped library.
ROBOT = """
name: skew_rp_test
title: RP with a skewed prismatic joint (test only)
plane: vertical
coordinates: [q1, q2]
parameters:
  m1: {value: 7.0, kind: mass}
  m2: {value: 2.5, kind: mass}
  L: {value: 0.9, kind: length}
  a: {value: 0.35, kind: com}
  e: {value: 0.1, kind: com}
  J1: {value: 0.6, kind: inertia}
  J2: {value: 0.08, kind: inertia}
  gam: {value: 1.0471975511965976, kind: angle}
  g0: {value: 9.81, kind: gravity}
gravity: [0, -g0, 0]
bodies:
  - name: arm
    joint: {type: revolute, axis: z, q: q1}
    mass: m1
    com: [a, 0, 0]
    inertia: J1
  - name: slider
    joint: {type: prismatic, axis: x, q: q2, origin: {xyz: [L, 0, 0], rpy: [0, 0, gam]}}
    mass: m2
    com: [e, 0, 0]
    inertia: J2
"""

EXERCISE = """
id: "unseen#1"
title: Skewed RP (never shipped)
robot: robot.yaml
question: Derive the model, a minimal parametrization, the equilibria, and the torque at a state.
given: {m2: 3.0, L: 1.1}
tasks:
  - kind: dynamics
  - kind: regressor
    known: [L, gam, g0]
  - kind: evaluate
    at: {q1: 0.4, q2: 0.7}
    velocity: {q1: -0.3, q2: 0.5}
    acceleration: {q1: 1.2, q2: -0.8}
"""


def independent_model():
    q1, q2, dq1, dq2 = sp.symbols("q1 q2 dq1 dq2")
    m1, m2, L, a, e, J1, J2, gam, g0 = sp.symbols("m1 m2 L a e J1 J2 gam g0")
    p1 = sp.Matrix([a * sp.cos(q1), a * sp.sin(q1)])
    axis = sp.Matrix([sp.cos(q1 + gam), sp.sin(q1 + gam)])
    p2 = sp.Matrix([L * sp.cos(q1), L * sp.sin(q1)]) + (q2 + e) * axis
    q, dq = sp.Matrix([q1, q2]), sp.Matrix([dq1, dq2])
    v1, v2 = p1.jacobian(q) * dq, p2.jacobian(q) * dq
    T = (m1 * v1.dot(v1) + m2 * v2.dot(v2) + (J1 + J2) * dq1 ** 2) / 2
    U = g0 * (m1 * p1[1] + m2 * p2[1])
    M = sp.hessian(T, dq)
    g = sp.Matrix([sp.diff(U, v) for v in q])
    syms = dict(q1=q1, q2=q2, dq1=dq1, dq2=dq2, m1=m1, m2=m2, L=L, a=a, e=e, J1=J1, J2=J2, gam=gam, g0=g0)
    return M, g, syms


def test_solve_an_exercise_never_seen(tmp_path):
    (tmp_path / "robot.yaml").write_text(ROBOT)
    (tmp_path / "exercise.yaml").write_text(EXERCISE)
    proc = subprocess.run([sys.executable, "-m", "app", "solve", str(tmp_path / "exercise.yaml"), "--json"],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    ans = out["answers"]
    M_ref, g_ref, s = independent_model()
    M = sp.Matrix([[sp.sympify(x) for x in row] for row in ans["M"]])
    g = sp.Matrix([sp.sympify(x) for x in ans["g"]])
    rename = {sp.Symbol(k): v for k, v in s.items()}
    assert sp.simplify(M.xreplace(rename) - M_ref) == sp.zeros(2, 2)
    assert sp.simplify(g.xreplace(rename) - g_ref) == sp.zeros(2, 1)
    # three inertial coefficients (J1 + J2 + m1 a^2 + m2 (L^2 + e^2 ...), m2, m2 e) and m1 a for gravity
    assert ans["regressor_count"] == 4
    # numeric torque at the given state, with the given (variant) numbers, against the independent model
    vals = dict(m1=7.0, m2=3.0, L=1.1, a=0.35, e=0.1, J1=0.6, J2=0.08, gam=np.pi / 3, g0=9.81,
                q1=0.4, q2=0.7, dq1=-0.3, dq2=0.5)
    subs = {s[k]: v for k, v in vals.items()}
    qd = sp.Matrix([s["dq1"], s["dq2"]])
    # c from the Christoffel symbols of the independent M
    q = [s["q1"], s["q2"]]
    c = sp.zeros(2, 1)
    for i in range(2):
        for j in range(2):
            for k in range(2):
                c[i] += (sp.diff(M_ref[i, j], q[k]) - sp.diff(M_ref[j, k], q[i]) / 2) * qd[j] * qd[k]
    tau_ref = (M_ref * sp.Matrix([1.2, -0.8]) + c + g_ref).subs(subs)
    assert np.allclose(np.array(ans["tau_at"], dtype=float), np.array(tau_ref, dtype=float).ravel(), rtol=1e-9)
    assert out["steps"] and all(st["latex"] or st["text"] for st in out["steps"])
