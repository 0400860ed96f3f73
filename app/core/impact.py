"""Instantaneous impacts of a mechanical system on a contact.

When the gap phi(q) closes, an impulsive force along its gradient J = dphi/dq changes the
velocities in no time: M (q'+ - q'-) = J^T Lambda, and a restitution coefficient e relates the
normal velocities, J q'+ = -e J q'- (e = 1: elastic, the kinetic energy is kept; e = 0: plastic).
Hence Lambda = -(1 + e) (J M^-1 J^T)^-1 J q'-.

>>> import sympy as sp
>>> m1, m2, v0 = sp.symbols("m1 m2 v0", positive=True)
>>> r = impact(sp.diag(m1, m2), sp.Matrix([[-1, 1]]), sp.Matrix([v0, 0]))
>>> r.dq_after.T
Matrix([[v0*(m1 - m2)/(m1 + m2), 2*m1*v0/(m1 + m2)]])
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .errors import UserError


class ImpactError(UserError):
    """An impact that cannot be computed (no gap, singular contact inertia)."""


@dataclass
class Impact:
    dq_after: sp.Matrix
    impulse: sp.Matrix
    energy_loss: sp.Expr
    momentum_change: sp.Expr


def impact(M: sp.Matrix, J: sp.Matrix, dq_before: sp.Matrix, restitution=1) -> Impact:
    """Velocities after an impact (see the module docstring)."""
    if all(x == 0 for x in J):
        raise ImpactError("the gap does not depend on the coordinates")
    Minv = M.inv()
    K = (J * Minv * J.T).applyfunc(sp.simplify)
    if sp.simplify(K.det()) == 0:
        raise ImpactError("the contact inertia J M^-1 J^T is singular")
    impulse = (-(1 + restitution) * K.inv() * J * dq_before).applyfunc(sp.factor)
    dq_after = (dq_before + Minv * J.T * impulse).applyfunc(sp.factor)
    loss = sp.factor(sp.simplify(((dq_before.T * M * dq_before)[0] - (dq_after.T * M * dq_after)[0]) / 2))
    momentum = sp.simplify(sum(M * (dq_after - dq_before)))
    return Impact(dq_after, impulse, loss, momentum)
