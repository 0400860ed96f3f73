"""The controllers of a point's position in task coordinates (app/core/control.py lists them):
impedance, admittance and hybrid force/position control, for contact with the scene's surfaces."""
from __future__ import annotations

import numpy as np

from .controller_base import KD, KP, Controller, Gain, GainError


# ====================================================================== Cartesian control and contact
class _Cartesian(Controller):
    """Controllers of a point's position p(q) in task coordinates (x, y for planar robots)."""
    needs_full_actuation = True
    space = "task"

    def reference_coordinates(self, s):
        robot = s.robot
        name = s.task_point
        if name is None:
            name = "ee" if "ee" in robot.points else next(iter(robot.points), None)
        if name is None:
            raise GainError(f"{self.name} needs a point on the robot (the file of {robot.name} has no points)")
        self.point = s.make_point(name)
        if self.point.dim != self.n:
            raise GainError(f"{self.name} needs as many joints as task coordinates: {robot.name} has {self.n} "
                            f"joints and the point moves in {self.point.dim} dimensions")
        return list(self.point.axes), self.point.position(s.q0)

    def force(self) -> np.ndarray:
        F = self.s.read_force(self.point.name)
        return np.zeros(self.point.dim) if F is None else F

    def reference_points(self, ref: np.ndarray) -> np.ndarray:
        """World positions (N x 3) of the reference samples."""
        return np.hstack([ref, np.zeros((ref.shape[0], 3 - ref.shape[1]))]) if ref.shape[1] < 3 else ref.copy()

    def measure(self, Q, DQ):
        X = np.array([self.point.position(q) for q in Q])
        DX = np.array([self.point.jacobian(q) @ dq for q, dq in zip(Q, DQ)])
        return self._to_task(X, DX)

    def _to_task(self, X, DX):
        return X, DX


class Impedance(_Cartesian):
    name = "impedance"
    title = "Impedance control (Cartesian, with force measurement)"
    law_latex = (r"\tau = M(q) J^{-1}(q)\left(\ddot p_d + M_m^{-1}\left(D_m \dot e + K_m e + F\right) - \dot J(q)\dot q\right)"
                 r" + c(q,\dot q) + g(q) - J^T(q) F,\quad e = p_d - p")
    closed_loop = ("M_m (p'' - p''_d) + D_m (p' - p'_d) + K_m (p - p_d) = F: the point behaves as a mass-spring-damper "
                   "under the external force F (on the robot); at rest against a surface K_m (p - p_d) = F.")
    gain_specs = (Gain("Mm", 2.0, "apparent mass M_m (diagonal)", "kg"),
                  Gain("Dm", 60.0, "apparent damping D_m (diagonal)", "N s/m"),
                  Gain("Km", 400.0, "apparent stiffness K_m (diagonal)", "N/m"))

    def prepare(self, s):
        self.internal_names = [f"F_{a}" for a in self.point.axes]
        self._F = np.zeros(self.point.dim)

    def step(self, k, t, q, dq, pd, dpd, ddpd):
        p, J, jd = self.point.kinematics(q, dq)
        dp = J @ dq
        F = self.force()
        self._F = F
        a = ddpd + (self.Dm * (dpd - dp) + self.Km * (pd - p) + F) / self.Mm
        return self.model.inverse_dynamics(q, dq, np.linalg.solve(J, a - jd)) - J.T @ F

    def internals(self):
        return self._F


