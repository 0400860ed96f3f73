"""Redundancy resolution with the robot's dynamics: the joint velocity, acceleration or torque that
realizes a task while minimizing a weighted norm.

    task:   J(q) x = r          x = q' (velocity level) or q'' (acceleration level),
                                r = x'_d (+ K (x_d - f)) or x''_d - J' q' (+ K_D e' + K_P e)
    model:  M(q) q'' + n(q, q') = tau

- min 1/2 (x - x_0)^T W (x - x_0)        ->  x = J_W^# r + (I - J_W^# J) x_0,  tau = M q'' + n
- min 1/2 (tau - tau_0)^T W (tau - tau_0)  (acceleration level) ->  with A = J M^-1 the task reads
  A tau = r + A n =: d, so tau = A_W^# d + (I - A_W^# A) tau_0 and q'' = M^-1 (tau - n).
- some joints imposed (joint-space decomposition): x_i given for i in F, the other columns solve
  J_-F x_-F = r - J_F x_F (exactly when J_-F is square).

J_W^# = W^-1 J^T (J W^-1 J^T)^-1 (full row rank). Every function works on sympy matrices (symbolic
results, full row rank assumed) and on numpy arrays (numbers; the weighted pseudoinverse then goes
through the SVD of ``redundancy.weighted_pinv``).

>>> J = np.array([[1.0, 1.0, 1.0]])
>>> res = minimum_weighted_norm(J, np.array([3.0]), np.diag([1.0, 2.0, 2.0]))
>>> np.round(res.x, 4).tolist()
[1.5, 0.75, 0.75]
>>> q1, q2 = sp.symbols("q1 q2", real=True)
>>> minimum_weighted_norm(sp.Matrix([[q2, 1]]), sp.Matrix([1])).x.applyfunc(sp.simplify).T
Matrix([[q2/(q2**2 + 1), 1/(q2**2 + 1)]])
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional

import numpy as np
import sympy as sp

from . import redundancy as red
from .errors import UserError


class DynamicRedundancyError(UserError):
    """Inconsistent data for a redundancy resolution (sizes, weights, singular matrices)."""


def _is_symbolic(*mats) -> bool:
    return any(isinstance(m, sp.MatrixBase) for m in mats if m is not None)


def _eye(n: int, symbolic: bool):
    return sp.eye(n) if symbolic else np.eye(n)


def _inv(X, symbolic: bool):
    if symbolic:
        if X.shape == (1, 1):
            return sp.Matrix([[1 / X[0, 0]]])
        return X.inv()
    try:
        return np.linalg.inv(X)
    except np.linalg.LinAlgError:
        raise DynamicRedundancyError("a matrix that must be inverted is singular (a singular configuration?)") from None


def weighted_pinv(J, W=None):
    """J_W^# = W^-1 J^T (J W^-1 J^T)^-1 (W = I: the pseudoinverse J^#).

    >>> np.round(weighted_pinv(np.array([[1.0, 1.0]]), np.diag([1.0, 3.0])), 4).ravel().tolist()
    [0.75, 0.25]
    """
    symbolic = _is_symbolic(J, W)
    if not symbolic:
        J = np.atleast_2d(np.asarray(J, float))
        if W is None:
            return red.pinv(J)
        return red.weighted_pinv(J, np.asarray(W, float))
    J = sp.Matrix(J)
    Wi = _inv(sp.Matrix(W), True) if W is not None else sp.eye(J.cols)
    return Wi * J.T * _inv(J * Wi * J.T, True)


@dataclass
class WeightedSolution:
    """x = pinv r + P x_0 and its pieces."""
    x: object
    pinv: object           # J_W^# (of the free columns, embedded in n rows)
    projector: object      # I - J_W^# J (zero rows/columns for imposed joints)
    particular: object     # J_W^# r (+ imposed joints)
    homogeneous: object    # P x_0


def minimum_weighted_norm(J, r, W=None, preferred=None, fixed: Optional[Dict[int, object]] = None) -> WeightedSolution:
    """Minimizer of 1/2 (x - x_0)^T W (x - x_0) subject to J x = r; ``fixed`` maps 0-based joint
    indices to imposed values (their columns move to the task side)."""
    symbolic = _is_symbolic(J, r, W, preferred)
    conv = (lambda X: sp.Matrix(X)) if symbolic else (lambda X: np.asarray(X, float))
    J = conv(J)
    if not symbolic:
        J = np.atleast_2d(J)
    r = conv(r).reshape(J.shape[0], 1) if symbolic else conv(r).reshape(-1)
    m, n = J.shape
    fixed = dict(fixed or {})
    bad = [i for i in fixed if not 0 <= i < n]
    if bad:
        raise DynamicRedundancyError(f"imposed joint {bad[0] + 1} does not exist (n = {n})")
    free = [j for j in range(n) if j not in fixed]
    x_fix = sp.zeros(n, 1) if symbolic else np.zeros(n)
    for i, v in fixed.items():
        x_fix[i] = v
    r_free = r - J * x_fix if symbolic else r - J @ x_fix
    Jf = J[:, free]
    Wf = None
    if W is not None:
        W = conv(W)
        Wf = W.extract(free, free) if symbolic else W[np.ix_(free, free)]
    Pinv_f = weighted_pinv(Jf, Wf)
    pinv = sp.zeros(n, m) if symbolic else np.zeros((n, m))
    P = sp.zeros(n, n) if symbolic else np.zeros((n, n))
    Pf = _eye(len(free), symbolic) - (Pinv_f * Jf if symbolic else Pinv_f @ Jf)
    for a, i in enumerate(free):
        for k in range(m):
            pinv[i, k] = Pinv_f[a, k]
        for b, j in enumerate(free):
            P[i, j] = Pf[a, b]
    particular = (pinv * r_free + x_fix) if symbolic else pinv @ r_free + x_fix
    if preferred is None:
        homogeneous = sp.zeros(n, 1) if symbolic else np.zeros(n)
    else:
        x0 = conv(preferred).reshape(n, 1) if symbolic else conv(preferred).reshape(-1)
        homogeneous = P * x0 if symbolic else P @ x0
    return WeightedSolution(particular + homogeneous, pinv, P, particular, homogeneous)


@dataclass
class TorqueSolution:
    """Acceleration-level resolution with the dynamics: q'' and tau, with the intermediate terms."""
    ddq: object
    tau: object
    solution: WeightedSolution     # of the problem actually solved (in q'' or in tau)
    A: object = None               # J M^-1 (torque objective)
    d: object = None               # r + J M^-1 n (torque objective)


def resolve_torque(J, r, M, n, objective: str = "acceleration", W=None, preferred=None,
                   fixed: Optional[Dict[int, object]] = None) -> TorqueSolution:
    """Joint acceleration and torque realizing J q'' = r with M q'' + n = tau.

    ``objective`` "acceleration": min 1/2 (q'' - q''_0)^T W (q'' - q''_0);
    "torque": min 1/2 (tau - tau_0)^T W (tau - tau_0) (``preferred`` is tau_0).

    >>> M = np.diag([2.0, 1.0]); n = np.array([1.0, 0.0]); J = np.array([[1.0, 1.0]])
    >>> s = resolve_torque(J, np.array([1.0]), M, n, "torque")
    >>> np.round(s.tau, 4).tolist(), np.round(J @ s.ddq, 6).tolist()
    ([0.6, 1.2], [1.0])
    """
    symbolic = _is_symbolic(J, r, M, n, W, preferred)
    conv = (lambda X: sp.Matrix(X)) if symbolic else (lambda X: np.asarray(X, float))
    J, M = conv(J), conv(M)
    nn = M.shape[0]
    n = conv(n).reshape(nn, 1) if symbolic else conv(n).reshape(-1)
    if objective == "acceleration":
        sol = minimum_weighted_norm(J, r, W, preferred, fixed)
        tau = M * sol.x + n if symbolic else M @ sol.x + n
        return TorqueSolution(sol.x, tau, sol)
    if objective != "torque":
        raise DynamicRedundancyError(f"objective: acceleration or torque, got {objective!r}")
    if fixed:
        raise DynamicRedundancyError("imposed joint accelerations go with the acceleration objective")
    Mi = _inv(M, symbolic)
    A = J * Mi if symbolic else np.atleast_2d(J) @ Mi
    d = (conv(r).reshape(J.shape[0], 1) + A * n) if symbolic else conv(r).reshape(-1) + A @ n
    sol = minimum_weighted_norm(A, d, W, preferred)
    ddq = Mi * (sol.x - n) if symbolic else Mi @ (sol.x - n)
    return TorqueSolution(ddq, sol.x, sol, A, d)


def kkt_minimizer(J, r, Q, h) -> np.ndarray:
    """Numeric minimizer of 1/2 x^T Q x + h^T x subject to J x = r from the optimality (KKT)
    conditions, an independent check of the closed forms (J of full row rank).

    >>> np.round(kkt_minimizer(np.array([[1.0, 1.0]]), np.array([2.0]), np.eye(2), np.zeros(2)), 6).tolist()
    [1.0, 1.0]
    """
    J = np.atleast_2d(np.asarray(J, float))
    m, n = J.shape
    K = np.block([[np.asarray(Q, float), J.T], [J, np.zeros((m, m))]])
    rhs = np.concatenate([-np.asarray(h, float).reshape(-1), np.asarray(r, float).reshape(-1)])
    try:
        return np.linalg.solve(K, rhs)[:n]
    except np.linalg.LinAlgError:
        raise DynamicRedundancyError("the optimality conditions are singular (J loses rank?)") from None
