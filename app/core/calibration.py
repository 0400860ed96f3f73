"""Kinematic calibration: the regressor of a measured point with respect to kinematic parameters
and encoder offsets, and their least-squares estimate from measured positions.

The direct kinematics p = f(q + dtheta, pi) of a point depends on kinematic parameters pi (link
lengths, DH twists, ...) and on encoder offsets dtheta added to the joint readings q. To first
order about the nominal values, p - p_nominal = Phi(q) [dpi; dtheta] with the regressor
Phi = [df/dpi, df/dq]. Stacking several experiments gives an overdetermined system solved by the
pseudoinverse; when f is linear in the parameters (e.g. link lengths with no offset), one step is
exact, otherwise the step is repeated about the new estimate (Gauss-Newton).

>>> import sympy as sp
>>> l1, l2, q1, q2 = sp.symbols("l1 l2 q1 q2")
>>> p = sp.Matrix([l1*sp.cos(q1) + l2*sp.cos(q1 + q2), l1*sp.sin(q1) + l2*sp.sin(q1 + q2)])
>>> est = least_squares_calibration(p, [l1, l2], [q1, q2], {l1: 1.0, l2: 1.0},
...                                 [([0, 0], [2.1, 0]), ([0, 1.5707963267948966], [1.1, 1.0])])
>>> [f"{v:.4f}" for v in est.values]
['1.1000', '1.0000']
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Sequence, Tuple

import numpy as np
import sympy as sp

from .numeric import numeric_function


def regressor(p: sp.Matrix, parameters: Sequence[sp.Symbol], offsets: Sequence[sp.Symbol]) -> sp.Matrix:
    """Phi = [dp/dparameters, dp/doffsets] (an offset on q_i enters like q_i itself)."""
    cols = [p.diff(s) for s in parameters] + [p.diff(s) for s in offsets]
    return sp.Matrix.hstack(*cols) if cols else sp.zeros(p.rows, 0)


def is_linear(p: sp.Matrix, unknowns: Sequence[sp.Symbol]) -> bool:
    """True when p is affine in the unknowns (every second derivative vanishes)."""
    return all(sp.simplify(p.diff(a).diff(b)) == sp.zeros(p.rows, 1) for a in unknowns for b in unknowns)


@dataclass
class Calibration:
    values: np.ndarray                 # estimated parameters, then offsets
    delta: np.ndarray                  # total correction from the nominal values
    stacked_regressor: np.ndarray      # Phi of the first step, experiments stacked
    stacked_error: np.ndarray          # measured - nominal positions, stacked
    rank: int
    iterations: int
    residual: float                    # norm of measured - estimated positions
    history: List[np.ndarray] = field(default_factory=list)


def least_squares_calibration(p: sp.Matrix, unknowns, coordinates, nominal: Dict[sp.Symbol, float],
                              experiments: Sequence[Tuple[Sequence[float], Sequence[float]]],
                              max_iterations: int = 20, tol: float = 1e-12) -> Calibration:
    """Least-squares estimate of the ``unknowns`` of p(q, unknowns) (kinematic parameters, and
    encoder offsets written into p as q_i + delta_i) from experiments (q, measured p), starting
    from ``nominal`` (which also holds every other number p needs; missing unknowns start at 0)."""
    unknowns, coordinates = list(unknowns), list(coordinates)
    fixed = {k: v for k, v in nominal.items() if k not in unknowns}
    f = numeric_function([coordinates, unknowns], p.subs(fixed), "numpy")
    Phi_f = numeric_function([coordinates, unknowns], p.jacobian(unknowns).subs(fixed), "numpy")

    def stacked(x):
        Phi = np.vstack([np.atleast_2d(np.array(Phi_f(list(q), list(x)), dtype=float)) for q, _ in experiments])
        err = np.concatenate([np.asarray(pm, float) - np.array(f(list(q), list(x)), dtype=float).reshape(-1)
                              for q, pm in experiments])
        return Phi, err

    x0 = np.array([float(nominal.get(s, 0.0)) for s in unknowns])
    x, first, history = x0.copy(), None, [x0.copy()]
    for it in range(1, max_iterations + 1):
        Phi, err = stacked(x)
        first = first or (Phi, err)
        step = np.linalg.pinv(Phi) @ err
        x = x + step
        history.append(x.copy())
        if np.linalg.norm(step) <= tol * max(1.0, np.linalg.norm(x)):
            break
    res = stacked(x)[1]
    return Calibration(x, x - x0, first[0], first[1], int(np.linalg.matrix_rank(first[0])), it,
                       float(np.linalg.norm(res)), history)


def transform_derivative(A: sp.Matrix, parameter: sp.Symbol) -> sp.Matrix:
    """d A / d parameter of a homogeneous transform (e.g. a DH matrix and its twist alpha)."""
    return A.diff(parameter).applyfunc(sp.simplify)
