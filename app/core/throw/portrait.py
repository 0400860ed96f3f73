"""Phase portraits of the reduced dynamics: theta_dot(theta) through several initial conditions,
the equilibria (gamma = 0) and their type (eq. 4.8); tests/test_throwing.py, and the Throw studio's
phase plot (tests/test_browser_throw.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, List, Optional, Sequence, Tuple

import numpy as np

from ..errors import UserError
from .config import ThrowSpec

if TYPE_CHECKING:
    from .arm import ThrowingArm


@dataclass
class Equilibrium:
    theta: float
    omega: float      # d(gamma/alpha)/dtheta at theta (eq. 4.8)
    kind: str         # "center" (omega > 0) or "saddle" (omega < 0)


@dataclass
class PhaseCurve:
    theta0: float
    theta_dot0: float
    theta: np.ndarray
    theta_dot: np.ndarray     # upper branch (+sqrt); NaN where theta_dot^2 < 0 or outside its segment


@dataclass
class PhasePortrait:
    theta: np.ndarray
    alpha: np.ndarray
    gamma: np.ndarray
    equilibria: List[Equilibrium]
    singular: List[float]      # theta where alpha changes sign
    curves: List[PhaseCurve]


def phase_portrait(arm: ThrowingArm, spec: ThrowSpec, theta_range: Optional[Tuple[float, float]] = None,
                   initial: Optional[Sequence[Tuple[float, float]]] = None, n: int = 2001) -> PhasePortrait:
    """theta_dot(theta) through several initial conditions (the integral (3.24) from each), the
    equilibria (gamma = 0) and their type from the sign of d(gamma/alpha)/dtheta (eq. 4.8).

    The reduced system has the first integral (3.24), so its equilibria are centres (omega > 0) or
    saddles (omega < 0); foci (as the thesis's section 4.3 suggests) cannot occur. Outside the
    reachable part of the range (|arccos argument| > 1) and across zeros of alpha the curves stop.
    """
    from scipy.integrate import cumulative_simpson
    from scipy.optimize import brentq

    lo, hi = theta_range or (spec.theta_b, spec.theta_e)
    if not hi > lo:
        raise UserError("the phase-portrait range must be increasing")
    theta = np.linspace(lo, hi, n)
    st = arm.constraint(spec, theta, strict=False)
    ok = np.abs(st.u[0]) <= 1.0
    a, b, c = st.alpha[2, 0], st.beta[2, 0], st.gamma[2, 0]
    a = np.where(ok, a, np.nan)
    # segments: reachable and alpha of one sign
    seg_id = np.full(n, -1)
    current = -1
    for j in range(n):
        if not ok[j] or a[j] == 0:
            continue
        if j == 0 or seg_id[j - 1] < 0 or np.sign(a[j]) != np.sign(a[j - 1]):
            current += 1
        seg_id[j] = current
    singular = [float(0.5 * (theta[j] + theta[j + 1])) for j in range(n - 1)
                if ok[j] and ok[j + 1] and np.sign(a[j]) * np.sign(a[j + 1]) < 0]

    def ratio(th):
        s = arm.constraint(spec, [th], strict=False)
        return s.gamma[2, 0, 0] / s.alpha[2, 0, 0]

    equilibria: List[Equilibrium] = []
    for j in range(n - 1):
        if seg_id[j] >= 0 and seg_id[j] == seg_id[j + 1] and np.sign(c[j]) * np.sign(c[j + 1]) <= 0 and c[j] != c[j + 1]:
            if c[j] == 0 and j > 0 and equilibria and abs(equilibria[-1].theta - theta[j]) < 1e-12:
                continue
            root = brentq(lambda th: arm.constraint(spec, [th], strict=False).gamma[2, 0, 0], theta[j], theta[j + 1],
                          xtol=1e-14)
            h = 1e-5 * max(1.0, abs(root))
            omega = (ratio(root + h) - ratio(root - h)) / (2 * h)
            equilibria.append(Equilibrium(float(root), float(omega), "center" if omega > 0 else "saddle"))
    # first integral per segment: Y e^{2 F1} + F2 = const
    F1 = np.full(n, np.nan)
    F2 = np.full(n, np.nan)
    for sid in range(current + 1):
        idx = np.flatnonzero(seg_id == sid)
        if idx.size < 3:
            continue
        th = theta[idx]
        with np.errstate(over="ignore", invalid="ignore"):
            F1[idx] = cumulative_simpson(b[idx] / a[idx], x=th, initial=0.0)
            F2[idx] = cumulative_simpson(np.exp(2 * F1[idx]) * 2 * c[idx] / a[idx], x=th, initial=0.0)
    if initial is None:
        initial = [(float(t0), 0.0) for t0 in np.linspace(lo, hi, 9)[1:-1]]
        initial.append((spec.theta_b, spec.theta_dot_b))
    curves = []
    for th0, thd0 in initial:
        j0 = int(np.clip(np.searchsorted(theta, th0), 0, n - 1))
        sid = seg_id[j0]
        out = np.full(n, np.nan)
        if sid >= 0:
            idx = np.flatnonzero(seg_id == sid)
            f1 = np.interp(th0, theta[idx], F1[idx])
            f2 = np.interp(th0, theta[idx], F2[idx])
            with np.errstate(over="ignore", invalid="ignore"):
                const = thd0 ** 2 * np.exp(2 * f1) + f2
                Y = (const - F2[idx]) * np.exp(-2 * F1[idx])
            out[idx] = np.where(np.isfinite(Y) & (Y >= 0), np.sqrt(np.abs(Y)), np.nan)
        curves.append(PhaseCurve(float(th0), float(thd0), theta, out))
    return PhasePortrait(theta, a, c, equilibria, singular, curves)


