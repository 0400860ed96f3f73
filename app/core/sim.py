"""Closed-loop simulation: a robot (the "real plant"), a controller sampled at a fixed rate with a
zero-order hold, and a fixed-step Runge-Kutta 4 integrator.

The plant is the robot's dynamics M(q) q'' + c + g + k(q) + friction = tau + tau_ext at the plant's
parameter values (which may differ from the controller's model: model mismatch), plus optional
extra viscous friction, actuator saturation, passive joints (zero torque), forces on points
(tau_ext = J^T F), compliant surfaces and rigid surfaces (a bilateral constraint whose force is
solved exactly). Forward dynamics come from pinocchio's ABA when the robot's joint variables are
its coordinates, else from the lambdified symbolic model (``ModelTerms``).

>>> res = simulate("planar_2r", "computed_torque", reference="setpoint goal=0.2,0.1",
...                q0=[0.0, 0.0], duration=1.0)
>>> res.completed, bool(abs(res.e[-1]).max() < 1e-3)
(True, True)

A run that leaves the joint limits or blows up stops with a message, keeping the samples up to
that time (here a PD far too soft to hold the throwing arm up):

>>> res = simulate("throwing_arm", "pd", gains={"Kp": 1, "Kd": 1}, q0=[1.73, 0.67, 0.63], duration=3.0)
>>> res.message.split(" at t = ")[0], res.completed
('q1 left its limits [-0.5236, 3.665]', False)
"""
from __future__ import annotations

import csv
import dataclasses
import io
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .control import ControlSetup, ControlStop, Controller, MomentumObserver, make_controller
from .errors import SimulationError, UserError  # noqa: F401 (SimulationError: public here too)
from .numeric import ModelTerms, NumericModel, PinocchioTwin, TaskPoint, resolve_point  # noqa: F401
from .robot import RobotModel, load_robot
from .sim_plant import PointForce, Surface, _Contact, _Plant  # noqa: F401 (PointForce, Surface: public here too)
from .trajectories import Reference, parse_reference

# integration steps of one run (duration x rate x substeps): the page's longest run, 120 s at
# 20 kHz, fits; more would take hours and fill the memory with samples
MAX_INTEGRATION_STEPS = 2_500_000

Progress = Optional[Callable[[float, str], Optional[bool]]]


