"""The thesis's numbers recomputed (``thesis_comparison``): Table 3.1, the hand estimate of chapter
6 (``hand_estimate``) and the three printed throws.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from .arm import ThrowingArm
from .config import VHCError, load_throw_config
from .optimize import landing


@dataclass
class HandEstimate:
    """The thesis's estimate (chapter 6): arm stretched out, every joint at its speed limit."""
    speed: float                # sum of speed limit x distance to the ball [m/s]
    angle_deg: float            # release direction [deg]
    position: np.ndarray        # ball position (arm perpendicular to the release direction)
    distance_from_base: float
    best_angle_deg: float
    best_distance: float


def hand_estimate(arm: ThrowingArm, angle_deg: float = 14.0, speed: Optional[float] = None) -> HandEstimate:
    """Ball speed with the arm straight and all joints at their speed limits (or ``speed``), thrown
    at ``angle_deg`` with the arm perpendicular to the throw.

    >>> arm = ThrowingArm()
    >>> round(hand_estimate(arm).speed, 4), round(hand_estimate(arm, speed=4.18).distance_from_base, 3)
    (4.1859, 2.756)
    """
    from scipy.optimize import minimize_scalar

    v = arm.limits["speed"]
    L1, L2, L3 = arm.l1 + arm.l2 + arm.l3, arm.l2 + arm.l3, arm.l3
    speed = float(v[0] * L1 + v[1] * L2 + v[2] * L3) if speed is None else float(speed)

    def throw(angle):
        arm_angle = angle + math.pi / 2           # the arm is perpendicular to the velocity
        pos = np.array([L1 * math.cos(arm_angle), arm.shoulder_height + L1 * math.sin(arm_angle)])
        vel = speed * np.array([math.cos(angle), math.sin(angle)])
        return pos, float(landing(arm, pos, vel))

    pos, d = throw(math.radians(angle_deg))
    best = minimize_scalar(lambda a: -throw(a)[1], bounds=(0.0, math.pi / 3), method="bounded",
                           options={"xatol": 1e-10})
    return HandEstimate(speed, angle_deg, pos, d, math.degrees(best.x), -float(best.fun))


# ====================================================================== the thesis, reproduced
#: Table 3.1 as printed: release angle [deg] -> distance [m], 30 m cliff, the text says 5 m/s.
TABLE_3_1 = {45: 7.8578, 30: 9.3025, 25: 9.6120, 20: 9.8348, 15: 9.9718, 10: 10.0250, 5: 9.9974, 0: 9.8924}


def thesis_comparison(arm: Optional[ThrowingArm] = None) -> List[dict]:
    """Every number of the thesis that the lab recomputes: rows {quantity, thesis, lab, note}.

    Distances from the thesis's own release speeds use its convention (speed theta_dot along psi,
    release height from eq. 3.1 plus the 0.63 m platform); the dynamic ones use the robot file's
    mass model (reading B of Appendix A).
    """
    from ..ballistics import angle_table

    arm = arm or ThrowingArm()
    rows: List[dict] = []

    def row(quantity, thesis, lab, note=""):
        rows.append({"quantity": quantity, "thesis": thesis, "lab": lab, "note": note})

    at4 = angle_table(4.0, 30.0, list(TABLE_3_1))
    at5 = angle_table(5.0, 30.0, list(TABLE_3_1))
    for (angle, printed), d4, d5 in zip(TABLE_3_1.items(), at4, at5):
        row(f"Table 3.1, {angle} deg [m]", printed, round(d4, 5),
            f"with v = 4 m/s; the text's 5 m/s would give {d5:.4f} m")
    est = hand_estimate(arm)
    rounded = hand_estimate(arm, speed=4.18)
    row("hand estimate: ball speed, arm straight, joints at their limits [m/s]", 4.18, round(est.speed, 4))
    row("hand estimate: distance from the base at 14 deg with 4.18 m/s [m]", 2.75,
        round(rounded.distance_from_base, 4),
        f"platform included; with {est.speed:.4f} m/s it is {est.distance_from_base:.4f} m, and the best "
        f"angle is {est.best_angle_deg:.1f} deg ({est.best_distance:.4f} m)")
    for name in ("throw1", "throw2", "throw3"):
        cfg = load_throw_config(name)
        rep = cfg.thesis
        label = name.replace("throw", "throw ")
        try:
            throw = arm.solve(cfg.spec)
        except VHCError as exc:
            row(f"{label}: theta_dot at release [m/s]", rep["theta_dot_e"], None, f"rejected: {exc}")
            continue
        rel = arm.release(cfg.spec, rep["theta_dot_e"])
        ratios = np.abs(rel.dq) / arm.limits["speed"]
        if name == "throw2":
            row(f"{label}: release point x_r [m]", -0.365, round(float(rel.position[0]), 5), "kinematics only")
        if "distance_from_base" in rep:
            row(f"{label}: distance from the base, thesis's theta_dot [m]", rep["distance_from_base"],
                round(rel.distance_from_base_thesis, 4),
                f"thesis convention; with the true ball velocity J(q) q' it is {rel.distance_from_base:.4f} m")
            row(f"{label}: distance from the release point, thesis's theta_dot [m]", rep["distance_from_release"],
                round(rel.distance_from_release_thesis, 4), "thesis convention")
        row(f"{label}: joint speeds at release with the thesis's theta_dot [limit]", None,
            [round(float(r), 4) for r in ratios], "fractions of the Table A.2 limits")
        row(f"{label}: theta_dot at release [m/s]", rep["theta_dot_e"], round(throw.theta_dot_e, 4),
            "reduced dynamics with reading B; the thesis's value cannot be reproduced by any reading")
        row(f"{label}: duration [s]", rep["duration"], round(throw.duration, 4), "reading B")
    return rows
