"""The controllers of the course, as objects a simulation samples at a fixed rate.

Each controller has a ``name`` (used on the command line), a ``title``, its law as LaTeX in the
notation of the exams (``law_latex``: e = q_d - q, M(q) the inertia matrix, c the Coriolis and
centrifugal terms, g the gravity vector, including spring terms k(q) when the robot has springs,
n = c + g + friction), a ``closed_loop`` note, and documented gains (``gain_specs``). A controller
is set up once for a robot (``setup``), told its reference (``begin``) and then called at every
sample: ``step(k, t, q, dq, qd, dqd, ddqd) -> tau``. Signals worth plotting (estimates, residuals,
forces) are its ``internals``.

Gains are given by name, case-insensitively: ``Kp=100`` sets every entry, ``Kp2=50`` only the
second one (entries follow the reference coordinates, or the coefficients for Gamma).

The rooms: the base class, gains and their parsing in app/core/controller_base.py, the task-space
controllers (impedance, admittance, hybrid) in app/core/control_cartesian.py; this module holds the
joint-space, underactuated and elastic laws, the collision observer and ``CONTROLLERS``.

>>> ct = make_controller("computed_torque", {"Kp": 100, "Kd2": 30})
>>> ct.law_latex
'\\\\tau = M(q)\\\\left(\\\\ddot q_d + K_D \\\\dot e + K_P e\\\\right) + c(q,\\\\dot q) + g(q)'
>>> sorted(CONTROLLERS)[:3]
['adaptive', 'admittance', 'computed_torque']
"""
from __future__ import annotations

from typing import Dict, Mapping, Optional

import numpy as np
import sympy as sp

from .control_cartesian import Admittance, Hybrid, Impedance
from .controller_base import KD, KP, ControlSetup, ControlStop, Controller, Gain, GainError


# ====================================================================== joint-space regulation and tracking
class PD(Controller):
    name = "pd"
    title = "PD without gravity compensation"
    law_latex = r"\tau = K_P e + K_D \dot e,\quad e = q_d - q"
    closed_loop = ("Regulation to a set point leaves a steady-state error: at rest K_P e_ss = g(q_ss) "
                   "(the equilibrium where the PD spring balances gravity).")
    gain_specs = (Gain("Kp", 100.0, "proportional gain K_P (diagonal)", "N m/rad", per_inertia=True),
                  Gain("Kd", 20.0, "derivative gain K_D (diagonal)", "N m s/rad", per_inertia=True))

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        return self.Kp * (qd - q) + self.Kd * (dqd - dq)


class PDGravity(PD):
    name = "pd_gravity"
    title = "PD + on-line gravity compensation g(q)"
    law_latex = r"\tau = K_P e + K_D \dot e + g(q),\quad e = q_d - q"
    closed_loop = ("Global asymptotic stability of a set point for any K_P, K_D > 0 "
                   "(Lyapunov V = 1/2 q'^T M q' + 1/2 e^T K_P e, LaSalle).")

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        return super().step(k, t, q, dq, qd, dqd, ddqd) + self.model.gravity(q)


class PDGravityConstant(PD):
    name = "pd_gravity_const"
    title = "PD + constant gravity compensation g(q_d)"
    law_latex = r"\tau = K_P e + K_D \dot e + g(q_d),\quad e = q_d - q"
    closed_loop = ("Global asymptotic stability of a set point when K_P,min > alpha, with alpha a bound "
                   "of the norm of dg/dq.")

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        return super().step(k, t, q, dq, qd, dqd, ddqd) + self.model.gravity(qd)


class ComputedTorque(Controller):
    name = "computed_torque"
    title = "Computed torque (feedback linearization)"
    law_latex = r"\tau = M(q)\left(\ddot q_d + K_D \dot e + K_P e\right) + c(q,\dot q) + g(q)"
    closed_loop = ("With an exact model: e'' + K_D e' + K_P e = 0, decoupled and exponentially stable; "
                   "K_P = w^2, K_D = 2 zeta w.")
    gain_specs = (KP, KD)
    needs_full_actuation = True

    def prepare(self, s):
        self._id = s.model.inverse_dynamics

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        return self._id(q, dq, ddqd + self.Kd * (dqd - dq) + self.Kp * (qd - q))


