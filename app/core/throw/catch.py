"""Throw and catch: the throwing arm throws (a closed-loop throw in full dynamics on a plant,
app/core/throw/closed_loop.py), a camera sees the ball in flight (noisy positions at a given rate), a
filter estimates the flight, and the catching arm (app/core/catching.py) plans its catch from that
estimate, never from the true release state, and moves there.

- The catcher stands on the ground at ``base_x``, placed before the throw: by default 0.5 m beyond the
  landing point of the *plan* (what the thrower intends), as in ``catching.catch_scene``.
- Camera: positions of the ball every 1 / ``rate`` seconds from the release, each with Gaussian noise
  of standard deviation ``noise`` [m] per axis, for ``observe`` seconds.
- Filter: the least-squares fit of the ballistic model with known gravity, p(t) = p0 + v0 t + (0, -g t^2/2),
  to the measurements (the estimate a Kalman filter of this model without process noise converges to).
- Catch: at the end of the observation the arm starts from its rest pose and moves with the
  coursework's synchronized trapezoids to the interception point of the *estimated* flight (the
  middle of its stay in the reachable region, ``catching.plan_catch``).
- The catcher's motion (``catcher``): ``"full"`` (the default) simulates the catching arm in its own
  full dynamics (its robot file's model derived by the engine, RK4) under computed torque + PD along
  the planned joint motion at 1 kHz, torques clipped to the file's torque limits when it has any
  (``catching.simulate_catch``); ``"kinematic"`` lets the arm follow the planned motion exactly, as in
  the coursework (for comparison).
- Outcome: the distance between the hand and the *true* ball at the planned catch time; the catch
  succeeds when it is below the cup's radius ``cup`` [m].

>>> est = fit_flight(np.array([0.0, 0.1, 0.2]), np.array([[0.5, 0.8, 1.1], [1.0, 1.35095, 1.6038]]), 9.81)
>>> [f"{v:.3f}" for v in (*est.p0, *est.v0)]
['0.500', '1.000', '3.000', '4.000']
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..catching import BallFlight, CatchError, CatchingArm, CatchRun, plan_catch, simulate_catch
from ..errors import UserError
from .closed_loop import simulate_closed_loop
from .plants import Plant
from .reduced import Throw

#: default camera: 100 frames per second, 5 mm noise per axis, 0.15 s of observation; cup radius 5 cm
CAMERA_RATE = 100.0
CAMERA_NOISE = 0.005
OBSERVE = 0.15
CUP = 0.05
REST_POSE = np.radians([30.0, 120.0, 80.0])
#: how the catching arm moves: its own full dynamics under computed torque, or its planned motion exactly
CATCHER_MODES = ("full", "kinematic")


@dataclass
class FlightEstimate:
    """The ball's estimated state at the release time (world frame, y from the ground)."""
    p0: np.ndarray
    v0: np.ndarray
    g: float
    samples: int


def fit_flight(t: np.ndarray, positions: np.ndarray, g: float) -> FlightEstimate:
    """Least-squares p0, v0 of a ballistic flight with known gravity from positions (2, n) at times t."""
    t = np.asarray(t, float)
    if t.size < 2:
        raise UserError("the camera needs at least two pictures of the ball to estimate its flight")
    A = np.stack([np.ones_like(t), t], axis=1)
    corrected = np.asarray(positions, float).copy()
    corrected[1] += 0.5 * g * t ** 2
    coef = np.linalg.lstsq(A, corrected.T, rcond=None)[0]      # rows: p0, v0; columns x, y
    return FlightEstimate(coef[0], coef[1], g, int(t.size))


@dataclass
class ThrowAndCatch:
    """One throw and its catch (world frame; times from the start of the throw)."""
    controller: str
    release_time: float
    release_position: np.ndarray
    release_velocity: np.ndarray
    estimate: FlightEstimate
    base_x: float
    camera_times: np.ndarray          # from the release [s]
    camera_positions: np.ndarray      # (2, n) measured [m]
    catch_time: Optional[float]       # from the release [s]; None when no catch could be planned
    catch_point: Optional[np.ndarray]     # planned (estimated) interception point, world frame
    hand: Optional[np.ndarray]        # the hand at the catch time, world frame
    ball: Optional[np.ndarray]        # the true ball at the catch time, world frame
    miss: float                       # |hand - ball| at the catch time [m] (inf: no catch planned)
    success: bool
    message: str
    q_start: np.ndarray
    q_catch: Optional[np.ndarray]     # planned joints at the catch
    plan: object = None               # catching.CatchPlan (joint motion from the start of the catch)
    catcher: str = "full"             # "full" (simulated in its dynamics) or "kinematic"
    run: Optional[CatchRun] = None    # the catcher's simulation (catcher "full" and a catch planned)
    q_end: Optional[np.ndarray] = None    # the catcher's joints at the catch time (simulated or planned)