# ====================================================================== results
@dataclass
class SimResult:
    """Arrays of a run (one row per control sample) and what produced them.

    ``q, dq, ddq, tau`` have one column per coordinate; ``ref, dref, ddref`` (the reference),
    ``actual, dactual`` (the referenced quantity: joints, a point's position, ...) and
    ``e = ref - actual``, ``de`` have one column per reference coordinate; ``internals`` maps a
    column name to the controller's (and observer's) internal signals; ``forces`` maps a contact
    to its force on the robot, ``tau_ext`` is their joint torque sum J^T F. ``message`` says why a run stopped early ('' when it completed)."""
    robot: str
    controller: str
    title: str
    law_latex: str
    gains: Dict[str, List[float]]
    reference: str
    coordinates: List[str]
    reference_names: List[str]
    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    tau: np.ndarray
    ref: np.ndarray
    dref: np.ndarray
    ddref: np.ndarray
    actual: np.ndarray
    dactual: np.ndarray
    internals: Dict[str, np.ndarray] = field(default_factory=dict)
    forces: Dict[str, np.ndarray] = field(default_factory=dict)
    force_axes: List[str] = field(default_factory=list)
    tau_ext: Optional[np.ndarray] = None           # sum of J^T F over the contacts (None: no contacts)
    contact_points: Dict[str, np.ndarray] = field(default_factory=dict)   # where each force acts (N x 3)
    surfaces: List[tuple] = field(default_factory=list)   # (point, normal (3), offset, 'rigid' or 'wall')
    task_point: Optional[str] = None               # the point of a Cartesian controller
    ref_points: Optional[np.ndarray] = None        # its reference and actual positions (N x 3, world)
    actual_points: Optional[np.ndarray] = None
    message: str = ""
    rate: float = 1000.0
    wall_time: float = 0.0
    loop_time: float = 0.0
    settings: Dict[str, str] = field(default_factory=dict)

    @property
    def completed(self) -> bool:
        return not self.message

    @property
    def e(self) -> np.ndarray:
        return self.ref - self.actual

    @property
    def de(self) -> np.ndarray:
        return self.dref - self.dactual

    @property
    def real_time_factor(self) -> float:
        """Simulated time / wall-clock time of the loop (set-up excluded: see ``wall_time``)."""
        return float(self.t[-1]) / self.loop_time if self.loop_time > 0 and len(self.t) else math.inf

    def columns(self) -> Tuple[List[str], np.ndarray]:
        """Column names and a 2-D array (one row per sample) of everything recorded."""
        names, cols = ["t"], [self.t[:, None]]
        c, r = self.coordinates, self.reference_names
        for prefix, arr, labels in (("", self.q, c), ("d", self.dq, c), ("dd", self.ddq, c),
                                    ("tau_", self.tau, c), ("ref_", self.ref, r), ("dref_", self.dref, r),
                                    ("e_", self.e, r), ("de_", self.de, r)):
            names += [f"{prefix}{x}" for x in labels]
            cols.append(arr)
        for name, arr in self.internals.items():
            names.append(name)
            cols.append(arr[:, None])
        for name, arr in self.forces.items():
            names += [f"F_{name}_{a}" for a in self.force_axes[:arr.shape[1]]]
            cols.append(arr)
        if self.tau_ext is not None:
            names += [f"tau_ext_{x}" for x in c]
            cols.append(self.tau_ext)
        return names, np.hstack(cols) if cols else np.zeros((0, 0))

    def metadata(self) -> Dict[str, str]:
        """What produced the run, as text: robot, controller, law, gains, reference, settings, status."""
        return {"robot": self.robot, "controller": self.controller, "law": self.law_latex,
                "gains": "; ".join(f"{k}={','.join(f'{x:g}' for x in v)}" for k, v in self.gains.items()),
                "reference": self.reference, "rate_hz": f"{self.rate:g}", **self.settings,
                "status": self.message or "completed"}

    def to_csv(self, target=None) -> str:
        """CSV text, a header row then one row per sample (and written to a path or file when given)."""
        names, data = self.columns()
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(names)
        for row in data:
            writer.writerow([f"{x:.9g}" for x in row])
        text = buf.getvalue()
        if target is not None:
            if hasattr(target, "write"):
                target.write(text)
            else:
                with open(target, "w", encoding="utf-8", newline="") as fh:
                    fh.write(text)
        return text


# ====================================================================== the simulation
def _vector_option(value, n: int, what: str, sign: str = "any") -> Optional[np.ndarray]:
    """One value per coordinate (or one for all); ``sign``: 'any', 'positive' or 'nonnegative'."""
    if value is None:
        return None
    arr = np.atleast_1d(np.asarray(value, dtype=float)).reshape(-1)
    if arr.size == 1:
        arr = np.full(n, arr[0])
    if arr.size != n or not np.all(np.isfinite(arr)):
        raise SimulationError(f"{what}: expected {n} finite values (one per coordinate) or one for all")
    if sign == "positive" and np.any(arr <= 0):
        raise SimulationError(f"{what}: values must be positive")
    if sign == "nonnegative" and np.any(arr < 0):
        raise SimulationError(f"{what}: values must not be negative")
    return arr


