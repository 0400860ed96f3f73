"""Speed of the throw model and of the optimizer, measured in the same process.

Baseline ("naive quadrature"): what the thesis describes in section 4.2, written plainly: a uniform
grid of N points in theta, the constraint and alpha, beta, gamma evaluated point by point with the
lab's compiled model (NumericModel.M, NumericModel.C, one call per point), and cumulative trapezoids
for the two integrals of (4.7). Ours: ``ThrowingArm.solve`` (adaptive piecewise Chebyshev in sigma,
vectorized), and the optimizer's batched fixed-mesh evaluation (one call for a throw and its
finite-difference neighbours). Accuracy is against the converged theta_dot at release.

Run: ``python -m benchmarks.throw``; ``figures()`` (for ``python -m benchmarks``): the optimizer's
issue-16 goal, the default budget reaching a throw of at least 2.95 m within 10 s on 2 cores.
"""
from __future__ import annotations

import math
import time

import numpy as np

from app.core.numeric import NumericModel
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import thesis_throw
from app.core.throw.optimize import DEFAULT_EVALUATIONS, ThrowOptimizer


def naive_theta_dot_e(arm: ThrowingArm, spec, N: int) -> float:
    """theta_dot at release from (4.7) on a uniform grid, one model call per grid point."""
    num = NumericModel(arm.robot, {**arm.values, "k": spec.k})
    theta = np.linspace(spec.theta_b, spec.theta_e, N)
    st = arm.constraint(spec, theta, dynamics=False)
    q, d1, d2 = st.q[:, 0, :], st.dq[:, 0, :], st.ddq[:, 0, :]
    a = np.empty(N)
    b = np.empty(N)
    c = np.empty(N)
    for j in range(N):
        M = num.M(q[:, j])
        a[j] = M[2] @ d1[:, j]
        b[j] = M[2] @ d2[:, j] + (num.C(q[:, j], d1[:, j]) @ d1[:, j])[2]
        c[j] = num.g(q[:, j])[2] + num.spring(q[:, j])[2]
    h = np.diff(theta)
    I1 = np.concatenate([[0.0], np.cumsum(0.5 * h * (b[1:] / a[1:] + b[:-1] / a[:-1]))])
    f = np.exp(2 * I1) * 2 * c / a
    I2 = np.concatenate([[0.0], np.cumsum(0.5 * h * (f[1:] + f[:-1]))])
    Y = np.exp(-2 * I1) * (spec.theta_dot_b ** 2 - I2)
    return math.sqrt(Y[-1])


def per_second(fn, min_time: float = 1.0) -> tuple:
    count, t0 = 0, time.perf_counter()
    while True:
        out = fn()
        count += 1
        elapsed = time.perf_counter() - t0
        if elapsed >= min_time:
            return count / elapsed, out


def main(evaluations: int = DEFAULT_EVALUATIONS) -> None:
    arm = ThrowingArm()
    print("throw model: throws evaluated per second (theta_dot at release and everything it needs)")
    print(f"{'throw':8s} {'method':44s} {'throws/s':>10s} {'|error| of theta_dot_e [m/s]':>30s}")
    for name in ("throw1", "throw2"):
        spec = thesis_throw(name)
        exact = arm.solve(spec, tol=1e-14).theta_dot_e
        rows = []
        for N in (100, 1000, 10000):
            rate, val = per_second(lambda: naive_theta_dot_e(arm, spec, N), 0.5)
            rows.append((f"naive: uniform trapezoid, N = {N}, per point", rate, abs(val - exact)))
        rate, val = per_second(lambda: arm.solve(spec).theta_dot_e)
        rows.append(("ours: adaptive Chebyshev (ThrowingArm.solve)", rate, abs(val - exact)))
        opt = ThrowOptimizer(arm, degree=len(spec.a) - 1)
        X = np.repeat(opt.to_vector(spec)[None], 25, axis=0)
        rate, _ = per_second(lambda: opt.evaluate(X))
        rows.append(("ours: optimizer batch of 25 (fixed mesh, all limits)", 25 * rate, float("nan")))
        for label, rate, err in rows:
            err_s = "-" if math.isnan(err) else f"{err:.1e}"
            print(f"{name:8s} {label:44s} {rate:10.1f} {err_s:>30s}")
    print()
    print(f"optimizer (seed 0, budget {evaluations} throw evaluations, objective thesis convention), twice "
          f"(the second run must give the identical throw):")
    results = []
    for run in range(2):
        t0, c0 = time.perf_counter(), time.process_time()
        res = ThrowOptimizer(arm).run(seed=0, evaluations=evaluations)
        total, cpu = time.perf_counter() - t0, time.process_time() - c0
        first = next((t for t, d in res.history if d >= 2.95), float("nan"))
        first_ev = next((e for e, d in res.evaluation_history if d >= 2.95), -1)
        results.append(res)
        print(f"  run {run + 1}: best {res.distance_from_base:.4f} m from the base (speed-limit bound "
              f"{res.bound.distance_from_base:.4f} m), feasible on the dense grid: {res.feasibility.feasible}")
        print(f"    total {total:.1f} s wall ({cpu:.1f} s CPU; target <= 10 s on 2 cores), first throw >= 2.95 m "
              f"(on the optimizer's mesh) after {first:.1f} s and {first_ev} evaluations, best after "
              f"{res.evaluation_history[-1][0]} evaluations, {res.local_runs} local runs, {res.evaluations} throw "
              f"evaluations ({res.evaluations / res.elapsed:.0f} per second)")
    same = np.array_equal(results[0].throw.spec.a, results[1].throw.spec.a) and \
        results[0].distance_from_base == results[1].distance_from_base
    print(f"  identical throw in both runs: {same}")


def figures(evaluations: int = DEFAULT_EVALUATIONS) -> list:
    """The optimizer with seed 0 and the default budget: wall seconds until its first throw of at
    least 2.95 m (on its mesh) and for the whole run (CPU beside), each against the 10 s goal."""
    arm = ThrowingArm()
    t0, c0 = time.perf_counter(), time.process_time()
    res = ThrowOptimizer(arm).run(seed=0, evaluations=evaluations)
    total, cpu = time.perf_counter() - t0, time.process_time() - c0
    first = next((t for t, d in res.history if d >= 2.95), float("inf"))
    first_ev = next((e for e, d in res.evaluation_history if d >= 2.95), -1)
    return [("throw optimizer: first throw >= 2.95 m (seed 0)", first, None, 10.0,
             f"after {first_ev} of {res.evaluations} throw evaluations"),
            ("throw optimizer: whole run, default budget (seed 0)", total, cpu, 10.0,
             f"best {res.distance_from_base:.4f} m after {res.evaluation_history[-1][0]} evaluations")]


if __name__ == "__main__":
    main()