class Robust(Controller):
    name = "robust"
    title = "Computed torque + robust (sliding-mode-style) correction"
    law_latex = (r"\tau = \hat M(q)\left(\ddot q_d + K_D \dot e + K_P e + w\right) + \hat c + \hat g,\quad "
                 r"w = \rho\,\frac{z}{\max(\|z\|, \varepsilon)},\quad z = \dot e + \Lambda e")
    closed_loop = ("e'' + K_D e' + K_P e = eta - w with eta the model error: w pushes along z with "
                   "magnitude rho >= |eta| (inside the boundary layer |z| < epsilon it is linear, "
                   "avoiding chattering), so the error reaches and stays near the surface z = 0.")
    gain_specs = (KP, KD,
                  Gain("Lambda", 5.0, "slope of the sliding surface z = e' + Lambda e", "1/s"),
                  Gain("rho", 20.0, "magnitude of the robust correction w", "rad/s^2", "one"),
                  Gain("eps", 0.05, "boundary layer width on |z|", "rad/s", "one"))
    needs_full_actuation = True

    def prepare(self, s):
        self._id = s.model.inverse_dynamics
        self.internal_names = ["|z|"]
        self._nz = 0.0

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        e, de = qd - q, dqd - dq
        z = de + self.Lambda * e
        nz = float(np.sqrt(z @ z))
        self._nz = nz
        w = self.rho * z / max(nz, self.eps)
        return self._id(q, dq, ddqd + self.Kd * de + self.Kp * e + w)

    def internals(self):
        return np.array([self._nz])


class Adaptive(Controller):
    name = "adaptive"
    title = "Adaptive control (Slotine-Li)"
    law_latex = (r"\tau = Y(q,\dot q,\dot q_r,\ddot q_r)\,\hat a + K_D(\dot q_r - \dot q),\quad "
                 r"\dot{\hat a} = \Gamma\, Y^T(q,\dot q,\dot q_r,\ddot q_r)\,(\dot q_r - \dot q),\quad "
                 r"\dot q_r = \dot q_d + \Lambda e,\ \ddot q_r = \ddot q_d + \Lambda \dot e")
    closed_loop = ("V = 1/2 s^T M(q) s + 1/2 a~^T Gamma^-1 a~ with s = q'_r - q' has V' = -s^T K_D s <= 0: "
                   "e -> 0 and the estimates stay bounded (they converge to the true a only with "
                   "persistent excitation).")
    gain_specs = (Gain("Kd", 20.0, "gain K_D on s = dq_r - dq (diagonal)", "N m s/rad"),
                  Gain("Lambda", 5.0, "Lambda in dq_r = dq_d + Lambda e (diagonal)", "1/s"),
                  Gain("Gamma", 1.0, "adaptation gain Gamma (diagonal, one per coefficient)", "", "param"))
    needs_full_actuation = True

    def _gain_size(self, spec):
        return self.count if spec.size == "param" else super()._gain_size(spec)

    def prepare(self, s):
        from .dynamics import derive
        from .numeric import compiled_model
        robot = s.robot
        par = derive(robot).parametrization
        self.count = par.count
        self.coefficients_latex = [sp.latex(a) for a in par.a]
        self.coefficient_names = [str(a) for a in par.a]
        self._Y, self._y0 = compiled_model(robot).regressor_ref()
        self._p = np.array([s.model.values[name] for name in robot.parameters], dtype=float)
        self.internal_names = [f"a_hat{i + 1}" for i in range(self.count)]

    def coefficients(self, values: Mapping[str, float]) -> np.ndarray:
        """The true coefficient vector a at given parameter values (e.g. the plant's)."""
        return coefficient_values(self.robot, values)

    def regressor(self, q, dq, dqr, ddqr) -> np.ndarray:
        return np.asarray(self._Y(q, dq, dqr, ddqr, self._p), dtype=float).reshape(self.n, self.count)

    def begin(self, reference):
        super().begin(reference)
        self.a_hat = self.coefficients(self.model.values)      # initial estimate: the controller's model
        self._used = self.a_hat.copy()

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        e, de = qd - q, dqd - dq
        dqr = dqd + self.Lambda * e
        ddqr = ddqd + self.Lambda * de
        sv = dqr - dq
        Y = self.regressor(q, dq, dqr, ddqr)
        self._used = self.a_hat
        y0 = np.asarray(self._y0(q, dq, dqr, ddqr, self._p), dtype=float).reshape(self.n)   # known terms
        tau = Y @ self.a_hat + y0 + self.Kd * sv
        self.a_hat = self.a_hat + self.dt * self.Gamma * (Y.T @ sv)
        return tau

    def internals(self):
        return self._used