@dataclass
class SimOptions:
    """How a run is set up (``simulate``'s keyword arguments):

    - ``duration`` [s]; ``rate``: control rate in Hz (zero-order hold); the plant takes
      ``substeps`` RK4 steps per period.
    - ``q0``, ``dq0``: initial state (default: the robot file's defaults, else 0; at rest).
    - ``gains``: the controller's gains by name (when it is given by name, or set on it).
    - ``plant_params`` / ``model_params``: parameter overrides of the real plant and of the
      controller's model (model mismatch); ``viscous``: extra viscous friction of the plant
      (N m s/rad, one value or one per coordinate), unknown to the controller.
    - ``saturation``: torque bounds (one value or one per coordinate), or ``"limits"`` for the
      robot file's torque limits; ``passive``: coordinates without actuator (default: the file's).
    - ``contacts``: PointForce and Surface objects; ``observer``: K_I gain(s) of a momentum-based
      collision residual running beside the controller; ``point``: the task point of Cartesian
      controllers (default: a surface's point, else 'ee', else the robot's first point).
    - ``backend``: ``auto`` (pinocchio where it applies), ``pinocchio`` or ``symbolic``.
    - ``stop_at_limits``: stop when a coordinate leaves its position limits; any run also stops on
      NaN, or when a speed exceeds ``max_speed``.
    """
    duration: float = 2.0
    rate: float = 1000.0
    substeps: int = 1
    q0: Optional[Sequence[float]] = None
    dq0: Optional[Sequence[float]] = None
    gains: Optional[Mapping[str, float]] = None
    plant_params: Optional[Mapping[str, float]] = None
    model_params: Optional[Mapping[str, float]] = None
    viscous: object = None
    saturation: object = None
    passive: Optional[Sequence[str]] = None
    contacts: Sequence[Union[PointForce, Surface]] = ()
    observer: object = None
    point: Optional[str] = None
    backend: str = "auto"
    stop_at_limits: bool = True
    max_speed: float = 1e3


@dataclass
class _Setup:
    """Everything a run needs, checked and resolved (``_prepare``)."""
    robot: RobotModel
    opts: SimOptions
    N: int
    period: float
    q0: np.ndarray
    dq0: np.ndarray
    limits: Tuple[np.ndarray, np.ndarray]
    actuated: np.ndarray
    bounds: Optional[np.ndarray]
    viscous: Optional[np.ndarray]
    model: ModelTerms
    plant_terms: ModelTerms
    resolved: List[_Contact]
    plant: "_Plant"
    controller: Controller
    reference: Reference
    ref_names: List[str]
    obs: Optional[MomentumObserver]
    sensor: Dict[str, np.ndarray]


@dataclass
class _Record:
    """The arrays a run fills, one row per control sample."""
    t: np.ndarray
    QD: np.ndarray
    DQD: np.ndarray
    DDQD: np.ndarray
    Q: np.ndarray
    DQ: np.ndarray
    DDQ: np.ndarray
    TAU: np.ndarray
    internal_names: List[str]
    INT: Optional[np.ndarray]
    contact_names: List[str]
    FORCES: Optional[np.ndarray]
    TEXT: Optional[np.ndarray]
    CPOS: Optional[np.ndarray]
    message: str = ""
    last: int = 0
    loop_time: float = 0.0


def simulate(robot: Union[RobotModel, str], controller: Union[Controller, str], reference=None,
             options: Optional[SimOptions] = None, progress: Progress = None, **settings) -> SimResult:
    """Run ``controller`` (a Controller or its name) in closed loop on ``robot`` (a RobotModel or
    a shipped robot's name) and return the samples.

    - ``reference``: a Reference, a text such as ``"quintic goal=1,0.5 T=2"``
      (trajectories.parse_reference), or None (hold the initial value).
    - ``options``: a SimOptions, or its fields as keyword arguments (``duration=3, q0=[0, 0]``).
    - ``progress(fraction, message)``: called about 100 times; returning False stops the run.
    """
    wall0 = time.perf_counter()
    opts = dataclasses.replace(options or SimOptions(), **settings)
    s = _prepare(robot if isinstance(robot, RobotModel) else load_robot(robot), controller, reference, opts)
    rec = _run(s, progress)
    if rec.last < 0:
        raise SimulationError(rec.message or "the simulation stopped before its first sample")
    if progress is not None and not rec.message:
        progress(1.0, "done")
    return _result(s, rec, wall0)


