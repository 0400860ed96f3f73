"""Ballistic flight of a released ball (no air drag): landing point, flight time, best angle.

Heights are measured from the ground the ball lands on (y = 0), distances along x. These are the
thesis's eqs. (3.2)-(3.5) written for any sign of the horizontal velocity (the printed (3.4) holds
for x' > 0 only, and (3.3) has a typo: its first y_r is the vertical velocity).

>>> round(float(landing_distance(0.0, 30.0, 4 * math.cos(math.radians(10)), 4 * math.sin(math.radians(10)))), 4)
10.025
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Tuple

import numpy as np

from .errors import UserError

G_DEFAULT = 9.81


def flight_time(y0, vy, g: float = G_DEFAULT):
    """Time until a ball released at height y0 (>= 0) with vertical speed vy hits y = 0 [s].

    >>> round(float(flight_time(0.0, 9.81)), 6)
    2.0
    """
    y0 = np.asarray(y0, dtype=float)
    vy = np.asarray(vy, dtype=float)
    if np.any(y0 < 0):
        raise UserError(f"release height {np.min(y0):.4g} m is below the ground")
    return (vy + np.sqrt(vy * vy + 2.0 * g * y0)) / g


def landing_distance(x0, y0, vx, vy, g: float = G_DEFAULT):
    """x where the ball released at (x0, y0) with velocity (vx, vy) lands on y = 0 (eq. 3.4) [m].

    The distance from the release point (eq. 3.5) is this minus x0. Works elementwise on arrays.

    >>> round(float(landing_distance(0.0, 0.0, 1.0, 1.0)), 6)   # 45 degrees from the ground: v^2/g
    0.203874
    """
    return np.asarray(x0, dtype=float) + np.asarray(vx, dtype=float) * flight_time(y0, vy, g)


@dataclass(frozen=True)
class Flight:
    """A ballistic flight: release point and velocity, landing point, apex, flight time."""
    release: Tuple[float, float]
    velocity: Tuple[float, float]
    g: float

    @property
    def time(self) -> float:
        return float(flight_time(self.release[1], self.velocity[1], self.g))

    @property
    def landing_x(self) -> float:
        """Distance of the landing point from x = 0 (the robot's base) [m]."""
        return float(landing_distance(*self.release, *self.velocity, self.g))

    @property
    def distance_from_release(self) -> float:
        return self.landing_x - self.release[0]

    def position_at(self, t) -> np.ndarray:
        """Ball position(s) (x, y) [m] at time(s) t [s] after the release, shape (..., 2). From the
        flight time on, the ball lies at its landing point: y is exactly 0 there, not a rounding of it.

        >>> flight = Flight((0.0, 1.0), (1.0, 0.0), 9.81)
        >>> [f"{v:.6f}" for v in flight.position_at(0.2)], bool(flight.position_at(5.0)[1] == 0)
        (['0.200000', '0.803800'], True)
        """
        t = np.minimum(np.asarray(t, dtype=float), self.time)
        x = self.release[0] + self.velocity[0] * t
        y = np.where(t < self.time, self.release[1] + self.velocity[1] * t - 0.5 * self.g * t * t, 0.0)
        return np.stack([x, y], axis=-1)

    def path(self, n: int = 100) -> np.ndarray:
        """(n, 2) points of the parabola from release to landing (the last one on the ground).

        >>> Flight((0.0, 1.0), (1.0, 0.0), 9.81).path(3)[-1].round(6).tolist()    # on the ground: y exactly 0
        [0.451524, 0.0]
        """
        return self.position_at(np.linspace(0.0, self.time, n))


def best_angle(speed: float, height: float, g: float = G_DEFAULT) -> Tuple[float, float]:
    """Release angle [rad] that throws farthest from height ``height`` at ``speed``, and that distance.

    Closed form: sin(angle) = v / sqrt(2 (v^2 + g h)).

    >>> a, d = best_angle(4.0, 30.0)
    >>> round(math.degrees(a), 2), round(d, 3)
    (9.24, 10.026)
    """
    angle = math.asin(speed / math.sqrt(2.0 * (speed * speed + g * height)))
    return angle, float(landing_distance(0.0, height, speed * math.cos(angle), speed * math.sin(angle), g))


def angle_table(speed: float, height: float, angles_deg: Sequence[float], g: float = G_DEFAULT):
    """Distances [m] for release angles [deg] at one speed and height (the thesis's Table 3.1).

    >>> [round(d, 4) for d in angle_table(4.0, 30.0, [45, 0])]
    [7.8578, 9.8924]
    """
    a = np.radians(np.asarray(angles_deg, dtype=float))
    return [float(d) for d in landing_distance(0.0, height, speed * np.cos(a), speed * np.sin(a), g)]