class Admittance(_Cartesian):
    name = "admittance"
    title = "Admittance control (compliant reference + Cartesian motion control)"
    law_latex = (r"M_m \ddot p_r + D_m(\dot p_r - \dot p_d) + K_m (p_r - p_d) = F + M_m \ddot p_d,\quad "
                 r"\tau = M(q) J^{-1}(q)\left(\ddot p_r + K_D(\dot p_r - \dot p) + K_P(p_r - p) - \dot J(q)\dot q\right)"
                 r" + c(q,\dot q) + g(q)")
    closed_loop = ("The measured force F bends the reference p_r through the admittance; a stiff inner motion loop "
                   "makes p follow p_r, so p - p_d obeys the desired mass-spring-damper (up to the inner error).")
    gain_specs = (Gain("Mm", 2.0, "admittance mass M_m (diagonal)", "kg"),
                  Gain("Dm", 60.0, "admittance damping D_m (diagonal)", "N s/m"),
                  Gain("Km", 400.0, "admittance stiffness K_m (diagonal)", "N/m"),
                  Gain("Kp", 2500.0, "inner position gain K_P (diagonal)", "1/s^2"),
                  Gain("Kd", 100.0, "inner velocity gain K_D (diagonal)", "1/s"))

    def prepare(self, s):
        axes = self.point.axes
        self.internal_names = [f"p_r_{a}" for a in axes] + [f"F_{a}" for a in axes]
        self.pr = self.point.position(s.q0)
        self.dpr = self.point.jacobian(s.q0) @ s.dq0
        self._out = np.concatenate([self.pr, np.zeros(self.point.dim)])

    def step(self, k, t, q, dq, pd, dpd, ddpd):
        p, J, jd = self.point.kinematics(q, dq)
        dp = J @ dq
        F = self.force()
        ddpr = ddpd + (F - self.Dm * (self.dpr - dpd) - self.Km * (self.pr - pd)) / self.Mm
        self._out = np.concatenate([self.pr, F])
        a = ddpr + self.Kd * (self.dpr - dp) + self.Kp * (self.pr - p)
        tau = self.model.inverse_dynamics(q, dq, np.linalg.solve(J, a - jd))
        self.dpr = self.dpr + self.dt * ddpr            # semi-implicit Euler of the admittance
        self.pr = self.pr + self.dt * self.dpr
        return tau

    def internals(self):
        return self._out


class Hybrid(_Cartesian):
    name = "hybrid"
    title = "Hybrid force/velocity control against a rigid surface"
    law_latex = (r"\tau = M(q) J^{-1}(q)\left(t\, a_t - \dot J(q)\dot q\right) + c(q,\dot q) + g(q) - J^T(q)\, n\, f_c,\quad "
                 r"a_t = \ddot s_d + K_D(\dot s_d - \dot s) + K_P(s_d - s),\quad "
                 r"f_c = f_d + K_F \int (f_d - \lambda)\,dt")
    closed_loop = ("On the surface (n^T p = const) the constraint force equals f_c, so lambda = f_d, and the motion "
                   "along the tangent t obeys e_s'' + K_D e_s' + K_P e_s = 0: force and motion are decoupled. "
                   "The integral action removes force errors caused by model mismatch.")
    gain_specs = (KP, KD,
                  Gain("Fd", 10.0, "desired normal force f_d pushed on the surface", "N", "one"),
                  Gain("KF", 10.0, "integral gain of the force loop", "1/s", "one", positive=False))

    def reference_coordinates(self, s):
        rigid = [x for x in s.surfaces if x[1] == "rigid"]
        if not rigid:
            raise GainError("hybrid control needs a rigid surface (e.g. --surface 'ee normal=0,1')")
        names, _ = super().reference_coordinates(s)
        surf = next((x for x in rigid if x[0] == self.point.name), None)
        if surf is None:
            raise GainError(f"hybrid: the rigid surface touches {rigid[0][0]}, the task point is {self.point.name}")
        self.normal = np.asarray(surf[2], dtype=float)
        # tangent basis: complete n to an orthonormal frame
        dim = self.point.dim
        if dim == 2:      # t = n rotated by -90 degrees: s = x on a floor with n = (0, 1)
            T = np.array([[self.normal[1]], [-self.normal[0]]])
        else:
            U, _, _ = np.linalg.svd(self.normal.reshape(3, 1))
            T = U[:, 1:]
        self.T = T
        self.ref_names = ["s"] if dim == 2 else ["s1", "s2"]
        return self.ref_names, T.T @ self.point.position(s.q0)

    def prepare(self, s):
        self.internal_names = ["lambda", "f_c"]
        self._I = 0.0
        self._out = np.zeros(2)

    def step(self, k, t, q, dq, sd, dsd, ddsd):
        p, J, jd = self.point.kinematics(q, dq)
        dp = J @ dq
        s_, ds_ = self.T.T @ p, self.T.T @ dp
        lam = float(self.normal @ self.force())
        fc = self.Fd + self.KF * self._I
        self._I += self.dt * (self.Fd - lam)
        self._out = np.array([lam, fc])
        a_t = ddsd + self.Kd * (dsd - ds_) + self.Kp * (sd - s_)
        acc = np.linalg.solve(J, self.T @ a_t - jd)
        return self.model.inverse_dynamics(q, dq, acc) - J.T @ (self.normal * fc)

    def internals(self):
        return self._out

    def _to_task(self, X, DX):
        return X @ self.T, DX @ self.T

    def reference_points(self, ref):
        # the point of the surface at tangential coordinate s: T s + n offset
        offset = float(self.normal @ self.point.position(self.s.q0))
        return super().reference_points(ref @ self.T.T + offset * self.normal)