def _steps(opts: SimOptions) -> Tuple[int, float]:
    """(control samples N, period) of a run, checked."""
    duration, rate, substeps = opts.duration, opts.rate, opts.substeps
    if not duration > 0 or not math.isfinite(duration):
        raise SimulationError(f"the duration must be a positive number of seconds, got {duration}")
    if not rate > 0 or not math.isfinite(rate):
        raise SimulationError(f"the control rate must be a positive number of Hz, got {rate}")
    if int(substeps) != substeps or substeps < 1:
        raise SimulationError(f"substeps must be a positive integer, got {substeps}")
    steps = duration * rate * substeps          # integration steps: what the run costs
    if steps > MAX_INTEGRATION_STEPS:
        raise SimulationError(f"{duration:g} s at {rate:g} Hz with {substeps} substeps is {steps:.3g} integration "
                              f"steps, more than {MAX_INTEGRATION_STEPS:.2g} (duration x rate x substeps)")
    N = int(round(duration * rate))
    if N < 1:
        raise SimulationError(f"{duration} s at {rate:g} Hz is less than one control period")
    return N, 1.0 / rate


def _initial_state(robot: RobotModel, opts: SimOptions):
    """(q0, dq0, position limits), checked."""
    n, q0, dq0 = robot.n, opts.q0, opts.dq0
    if q0 is None:
        q0 = [robot.defaults.get(c, 0.0) for c in robot.coordinates]
    if np.size(q0) != n:
        raise SimulationError(f"q0 needs {n} values ({', '.join(robot.coordinates)}), got {np.size(q0)}")
    q0 = _vector_option(q0, n, "initial configuration q0")
    dq0 = np.zeros(n) if dq0 is None else np.asarray(dq0, dtype=float).reshape(-1)
    if dq0.size != n or not np.all(np.isfinite(dq0)):
        raise SimulationError(f"dq0 needs {n} finite values ({', '.join(robot.coordinates)})")
    limits = _position_limits(robot)
    if opts.stop_at_limits:
        bad = np.flatnonzero((q0 < limits[0]) | (q0 > limits[1]))
        if bad.size:
            i = bad[0]
            raise SimulationError(f"the initial {robot.coordinates[i]} = {q0[i]:g} is outside its limits "
                                  f"[{limits[0][i]:g}, {limits[1][i]:g}]")
    return q0, dq0, limits


def _actuation(robot: RobotModel, opts: SimOptions):
    """(actuated mask, torque bounds or None), checked."""
    n, passive, saturation = robot.n, opts.passive, opts.saturation
    if passive is None:
        actuated = np.array(robot.actuated, dtype=bool)
    else:
        unknown = [p for p in passive if p not in robot.coordinates]
        if unknown:
            raise SimulationError(f"passive: unknown coordinate(s) {unknown} (the robot has {list(robot.coordinates)})")
        actuated = np.array([c not in passive for c in robot.coordinates], dtype=bool)
    if isinstance(saturation, str):
        if saturation != "limits":
            raise SimulationError(f"saturation: a number, one per coordinate, or 'limits' (got {saturation!r})")
        bounds = np.array([robot.limits[c].torque if c in robot.limits and robot.limits[c].torque else np.inf
                           for c in robot.coordinates])
        if np.all(np.isinf(bounds[actuated])):
            raise SimulationError(f"{robot.name} has no torque limits in its file; give bounds as numbers")
    else:
        bounds = _vector_option(saturation, n, "saturation (torque bounds)", "positive")
    return actuated, bounds


