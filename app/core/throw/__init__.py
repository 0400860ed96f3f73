"""Throws of the three-link arm with a passive spring wrist, planned with virtual holonomic
constraints (VHC), after Lillehammer (NTNU 2014), chapters 3-4; docs/throwing.md.

The ball's position along an axis through the shoulder, rotated by the release angle psi, is the
path coordinate (eq. 3.12)::

    theta = l1 cos(q1 - psi) + l2 cos(q1 + q2 - psi) + l3 cos(q1 + q2 + q3 - psi)

The actuated joints follow Bezier polynomials q1 = phi1(theta), q2 = phi2(theta) of any degree in
s = (theta - theta_b) / (theta_e - theta_b) (eqs. 4.1, 4.2); the wrist angle follows from (3.12)
(eq. 3.14, printed "+" branch by default). Everything is vectorized over nodes and over batches of
throws (the optimizer's finite differences are one call).

Modules, each importing only those above it:

- ``bezier``: Bernstein bases, degree elevation, piecewise Chebyshev quadrature
- ``config``: ``ThrowSpec``, ``SpecBatch``, ``ThrowConfig`` and the throw files, ``VHCError``
- ``reduced``: the reduced dynamics (3.24) solved, ``Throw``, ``Release``, ``Trajectory``, ``Feasibility``
- ``arm``: ``ThrowingArm``, the model at given parameters (constraint, alpha, beta, gamma)
- ``portrait``: phase portraits and equilibria; ``simulation``: the full 3-DOF arm (``simulate_full``)
- ``optimize``: ``ThrowOptimizer``, ``speed_limit_bound``; ``thesis``: the thesis's numbers recomputed
- ``study``: one throw evaluated for display (what the Throw studio shows), the editable throw
- ``plants``, ``closed_loop``, ``montecarlo``, ``robust``, ``catch``: closed-loop throws on uncertain
  plants, their Monte-Carlo spread, the robust objective, throw and catch

>>> from app.core.throw.arm import ThrowingArm
>>> from app.core.throw.config import thesis_throw
>>> throw = ThrowingArm().solve(thesis_throw("throw1"))
>>> round(throw.theta_dot_e, 4), round(throw.duration, 4)     # reference model B
(3.7762, 0.2863)
"""