def coefficient_values(robot, values: Mapping[str, float]) -> np.ndarray:
    """The minimal dynamic coefficients a of the robot's linear parametrization (the ones adaptive
    control estimates) at the given parameter values.

    >>> from app.core.robot import load_robot
    >>> coefficient_values(load_robot("rp_2004_03_25"), {"m1": 8, "m2": 4, "d1": 0.4, "l1": 0.8,
    ...                    "I1": 0.5, "I2": 0.2, "g0": 9.81}).round(6).tolist()   # I1 + I2 + m1 d1^2, m1 d1, m2
    [1.98, 3.2, 4.0]
    """
    from .dynamics import derive
    par = derive(robot).parametrization
    subs = {sp.Symbol(k, real=True): float(values[k]) for k in robot.parameters}
    return np.array([float(sp.sympify(a).xreplace(subs)) for a in par.a], dtype=float)


class Learning(Controller):
    name = "learning"
    title = "Iterative learning for regulation (gravity feedforward learned over iterations)"
    law_latex = (r"\tau = K_P e - K_D \dot q + u_{i-1},\quad u_i = u_{i-1} + K_P e_i"
                 r"\quad (\text{at the end of each iteration of length } T)")
    closed_loop = ("At the end of iteration i the robot rests where g(q_i) = K_P e_i + u_{i-1}, so u_i = g(q_i); "
                   "with K_P,min > 2 alpha (alpha bounds |dg/dq|) the errors contract, |e_i| <= beta/(1-beta) |e_(i-1)|, "
                   "and q_i -> q_d without knowing g.")
    gain_specs = (Gain("Kp", 100.0, "proportional gain K_P (diagonal)", "N m/rad", per_inertia=True),
                  Gain("Kd", 20.0, "derivative gain K_D (diagonal)", "N m s/rad", per_inertia=True),
                  Gain("T", 5.0, "iteration length: the feedforward is updated every T seconds", "s", "one"))

    def prepare(self, s):
        self.internal_names = [f"u_{c}" for c in self.reference_names] + ["iteration"]

    def begin(self, reference):
        from .trajectories import SetPoint
        if not isinstance(reference, SetPoint):
            raise GainError("learning is a regulation scheme: give a setpoint reference")
        super().begin(reference)
        self.u = np.zeros(self.n)
        self.iteration = 0
        self._next = self.T

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        if t >= self._next - 1e-9:
            self.u = self.u + self.Kp * (qd - q)
            self.iteration += 1
            self._next += self.T
        return self.Kp * (qd - q) - self.Kd * dq + self.u

    def internals(self):
        return np.append(self.u, self.iteration)


# ====================================================================== underactuated and elastic robots
class _PFL(Controller):
    collocated = True
    gain_specs = (KP, KD)

    def reference_coordinates(self, s):
        act = np.flatnonzero(s.actuated)
        pas = np.flatnonzero(~s.actuated)
        if pas.size == 0:
            raise GainError(f"{self.name} is for robots with a passive joint; mark one passive (e.g. "
                            f"{s.robot.coordinates[-1]})")
        if act.size == 0:
            raise GainError(f"{self.name}: no joint is actuated")
        if not self.collocated and act.size < pas.size:
            raise GainError(f"{self.name}: {pas.size} passive coordinates cannot be linearized with {act.size} inputs")
        self.A, self.P = act, pas
        self.ref_index = act if self.collocated else pas
        return [s.robot.coordinates[i] for i in self.ref_index], s.q0[self.ref_index].copy()

    def prepare(self, s):
        self.internal_names = [f"a_{c}" for c in self.reference_names]
        self._y = np.zeros(len(self.ref_index))

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        A, P = self.A, self.P
        x, dx = q[self.ref_index], dq[self.ref_index]
        y = ddqd + self.Kd * (dqd - dx) + self.Kp * (qd - x)
        self._y = y
        M = self.model.M(q)
        h = self.model.bias(q, dq)
        MAA, MAP, MPA, MPP = M[np.ix_(A, A)], M[np.ix_(A, P)], M[np.ix_(P, A)], M[np.ix_(P, P)]
        if self.collocated:
            ddqP = -np.linalg.solve(MPP, MPA @ y + h[P])
            u = MAA @ y + MAP @ ddqP + h[A]
        else:
            sv = np.linalg.svd(MPA, compute_uv=False)
            if sv.min() < 1e-9 * max(1.0, sv.max()):
                raise ControlStop("non-collocated PFL lost its inertial coupling (M_PA is singular)")
            ddqA = np.linalg.lstsq(MPA, -(MPP @ y + h[P]), rcond=None)[0]
            u = MAA @ ddqA + MAP @ y + h[A]
        tau = np.zeros(self.n)
        tau[A] = u
        return tau

    def internals(self):
        return self._y