def _contacts(robot: RobotModel, opts: SimOptions, plant_terms: ModelTerms, q0, dq0) -> List[_Contact]:
    """The contacts resolved at the plant's parameters; a rigid one must start on its surface."""
    resolved = [_Contact(c, robot, plant_terms.values, q0) for c in opts.contacts]
    for c in resolved:
        if c.kind != "rigid":
            continue
        gap = c.n @ c.point.position(q0) - c.offset
        if abs(gap) > 1e-6:
            raise SimulationError(f"the point {c.name} is {gap * 1000:.3g} mm from the rigid surface at the start; "
                                  "start on it (or leave the offset out: the surface then passes through the point)")
        vn = c.n @ (c.point.jacobian(q0) @ dq0)
        if abs(vn) > 1e-9:
            raise SimulationError(f"the point {c.name} starts moving across the rigid surface (normal speed {vn:g} m/s)")
    return resolved


def _prepare(robot: RobotModel, controller, reference, opts: SimOptions) -> _Setup:
    """Check the options, build the controller's model and the plant, set the controller up."""
    N, period = _steps(opts)
    q0, dq0, limits = _initial_state(robot, opts)
    actuated, bounds = _actuation(robot, opts)
    viscous = _vector_option(opts.viscous, robot.n, "viscous friction", "nonnegative")
    model = ModelTerms(robot, opts.model_params, opts.backend)
    plant_terms = ModelTerms(robot, opts.plant_params, opts.backend, extra_viscous=viscous)
    resolved = _contacts(robot, opts, plant_terms, q0, dq0)
    plant = _Plant(plant_terms, resolved)
    if isinstance(controller, str):
        controller = make_controller(controller, opts.gains)
    elif opts.gains:
        controller.set_gains(opts.gains)
    task_point = opts.point
    if task_point is None:
        task_point = next((c.spec.point for c in resolved if c.kind != "force"), None)
    setup = ControlSetup(robot=robot, model=model, period=period, actuated=actuated, q0=q0, dq0=dq0,
                         make_point=lambda p: TaskPoint(robot, p, model.values), task_point=task_point,
                         surfaces=[(c.name, c.kind, getattr(c, "n", None), getattr(c, "offset", None))
                                   for c in resolved if c.kind != "force"])
    sensor: Dict[str, np.ndarray] = {}
    setup.read_force = lambda name: sensor.get(name)
    controller.setup(setup)
    ref_names = controller.reference_names
    if reference is None or isinstance(reference, str):
        reference = parse_reference(reference, controller.reference_start, ref_names)
    if not isinstance(reference, Reference):
        raise SimulationError("reference: a text like 'quintic goal=1,0.5 T=2' or a trajectories.Reference")
    if reference.n != len(ref_names):
        raise SimulationError(f"{controller.name}: the reference needs {len(ref_names)} coordinates "
                              f"({', '.join(ref_names)}), got {reference.n}")
    controller.begin(reference)
    obs = None
    if opts.observer is not None:
        obs = MomentumObserver(opts.observer)
        obs.setup(setup)
    return _Setup(robot, opts, N, period, q0, dq0, limits, actuated, bounds, viscous, model, plant_terms,
                  resolved, plant, controller, reference, ref_names, obs, sensor)


def _record(s: _Setup) -> _Record:
    """The time grid, the reference sampled once, and empty arrays for the run."""
    N, n, resolved = s.N, s.robot.n, s.resolved
    t = np.arange(N + 1) * s.period
    QD, DQD, DDQD = s.reference.sample(t)
    internal_names = list(s.controller.internal_names) + ([] if s.obs is None else list(s.obs.internal_names))
    dim = resolved[0].point.dim if resolved else 0
    return _Record(t, QD, DQD, DDQD, np.empty((N + 1, n)), np.empty((N + 1, n)), np.empty((N + 1, n)),
                   np.empty((N + 1, n)), internal_names,
                   np.empty((N + 1, len(internal_names))) if internal_names else None, [c.name for c in resolved],
                   np.zeros((N + 1, len(resolved), dim)) if resolved else None,
                   np.zeros((N + 1, n)) if resolved else None,
                   np.zeros((N + 1, len(resolved), dim)) if resolved else None, last=N)


