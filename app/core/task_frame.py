"""Errors in a planar task frame that rotates with the desired path (normal / tangent axes), and the
Cartesian acceleration that makes them decoupled second-order systems.

With R = R(alpha_d(t)) the task frame, e = p_d - p the error in the base frame and te = R^T e,

    te'  = R^T (e' + S^T(alpha') e),
    te'' = R^T (e'' + 2 S^T(alpha') e' + (S^T(alpha'') - D(alpha')) e),    D = alpha'^2 I,

where S(w) = [[0, -w], [w, 0]]. Imposing te'' + tK_D te' + tK_P te = 0 with p'' = a gives

    a = p''_d + R (tK_D te' + tK_P te) + 2 S^T(alpha') e' + (S^T(alpha'') - D) e
      = p''_d + K_D(t) e' + K_P(t) e,
    K_D(t) = R tK_D R^T + 2 S^T(alpha'),   K_P(t) = R tK_P R^T + R tK_D R^T S^T(alpha') + S^T(alpha'') - D.

Everything is derived here by differentiating R^T e with alpha a function of time (not typed in).

>>> f = rotating_frame_errors(["n", "t"])
>>> f.K_D_t[0, 1]        # 2 alpha' + (k_D,n - k_D,t) sin(alpha) cos(alpha)
2*dalpha_d + (k_D_n/2 - k_D_t/2)*sin(2*alpha_d)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import sympy as sp

from .expressions import symbol
from .trig import TrigPoly


def _canonical(expr):
    return TrigPoly.from_expr(sp.expand(expr)).to_expr()


def rotation2(angle) -> sp.Matrix:
    return sp.Matrix([[sp.cos(angle), -sp.sin(angle)], [sp.sin(angle), sp.cos(angle)]])


def skew2(w) -> sp.Matrix:
    return sp.Matrix([[0, -w], [w, 0]])


@dataclass
class FrameErrors:
    R: sp.Matrix
    S: sp.Matrix            # S(alpha')
    D: sp.Matrix            # alpha'^2 I
    te: sp.Matrix
    te_dot: sp.Matrix
    te_ddot: sp.Matrix
    a: sp.Matrix            # commanded Cartesian acceleration
    K_P_t: sp.Matrix
    K_D_t: sp.Matrix
    residual: sp.Matrix     # te'' + tK_D te' + tK_P te with p'' = a (identically zero)
    symbols: dict


def rotating_frame_errors(axes: Sequence[str], angle: str = "alpha_d") -> FrameErrors:
    """Task-frame error kinematics and the decoupling acceleration (see the module docstring).
    ``axes``: labels of the task axes x_t, y_t (gains k_P_<label>, k_D_<label>)."""
    t = sp.Symbol("t", real=True)
    al, dal, ddal = symbol(angle), symbol("d" + angle), symbol("dd" + angle)
    e = sp.Matrix([symbol("e_x"), symbol("e_y")])
    de = sp.Matrix([symbol("de_x"), symbol("de_y")])
    dde = sp.Matrix([symbol("dde_x"), symbol("dde_y")])
    ddp_d = sp.Matrix([symbol("ddp_dx"), symbol("ddp_dy")])
    KP = sp.diag(*[symbol(f"k_P_{a}") for a in axes])
    KD = sp.diag(*[symbol(f"k_D_{a}") for a in axes])
    # differentiate with alpha(t), e(t) as functions, then back to symbols
    alpha_f = sp.Function("alpha")(t)
    e_f = sp.Matrix([sp.Function("ex")(t), sp.Function("ey")(t)])
    te_f = rotation2(alpha_f).T * e_f
    back = {alpha_f.diff(t, 2): ddal, alpha_f.diff(t): dal, alpha_f: al}
    for k in range(2):
        back.update({e_f[k].diff(t, 2): dde[k], e_f[k].diff(t): de[k], e_f[k]: e[k]})

    def symbolic(expr):
        out = expr
        for key in sorted(back, key=lambda x: -sp.count_ops(x)):
            out = out.subs(key, back[key])
        return out.applyfunc(_canonical)
    R = rotation2(al)
    te = symbolic(te_f)
    te_dot = symbolic(te_f.diff(t))
    te_ddot = symbolic(te_f.diff(t, 2))
    # p'' = a, e'' = p''_d - a: te'' = R^T (p''_d - a) + X, so the error law fixes a linearly
    X = te_ddot.subs({dde[0]: 0, dde[1]: 0})
    a_law = (ddp_d + R * (X + KD * te_dot + KP * te)).applyfunc(_canonical)
    K_D_t = a_law.jacobian(de).applyfunc(_canonical)
    K_P_t = a_law.jacobian(e).applyfunc(_canonical)
    check = (te_ddot.subs({dde[0]: ddp_d[0] - a_law[0], dde[1]: ddp_d[1] - a_law[1]})
             + KD * te_dot + KP * te).applyfunc(_canonical)
    return FrameErrors(R, skew2(dal), dal ** 2 * sp.eye(2), te, te_dot, te_ddot, a_law, K_P_t, K_D_t, check,
                       dict(alpha=al, dalpha=dal, ddalpha=ddal, e=e, de=de, dde=dde, ddp_d=ddp_d, KP=KP, KD=KD))
