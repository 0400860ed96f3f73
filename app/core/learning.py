"""Iterative learning of the gravity torque for regulation (De Luca's scheme): a PD law plus a
constant feedforward u_{i-1}, updated at each rest configuration q_i reached,

    u = K_P (q_d - q) - K_D q' + u_{i-1},     u_i = u_{i-1} + K_P (q_d - q_i),   u_0 = 0.

Each rest configuration solves g(q_i) = K_P (q_d - q_i) + u_{i-1}. With alpha >= ||dg/dq|| and
k_P = k'_P / beta, k'_P > alpha, beta <= 1/2 (so k_P > 2 alpha suffices), the errors contract:
||e_i|| < beta/(1 - beta) ||e_{i-1}||, and u_i -> g(q_d).

>>> import numpy as np
>>> run = iterate(lambda q: 98.1 * np.sin(q), np.array([500.0]), np.array([np.pi / 3]), np.array([0.0]),
...               98.1, 0.01)
>>> run.i_min, f"{run.q_iterates[1][0]:.4f}", f"{run.u_iterates[1][0]:.4f}"
(4, '0.8942', '76.4904')
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, List, Optional

import numpy as np
import sympy as sp

from .errors import UserError
from .numeric import numeric_function


class LearningError(UserError):
    """The scheme cannot be run (no rest configuration found, bad sizes)."""


@dataclass
class LearningRun:
    alpha: float
    converges: bool
    beta: float
    contraction: float
    e_bounds: List[float]
    i_min: Optional[int]
    q_iterates: List[np.ndarray]
    e_iterates: List[float]
    u_iterates: List[np.ndarray]
    u_true: np.ndarray


def gradient_bound(dg: sp.Matrix, robot, values, samples: int = 2000, seed: int = 0) -> float:
    """Largest spectral norm of dg/dq over random configurations and the grid corners (numeric)."""
    subs = {p.symbol: float(v) for p, v in zip(robot.parameters.values(), robot.parameter_values(values).values())}
    f = numeric_function([list(robot.q)], dg.xreplace(subs), "numpy")
    rng = np.random.default_rng(seed)
    best = 0.0
    for _ in range(samples):
        q = rng.uniform(-math.pi, math.pi, robot.n)
        best = max(best, float(np.linalg.norm(np.atleast_2d(np.asarray(f(q), float)), 2)))
    for q in ([0.0] * robot.n, [math.pi] * robot.n):
        best = max(best, float(np.linalg.norm(np.atleast_2d(np.asarray(f(np.array(q)), float)), 2)))
    return best


def default_beta(kp_min: float, alpha: float) -> float:
    """The smallest unit fraction 1/N with k_P / N > alpha (the design value beta of the proof)."""
    N = math.floor(kp_min / alpha) if alpha > 0 else 2
    if N * alpha >= kp_min:
        N -= 1
    return 1.0 / max(N, 1)


def iterate(g: Callable, kp: np.ndarray, q_d: np.ndarray, q_0: np.ndarray, alpha: float, epsilon: float,
            beta: Optional[float] = None, iterations: int = 8) -> LearningRun:
    """Run the scheme: rest configurations, feedforward torques, and the a-priori error bounds."""
    from scipy.optimize import fsolve
    kp = np.asarray(kp, float)
    beta = default_beta(float(np.min(kp)), alpha) if beta is None else float(beta)
    contraction = beta / (1 - beta)
    e0 = float(np.linalg.norm(q_d - q_0))
    bounds = [e0 * contraction ** i for i in range(iterations + 1)]
    i_min = next((i for i, b in enumerate(bounds) if i > 0 and b < epsilon), None)
    q, u = np.asarray(q_0, float), np.zeros_like(q_d, dtype=float)
    qs, us, es = [q.copy()], [u.copy()], [e0]
    for _ in range(iterations):
        def rest(x):
            return np.asarray(g(x), float).reshape(-1) - kp * (q_d - x) - u
        sol, info, ok, msg = fsolve(rest, q, xtol=1e-13, full_output=True)
        if np.max(np.abs(rest(sol))) > 1e-9 * max(1.0, float(np.max(np.abs(u)))):
            raise LearningError(f"no rest configuration found ({msg.strip()})")
        q = sol
        u = u + kp * (q_d - q)
        qs.append(q.copy())
        us.append(u.copy())
        es.append(float(np.linalg.norm(q_d - q)))
    return LearningRun(alpha, bool(np.min(kp) > 2 * alpha), beta, contraction, bounds, i_min, qs, es, us,
                       np.asarray(g(q_d), float).reshape(-1))