class PFLCollocated(_PFL):
    name = "pfl_collocated"
    title = "Partial feedback linearization, collocated (actuated joints)"
    law_latex = (r"u_a = \left(M_{aa} - M_{ap} M_{pp}^{-1} M_{pa}\right) a + n_a - M_{ap} M_{pp}^{-1} n_p,\quad "
                 r"a = \ddot q_{a,d} + K_D \dot e_a + K_P e_a")
    closed_loop = ("q''_a = a exactly (the actuated coordinates follow a linear system); the passive ones obey "
                   "the zero dynamics M_pp q''_p + M_pa a + n_p = 0.")
    collocated = True


class PFLNonCollocated(_PFL):
    name = "pfl_noncollocated"
    title = "Partial feedback linearization, non-collocated (passive joints)"
    law_latex = (r"u_a = M_{aa} \ddot q_a + M_{ap} a + n_a,\quad \ddot q_a = -M_{pa}^{-1}\left(M_{pp} a + n_p\right),\quad "
                 r"a = \ddot q_{p,d} + K_D \dot e_p + K_P e_p")
    closed_loop = ("q''_p = a exactly, as long as M_pa (the inertial coupling) is invertible; the actuated "
                   "coordinates are then left to their own (zero) dynamics.")
    collocated = False


class ElasticPD(Controller):
    name = "elastic_pd"
    title = "Elastic joints: motor PD + link gravity compensation"
    law_latex = (r"\tau = K_P(\theta_d - \theta) - K_D \dot\theta + g(q_d),\quad "
                 r"\theta_d = q_d + K^{-1} g(q_d)")
    closed_loop = ("The link set point q_d and the motor set point theta_d (where the springs balance gravity) "
                   "are globally asymptotically stable when the joint stiffness and K_P are large enough "
                   "compared with the gravity gradient (K_min > alpha, K_P,min > alpha).")
    gain_specs = (Gain("Kp", 200.0, "motor proportional gain K_P (diagonal)", "N m/rad"),
                  Gain("Kd", 30.0, "motor derivative gain K_D (diagonal)", "N m s/rad"))

    def reference_coordinates(self, s):
        robot = s.robot
        motors = [c for c in robot.coordinates if c in robot.motor_inertias]
        if not motors:
            raise GainError(f"{self.name} needs a robot with elastic joints (motor coordinates under 'motors:'); "
                            f"{robot.name} has none")
        self.motor_index = np.array([robot.coordinates.index(c) for c in motors])
        self.link_index = np.array([i for i, c in enumerate(robot.coordinates) if c not in motors])
        if self.link_index.size != self.motor_index.size:
            raise GainError(f"{self.name}: {self.link_index.size} link and {self.motor_index.size} motor coordinates; "
                            "one motor per link is needed")
        self.ref_index = self.link_index
        return [robot.coordinates[i] for i in self.link_index], s.q0[self.link_index].copy()

    def _gain_size(self, spec):
        return self.motor_index.size

    def begin(self, reference):
        from scipy.optimize import fsolve
        from .trajectories import SetPoint
        if not isinstance(reference, SetPoint):
            raise GainError("elastic_pd regulates to a set point: give a setpoint reference")
        super().begin(reference)
        x = self.s.q0.copy()
        x[self.link_index] = reference.goal
        L, Mo = self.link_index, self.motor_index

        def residual(theta):
            y = x.copy()
            y[Mo] = theta
            return self.model.gravity(y)[L]

        theta = fsolve(residual, x[L].copy(), xtol=1e-12, full_output=True)[0]   # checked below
        if np.max(np.abs(residual(theta))) > 1e-8:
            raise GainError(f"{self.name}: no motor positions balance gravity at q_d = {reference.goal.tolist()}")
        x[Mo] = theta
        self.theta_d = theta
        self.tau_ff = self.model.gravity(x)[Mo]
        self.internal_names = [f"theta_d_{self.robot.coordinates[i]}" for i in Mo]

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        tau = np.zeros(self.n)
        Mo = self.motor_index
        tau[Mo] = self.Kp * (self.theta_d - q[Mo]) - self.Kd * dq[Mo] + self.tau_ff
        return tau

    def internals(self):
        return self.theta_d


