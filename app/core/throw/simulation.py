"""The complete 3-DOF arm simulated in full dynamics (wrist free) from a VHC throw's initial state,
open loop (the VHC torques) or tracking the VHC on the actuated joints: how far the arm drifts from
the reduced dynamics' prediction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from ..numeric import NumericModel
from .config import Progress, SpecBatch, VHCError
from .reduced import Release, Throw


@dataclass
class FullSimulation:
    """The complete 3-DOF arm, wrist free, from the VHC's initial state."""
    controller: str
    t: np.ndarray
    q: np.ndarray                 # (3, n)
    dq: np.ndarray
    tau: np.ndarray               # (2, n)
    q_vhc: np.ndarray             # the VHC prediction at the same times
    max_wrist_drift: float        # max |q3 - q3_vhc| [rad]
    max_ball_drift: float         # max |ball - ball_vhc| [m]
    max_theta_dot_error: float    # max |theta_dot_sim - theta_dot_closed_form(theta_sim)| / theta_dot_e
    duration: float               # time to reach theta_e [s]
    release: Release


def simulate_full(throw: Throw, controller: str = "feedforward", rtol: float = 1e-11,
                  kp: float = 400.0, kd: float = 40.0, samples: int = 400,
                  progress: Progress = None) -> FullSimulation:
    """Simulate M q'' + C q' + g + k q3 = [tau1, tau2, 0] (NumericModel, wrist passive).

    ``controller``: "feedforward" applies the VHC torques tau1(t), tau2(t) open loop; "computed_torque"
    tracks the VHC's joint trajectory on joints 1 and 2 by collocated partial feedback linearization
    (q1'' and q2'' imposed as reference + kd e' + kp e, the wrist left to its own dynamics). The
    reference theta*(t) is integrated alongside from the reduced dynamics. The run stops when the
    simulated ball reaches theta_e (release)."""
    from scipy.integrate import solve_ivp

    if controller not in ("feedforward", "computed_torque"):
        raise UserError(f"unknown controller '{controller}' (feedforward or computed_torque)")
    if progress:
        progress(0.0, f"preparing the full arm's model ({controller})")
    arm, spec = throw.arm, throw.spec
    num = NumericModel(arm.robot, {**arm.values, "k": spec.k})
    batch = SpecBatch.of([spec])
    D = throw.delta

    def reference(th, thd):
        st = arm.evaluate_batch(batch, np.array([(th - spec.theta_b) / D]), strict=False)
        a, b, c = st.alpha[:, 0, 0], st.beta[:, 0, 0], st.gamma[:, 0, 0]
        thdd = -(b[2] * thd * thd + c[2]) / a[2]
        q = st.q[:, 0, 0]
        dq = st.dq[:, 0, 0] * thd
        ddq = st.ddq[:, 0, 0] * thd * thd + st.dq[:, 0, 0] * thdd
        tau = a[:2] * thdd + b[:2] * thd * thd + c[:2]
        return q, dq, ddq, thdd, tau

    def torques(x):
        q, dq, th, thd = x[:3], x[3:6], x[6], x[7]
        qr, dqr, ddqr, thdd, tau_ff = reference(th, thd)
        if controller == "feedforward":
            return tau_ff, thdd
        M = num.M(q)
        h = num.bias(q, dq)
        acc = ddqr[:2] + kd * (dqr[:2] - dq[:2]) + kp * (qr[:2] - q[:2])
        dd3 = -(M[2, :2] @ acc + h[2]) / M[2, 2]
        ddq = np.array([acc[0], acc[1], dd3])
        return (M @ ddq + h)[:2], thdd

    horizon = 2.0 * throw.duration + 0.5
    calls = [0]

    def rhs(t, x):
        calls[0] += 1
        if progress and calls[0] % 50 == 0:       # about 10 ms apart; the progress may stop the run (by raising)
            progress(0.05 + 0.9 * min(1.0, t / throw.duration), f"simulating the full arm ({controller}), t = {t:.3f} s")
        tau, thdd = torques(x)
        ddq = num.forward_dynamics(x[:3], x[3:6], [tau[0], tau[1], 0.0])
        return np.concatenate([x[3:6], ddq, [x[7], thdd]])

    def at_release(t, x):
        return arm.theta_of_q(x[:3], spec.psi) - spec.theta_e
    at_release.terminal = True
    at_release.direction = 1

    st0 = arm.constraint(spec, [spec.theta_b], dynamics=False)
    x0 = np.concatenate([st0.q[:, 0, 0], st0.dq[:, 0, 0] * spec.theta_dot_b, [spec.theta_b, spec.theta_dot_b]])
    if progress:
        progress(0.05, f"simulating the full arm ({controller})")
    sol = solve_ivp(rhs, (0.0, horizon), x0, method="DOP853", rtol=rtol, atol=1e-12,
                    events=at_release, dense_output=True)
    if not sol.t_events[0].size:
        raise VHCError(f"in the full simulation ({controller}) the ball never reaches theta_e")
    T = float(sol.t_events[0][0])
    t = np.linspace(0.0, T, samples)
    X = sol.sol(t)
    X[:, -1] = sol.y_events[0][0]
    q, dq = X[:3], X[3:6]
    if progress:
        progress(0.95, f"sampling the full arm's motion ({controller})")
    refs = [reference(X[6, j], X[7, j]) for j in range(samples)]
    if progress:
        progress(0.97, f"sampling the full arm's motion ({controller})")
    q_vhc = np.array([r[0] for r in refs]).T
    tau = np.array([torques(X[:, j])[0] for j in range(samples)]).T
    if progress:
        progress(0.99, f"sampling the full arm's motion ({controller})")
    ball = arm.ball_position(q)
    ball_vhc = arm.ball_position(q_vhc)
    theta_sim = arm.theta_of_q(q, spec.psi)
    # d theta / dt = d theta/dq . dq
    a1, a12, a123 = q[0] - spec.psi, q[0] + q[1] - spec.psi, q[0] + q[1] + q[2] - spec.psi
    w1, w12, w123 = dq[0], dq[0] + dq[1], dq[0] + dq[1] + dq[2]
    thd_sim = -(arm.l1 * np.sin(a1) * w1 + arm.l2 * np.sin(a12) * w12 + arm.l3 * np.sin(a123) * w123)
    thd_cf = throw.theta_dot(np.clip(theta_sim, spec.theta_b, spec.theta_e))
    rel = Release.make(arm, spec, q[:, -1], dq[:, -1], float(thd_sim[-1]))
    if progress:
        progress(1.0, "done")
    return FullSimulation(controller, t, q, dq, tau, q_vhc, float(np.max(np.abs(q[2] - q_vhc[2]))),
                          float(np.max(np.hypot(*(ball - ball_vhc)))),
                          float(np.max(np.abs(thd_sim - thd_cf)) / throw.theta_dot_e), T, rel)