def _run(s: _Setup, progress: Progress) -> _Record:
    """The loop: sense, control (zero-order hold), record, RK4 ``substeps`` times per period; stops
    on a singular matrix, a controller's stop, NaN, the limits, too high a speed or the user."""
    rec = _record(s)
    n, N, substeps, robot = s.robot.n, s.N, s.opts.substeps, s.robot
    t, QD, DQD, DDQD, Q, DQ, DDQ, TAU, INT = rec.t, rec.QD, rec.DQD, rec.DDQD, rec.Q, rec.DQ, rec.DDQ, rec.TAU, rec.INT
    step, accel, plant, resolved, sensor, obs = s.controller.step, s.plant.accel, s.plant, s.resolved, s.sensor, s.obs
    bounds, mask = s.bounds, (None if s.actuated.all() else s.actuated.astype(float))
    has_contacts = bool(resolved)
    ctrl_internals = s.controller.internals if s.controller.internal_names else None
    check_every, progress_every = 10, max(1, N // 100)
    x = np.concatenate((s.q0, s.dq0))
    q, dq = x[:n], x[n:]
    cat = np.concatenate
    tau = np.zeros(n)
    h = s.period / substeps
    h2, h6 = h / 2, h / 6
    loop_start = time.perf_counter()
    for k in range(N + 1):
        tk = t[k]
        try:
            if has_contacts:      # the force sensor, read before the new torque is applied
                for j, f in enumerate(plant.forces(tk, q, dq, tau)):
                    sensor[rec.contact_names[j]] = f
            tau = step(k, tk, q, dq, QD[k], DQD[k], DDQD[k])
            if bounds is not None:
                tau = np.clip(tau, -bounds, bounds)
            if mask is not None:
                tau = tau * mask
            if has_contacts:      # the contact forces acting from t_k on (with the new torque)
                _record_contacts(rec, k, plant, resolved, tk, q, dq, tau, n)
            if obs is not None:
                obs.update(q, dq, tau)
            Q[k] = q
            DQ[k] = dq
            TAU[k] = tau
            if INT is not None:
                if ctrl_internals is not None:
                    ci = ctrl_internals()
                    INT[k, :ci.size] = ci
                if obs is not None:
                    INT[k, INT.shape[1] - n:] = obs.r
            a1 = accel(q, dq, tau, tk) if has_contacts else accel(q, dq, tau)
            DDQ[k] = a1
            if k == N:
                break
            for sub in range(substeps):      # RK4 on x = (q, q'), k = (q', q'')
                ts = tk + sub * h
                if sub:
                    a1 = accel(q, dq, tau, ts) if has_contacts else accel(q, dq, tau)
                k1 = cat((dq, a1))
                x2 = x + h2 * k1
                v = x2[n:]
                k2 = cat((v, accel(x2[:n], v, tau, ts + h2) if has_contacts else accel(x2[:n], v, tau)))
                x3 = x + h2 * k2
                v = x3[n:]
                k3 = cat((v, accel(x3[:n], v, tau, ts + h2) if has_contacts else accel(x3[:n], v, tau)))
                x4 = x + h * k3
                v = x4[n:]
                k4 = cat((v, accel(x4[:n], v, tau, ts + h) if has_contacts else accel(x4[:n], v, tau)))
                x = x + h6 * (k1 + 2.0 * (k2 + k3) + k4)
                q, dq = x[:n], x[n:]
        except (np.linalg.LinAlgError, FloatingPointError, ControlStop) as exc:
            rec.message, rec.last = _stop_message(exc, tk), k - 1
            break
        if (k % check_every == check_every - 1 or k == N - 1) and _left_bounds(s, rec, k, q, dq):
            break
        if progress is not None and k % progress_every == 0:
            if progress(k / N, f"t = {tk:.2f} s") is False:
                rec.message, rec.last = f"stopped by the user at t = {tk:.3f} s", k
                break
    rec.loop_time = time.perf_counter() - loop_start
    return rec


def _record_contacts(rec: _Record, k: int, plant, resolved, tk, q, dq, tau, n: int) -> None:
    text = np.zeros(n)
    for j, f in enumerate(plant.forces(tk, q, dq, tau)):
        rec.FORCES[k, j] = f
        rec.CPOS[k, j] = resolved[j].point.position(q)
        text = text + resolved[j].joint_torque(tk, q, f)
    rec.TEXT[k] = text


def _stop_message(exc: Exception, tk: float) -> str:
    if isinstance(exc, np.linalg.LinAlgError):
        return f"stopped at t = {tk:.3f} s: a singular matrix ({exc}) - a singular configuration?"
    if isinstance(exc, FloatingPointError):
        return f"stopped at t = {tk:.3f} s: {exc}"
    return f"{exc} at t = {tk:.3f} s"


def _left_bounds(s: _Setup, rec: _Record, k: int, q, dq) -> bool:
    """Whether the state left the limits (or blew up) by sample k + 1; if so, the message and the
    last good sample go into ``rec`` (the first bad sample is found by replaying the check on the
    block recorded since the last check)."""
    lo, hi = s.limits
    args = (lo, hi, s.opts.stop_at_limits, s.opts.max_speed, s.robot.coordinates)
    if _first_bad(q, dq, *args) is None:
        return False
    check_every = 10
    j0 = k - (k % check_every)
    first = next((j for j in range(j0, k + 1) if _first_bad(rec.Q[j], rec.DQ[j], *args) is not None), None)
    if first is None:          # the state just reached (sample k + 1)
        first, qs, dqs = k + 1, q, dq
    else:
        qs, dqs = rec.Q[first], rec.DQ[first]
    rec.message = f"{_first_bad(qs, dqs, *args)} at t = {rec.t[first]:.3f} s"
    rec.last = first - 1
    return True


def _settings(s: _Setup) -> Dict[str, str]:
    """The run's settings as text (SimResult.settings)."""
    opts, model, plant_terms = s.opts, s.model, s.plant_terms
    settings = {"duration_s": f"{opts.duration:g}", "substeps": str(opts.substeps), "backend": plant_terms.backend}
    if opts.plant_params:
        settings["plant"] = ", ".join(f"{k}={v:g}" for k, v in opts.plant_params.items())
    if opts.model_params:
        settings["model"] = ", ".join(f"{k}={v:g}" for k, v in opts.model_params.items())
    differ = {k: v for k, v in model.values.items() if v != plant_terms.values[k]}
    if differ:
        settings["model_mismatch"] = ", ".join(f"{k}={v:g}" for k, v in differ.items())
    if s.viscous is not None:
        settings["viscous"] = ",".join(f"{v:g}" for v in s.viscous)
    if s.bounds is not None:
        settings["saturation"] = ",".join(f"{v:g}" for v in s.bounds)
    if not s.actuated.all():
        settings["passive"] = ",".join(c for c, a in zip(s.robot.coordinates, s.actuated) if not a)
    if s.obs is not None:
        settings["observer_KI"] = ",".join(f"{v:g}" for v in s.obs.K)
    for c in s.resolved:
        if c.kind == "force":
            settings[f"force_{c.name}"] = f"F={','.join(f'{v:g}' for v in c.F)} from {c.spec.start:g} s to {c.spec.end:g} s"
        else:
            settings[f"surface_{c.name}"] = (f"normal={','.join(f'{v:g}' for v in c.n)} offset={c.offset:g}"
                                             + ("" if c.kind == "rigid" else f" k={c.spec.stiffness:g} d={c.spec.damping:g}"))
    return settings


def _result(s: _Setup, rec: _Record, wall0: float) -> SimResult:
    """The SimResult of a finished (or stopped) run: the samples up to ``rec.last``."""
    controller, robot, resolved = s.controller, s.robot, s.resolved
    sl = slice(0, rec.last + 1)
    X, DX = controller.measure(rec.Q[sl], rec.DQ[sl])
    internals = {}
    if rec.INT is not None:
        for j, name in enumerate(rec.internal_names):
            internals[name] = rec.INT[sl, j].copy()
    ref_points = act_points = None
    if getattr(controller, "point", None) is not None:
        ref_points = controller.reference_points(rec.QD[sl])
        act_points = _pad3(np.array([controller.point.position(qk) for qk in rec.Q[sl]]))
    forces, contact_points = {}, {}
    if rec.FORCES is not None:
        for j, name in enumerate(rec.contact_names):
            key = name if name not in forces else f"{name}{j + 1}"
            forces[key] = rec.FORCES[sl, j].copy()
            contact_points[key] = _pad3(rec.CPOS[sl, j])
    return SimResult(
        robot=robot.name, controller=controller.name, title=controller.title, law_latex=controller.law_latex,
        gains={k: [float(x) for x in np.atleast_1d(v)] for k, v in controller.gain_arrays.items()},
        reference=s.reference.describe(), coordinates=list(robot.coordinates), reference_names=list(s.ref_names),
        t=rec.t[sl].copy(), q=rec.Q[sl].copy(), dq=rec.DQ[sl].copy(), ddq=rec.DDQ[sl].copy(), tau=rec.TAU[sl].copy(),
        ref=rec.QD[sl].copy(), dref=rec.DQD[sl].copy(), ddref=rec.DDQD[sl].copy(), actual=X, dactual=DX,
        internals=internals, forces=forces, force_axes=(resolved[0].point.axes if resolved else []),
        tau_ext=None if rec.TEXT is None else rec.TEXT[sl].copy(), contact_points=contact_points,
        surfaces=[(c.name, _pad3(c.n[None, :])[0], c.offset, c.kind) for c in resolved if c.kind != "force"],
        task_point=getattr(getattr(controller, "point", None), "name", None),
        ref_points=ref_points, actual_points=act_points, message=rec.message, rate=s.opts.rate,
        wall_time=time.perf_counter() - wall0, loop_time=rec.loop_time, settings=_settings(s))


def _position_limits(robot: RobotModel) -> Tuple[np.ndarray, np.ndarray]:
    lo = np.full(robot.n, -np.inf)
    hi = np.full(robot.n, np.inf)
    for i, c in enumerate(robot.coordinates):
        lim = robot.limits.get(c)
        if lim is not None and lim.position is not None:
            lo[i], hi[i] = lim.position
    return lo, hi


def _first_bad(q, dq, lo, hi, use_limits, max_speed, names) -> Optional[str]:
    """Why a state is not acceptable (None when it is)."""
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
        return "the state became NaN or infinite (the run diverged)"
    if use_limits:
        out = np.flatnonzero((q < lo) | (q > hi))
        if out.size:
            i = out[0]
            return f"{names[i]} left its limits [{lo[i]:.4g}, {hi[i]:.4g}]"
    fast = np.flatnonzero(np.abs(dq) > max_speed)
    if fast.size:
        return f"the speed of {names[fast[0]]} exceeded {max_speed:g} rad/s or m/s (the run diverged)"
    return None


def _pad3(points: np.ndarray) -> np.ndarray:
    """Task positions (N x 2 or N x 3) as world points (N x 3), z = 0 for planar robots."""
    points = np.asarray(points, dtype=float)
    if points.shape[1] == 3:
        return points
    return np.hstack([points, np.zeros((points.shape[0], 3 - points.shape[1]))])