class ElasticPDOnline(ElasticPD):
    name = "elastic_pd_online"
    title = "Elastic joints: motor PD + on-line gravity compensation"
    law_latex = (r"\tau = K_P(\theta_d - \theta) - K_D \dot\theta + g(\tilde q),\quad "
                 r"\tilde q = \theta - K^{-1} g(q_d),\quad \theta_d = q_d + K^{-1} g(q_d)")
    closed_loop = ("The same equilibrium as with the constant g(q_d), but the gravity term follows the motion: it "
                   "is evaluated at q~, the link position that the motor positions give with the set point's "
                   "spring deflection (q~ = q_d at the set point; De Luca, Siciliano and Zollo's on-line "
                   "compensation).")

    def begin(self, reference):
        super().begin(reference)
        self.deflection = self.theta_d - reference.goal          # K^-1 g(q_d): motor i drives link i
        self._x = self.s.q0.copy()

    def step(self, k, t, q, dq, qd, dqd, ddqd):
        x = self._x
        x[self.link_index] = q[self.motor_index] - self.deflection
        g = self.model.num.g(x)[self.link_index]                 # link gravity at q~ (no springs)
        tau = np.zeros(self.n)
        Mo = self.motor_index
        tau[Mo] = self.Kp * (self.theta_d - q[Mo]) - self.Kd * dq[Mo] + g
        return tau


# ====================================================================== collision detection
class MomentumObserver:
    """Momentum-based collision detection residual, running beside any controller:

        r = K_I ( p(t) - p(0) - int_0^t (tau + C^T(q, q') q' - g(q) + r) ds ),   p = M(q) q'

    so that r' = K_I (tau_ext - r): a first-order filtered estimate of the external joint torque
    (J^T F for a force F on a point). Discretized with the trapezoidal rule (the applied torque is
    held constant over each period, so its integral is exact).
    """
    law_latex = (r"r = K_I\left(M(q)\dot q - \int_0^t \left(\tau + C^T(q,\dot q)\dot q - g(q) + r\right)ds"
                 r" - M(q_0)\dot q_0\right),\quad \dot r = K_I(\tau_{ext} - r)")

    def __init__(self, gain):
        self.gain = gain

    def setup(self, s: ControlSetup) -> None:
        n = s.robot.n
        K = np.atleast_1d(np.asarray(self.gain, dtype=float)).reshape(-1)
        if K.size == 1:
            K = np.full(n, K[0])
        if K.size != n or not np.all(np.isfinite(K)) or np.any(K <= 0):
            raise GainError(f"observer: K_I needs one positive value or {n} (one per coordinate)")
        self.K = K
        self.model = s.model
        self.dt = s.period
        self.internal_names = [f"r_{c}" for c in s.robot.coordinates]
        self.r = np.zeros(n)
        self._started = False

    def _beta(self, q, dq):
        m = self.model
        return m.gravity(q) + m.friction(dq) - m.coriolis_matrix(q, dq).T @ dq

    def update(self, q, dq, tau) -> np.ndarray:
        """Advance to the current sample (q, q') where ``tau`` will be applied; returns r."""
        p = self.model.M(q) @ dq
        beta = self._beta(q, dq)
        if not self._started:
            self._started = True
            self.p0, self.I = p, np.zeros_like(p)
        else:
            dt = self.dt
            I1 = self.I + dt * self._tau - dt / 2 * (self._beta_prev + beta) + dt / 2 * self.r
            self.r = self.K * (p - self.p0 - I1) / (1 + self.K * dt / 2)
            self.I = I1 + dt / 2 * self.r
        self._tau, self._beta_prev = np.array(tau, dtype=float), beta
        return self.r


# ====================================================================== by name
#: every controller by its ``name`` (command line, page, ``make_controller``)
CONTROLLERS: Dict[str, type] = {cls.name: cls for cls in (
    PD, PDGravity, PDGravityConstant, ComputedTorque, Robust, Adaptive, Learning, PFLCollocated,
    PFLNonCollocated, ElasticPD, ElasticPDOnline, Impedance, Admittance, Hybrid,
)}


def make_controller(name: str, gains: Optional[Mapping[str, float]] = None) -> Controller:
    """A controller by name, with gains.

    >>> make_controller("pid")
    Traceback (most recent call last):
    ...
    app.core.controller_base.GainError: unknown controller 'pid' (adaptive, admittance, computed_torque, elastic_pd, elastic_pd_online, hybrid, impedance, learning, pd, pd_gravity, pd_gravity_const, pfl_collocated, pfl_noncollocated, robust)
    """
    cls = CONTROLLERS.get(name)
    if cls is None:
        raise GainError(f"unknown controller '{name}' ({', '.join(sorted(CONTROLLERS))})")
    return cls(gains)