def throw_and_catch(throw: Throw, plant: Optional[Plant] = None, controller: str = "transverse",
                    rate: float = CAMERA_RATE, noise: float = CAMERA_NOISE, observe: float = OBSERVE,
                    cup: float = CUP, base_x: Optional[float] = None, seed: int = 0,
                    catcher: Optional[CatchingArm] = None, release=None, catcher_mode: str = "full",
                    catcher_plant: Optional[dict] = None) -> ThrowAndCatch:
    """Throw ``throw`` on ``plant`` under ``controller`` (full dynamics), watch the ball with a noisy
    camera, estimate its flight and catch it with the catching arm (see the module's docstring).

    ``release`` = (position, velocity, time) skips the throw's simulation (a release computed before).
    ``catcher_mode``: ``"full"`` or ``"kinematic"``; ``catcher_plant``: parameter values of the
    simulated catching arm that differ from its controller's model (full mode only)."""
    if catcher_mode not in CATCHER_MODES:
        raise UserError(f"unknown catcher mode '{catcher_mode}' (full or kinematic)")
    if not rate > 0 or not observe > 0 or noise < 0 or not cup > 0:
        raise UserError("the camera rate, the observation time and the cup radius must be positive, the noise >= 0")
    catcher = catcher or CatchingArm()
    g = throw.arm.g
    if release is None:
        run = simulate_closed_loop(throw, controller, plant or Plant(), seed=seed)
        if not run.released[0]:
            raise CatchError(f"the throw ({controller}) never released the ball")
        release = (run.release_position[:, 0], run.release_velocity[:, 0], float(run.release_time[0]))
    pos, vel, t_release = (np.asarray(release[0], float), np.asarray(release[1], float), float(release[2]))
    truth = BallFlight.from_release(pos, vel, g)
    if base_x is None:
        planned = BallFlight.from_release(throw.release.position, throw.release.velocity, g)
        base_x = float(planned.position(planned.landing_time())[0]) + 0.5
    rng = np.random.default_rng(seed)
    land = truth.landing_time()
    times = np.arange(0.0, min(observe, land) + 1e-12, 1.0 / rate)
    measured = truth.position(times) + noise * rng.normal(size=(2, times.size))
    est = fit_flight(times, measured, g)
    # the estimated flight seen from the catcher's base, from the moment the arm starts (end of observation)
    t_start = float(times[-1])
    p_start = est.p0 + est.v0 * t_start + np.array([0.0, -0.5 * g * t_start ** 2])
    v_start = est.v0 + np.array([0.0, -g * t_start])
    seen = BallFlight.from_release(p_start, v_start, g, origin=(base_x, 0.0))
    common = dict(controller=controller, release_time=t_release, release_position=pos, release_velocity=vel,
                  estimate=est, base_x=base_x, camera_times=times, camera_positions=measured, q_start=REST_POSE,
                  catcher=catcher_mode)
    try:
        plan = plan_catch(catcher, seen, REST_POSE)
    except CatchError as exc:
        return ThrowAndCatch(**common, catch_time=None, catch_point=None, hand=None, ball=None, miss=math.inf,
                             success=False, message=f"no catch: {exc}", q_catch=None)
    t_catch = t_start + plan.time
    run = None
    q_end = plan.q_catch
    if catcher_mode == "full":
        run = simulate_catch(catcher, plan, plant_params=catcher_plant)
        q_end = run.q_end
    hand = catcher.forward(q_end) + np.array([base_x, 0.0])
    ball = truth.position(t_catch)
    miss = float(np.hypot(*(hand - ball)))
    ok = miss <= cup and (run is None or not run.message)
    message = (f"caught: the hand is {1e3 * miss:.1f} mm from the ball" if ok else
               f"missed by {1e3 * miss:.1f} mm (cup radius {1e3 * cup:.0f} mm)")
    if run is not None and run.message:
        message = f"missed: the catching arm's simulation stopped ({run.message})"
    return ThrowAndCatch(**common, catch_time=t_catch, catch_point=plan.point + np.array([base_x, 0.0]), hand=hand,
                         ball=ball, miss=miss, success=ok, message=message, q_catch=plan.q_catch, plan=plan,
                         run=run, q_end=q_end)


def success_rate(throw: Throw, seeds: int = 200, plant: Optional[Plant] = None, controller: str = "transverse",
                 release=None, **kwargs) -> dict:
    """Catches over camera-noise seeds 0 .. seeds - 1 of one throw (simulated once, or ``release`` given):
    success rate and misses (and, with the catcher in full dynamics, its largest tracking errors)."""
    catcher = kwargs.pop("catcher", None) or CatchingArm()
    first = throw_and_catch(throw, plant, controller, seed=0, catcher=catcher, release=release, **kwargs)
    release = (first.release_position, first.release_velocity, first.release_time)
    runs = [first] + [throw_and_catch(throw, plant, controller, seed=s, catcher=catcher, release=release, **kwargs)
                      for s in range(1, seeds)]
    misses = np.array([r.miss for r in runs])
    sims = [r.run for r in runs if r.run is not None]
    cup = kwargs.get("cup", CUP)
    finite = misses[np.isfinite(misses)]
    return {"seeds": seeds, "success_rate": float(np.mean(misses <= cup)),
            "miss_median": float(np.median(finite)) if finite.size else None,
            "miss_95": float(np.quantile(finite, 0.95)) if finite.size else None,
            "planned": int(finite.size), "catcher": first.catcher,
            "tracking_error_max": max((r.tracking_error for r in sims), default=None),
            "hand_tracking_error_max": max((r.hand_tracking_error for r in sims), default=None)}
