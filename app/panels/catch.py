"""Catch panel (catching arm): the reachable region, a thrown ball's flight, where and when the
arm intercepts it and the trapezoidal joint motions that get it there (app/core/catching.py).

The ball comes either from the coursework's launcher (speed, elevation, distance) or from one of the
throwing arm's throws (app/throws, solved by app/core/throw/), placed so that it lands 0.5 m beyond
the catching arm's base.
"""
from __future__ import annotations

import threading
import time

import numpy as np

TITLE = "Catch"
ORDER = 40

_SOURCES = ("coursework launcher", "throw1", "throw2", "throw3")


def available(robot) -> bool:
    return robot.group == "catching"


def _table(plan) -> str:
    deg = np.degrees
    rows = "".join(f"<tr><td>{i + 1}</td><td>{deg(a):.2f}</td><td>{deg(b):.2f}</td><td>{deg(v):.1f}</td>"
                   f"<td>{deg(acc):.0f}</td></tr>"
                   for i, (a, b, v, acc) in enumerate(zip(plan.q_start, plan.q_catch, plan.joint_speed_max,
                                                           plan.joint_acceleration_max)))
    return ("<table><tr><th>joint</th><th>start [deg]</th><th>catch [deg]</th><th>speed [deg/s]</th>"
            "<th>acc. [deg/s²]</th></tr>" + rows + "</table>")


def _frame(session, points) -> None:
    """Camera square-on to the plane, showing every point (region, flight) beside the side panel."""
    from app.scene import Framing, camera_pose
    from app.viewer import SIDE_PANEL_PX
    pts = np.asarray(points, float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    framing = Framing(np.array([*(lo + hi) / 2, 0.0]), float(np.linalg.norm(hi - lo) / 2),
                      np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    fov = np.radians(28.0)

    def pose(width, height):
        occluded = SIDE_PANEL_PX / width if width > 2.2 * SIDE_PANEL_PX else 0.0
        return (fov, *camera_pose(framing, fov=fov, aspect=width / height, occluded_right=occluded))

    session.scene.point_camera(pose)


def build(session) -> None:
    from app.core.catching import BallFlight, CatchingArm, catch_thesis_throw, plan_catch

    gui = session.gui
    state = session.state.setdefault("catch", {})
    generation = session.generation         # this panel's robot: nothing is drawn after a switch
    gui.add_markdown("A ball flies through the arm's workspace (green); the arm reaches the interception "
                     "point when the ball does, with synchronized trapezoidal joint speeds, starting from "
                     "the configuration of the sliders.")
    source = gui.add_dropdown("Ball from", _SOURCES, initial_value=_SOURCES[0])
    speed = gui.add_slider("Launch speed u [m/s]", min=4.0, max=15.0, step=0.1, initial_value=10.0)
    angle = gui.add_slider("Elevation alpha [deg]", min=20.0, max=88.0, step=0.5, initial_value=45.0)
    x0 = gui.add_slider("Launcher at x0 [m]", min=1.0, max=6.0, step=0.1, initial_value=3.0)
    method = gui.add_dropdown("Interception point", ("middle of the reachable stretch", "closest to the hand"),
                              initial_value="middle of the reachable stretch")
    plan_button = gui.add_button("Plan the catch")
    play_button = gui.add_button("Play", disabled=True)
    out = gui.add_html("")

    def compute(progress):
        params = {k: v for k, v in session.params.items() if k in session.robot.parameters}
        arm = CatchingArm(session.robot, params)
        q0 = np.asarray(session.q, float)
        how = "middle" if method.value.startswith("middle") else "closest"
        progress(0.1, "ball flight")
        if source.value.startswith("coursework"):
            ball = BallFlight.coursework(speed.value, angle.value, x0.value, 0.0)
        else:
            scene = catch_thesis_throw(source.value, q_start=q0, method=how, arm=arm)
            ball = BallFlight.from_release(scene["release"], scene["velocity"], scene["g"], origin=scene["base"])
        progress(0.3, "reachable region")
        region = arm.reachable_region(resolution=0.03, samples=121)
        progress(0.7, "interception and joint motions")
        plan = plan_catch(arm, ball, q0, method=how)
        path = ball.position(np.linspace(0.0, ball.landing_time(), 200)).T
        return {"region": region, "path": path, "plan": plan, "ball": ball}

    def draw(result):
        state["result"] = result
        sc = session.scene
        plan, ball = result["plan"], result["ball"]
        z = lambda pts: np.column_stack([pts, np.zeros(len(pts))])
        with session.holding(generation) as current, session.atomic():
            if not current:
                return
            for k, line in enumerate(result["region"]):
                sc.add_line(f"catch_region{k}", z(line), (60, 150, 60), 3.0)
            sc.add_trajectory("catch_ball_path", z(result["path"]), (230, 120, 20))
            sc.add_marker("catch_release", [*ball.p0, 0.0], (230, 120, 20), label="release")
            sc.add_marker("catch_point", [*plan.point, 0.0], (200, 30, 30), label=f"catch at t = {plan.time:.3f} s")
            sc.ghost(plan.q_catch, name="catch_ghost")
        _frame(session, np.vstack([*result["region"], result["path"], [ball.p0]]))
        out.content = (session.math_html(rf"t_c = {plan.time:.4f}\ \mathrm{{s}},\quad p_c = ({plan.point[0]:.4f},\ "
                                         rf"{plan.point[1]:.4f})\ \mathrm{{m}}")
                       + f"<p>The ball is within reach for t in [{plan.window[0]:.3f}, {plan.window[1]:.3f}] s.</p>"
                       + _table(plan)
                       + f"<p>T<sub>s</sub>/T = {plan.ratio:.4f} (the coursework's weighted optimum); the joint "
                         "solution is the one that moves the joints least (l1 norm).</p>")
        play_button.disabled = False

    def on_plan(_):
        play_button.disabled = True
        session.run_in_background(compute, "Planning the catch", on_done=draw)

    def on_play(_):
        result = state.get("result")
        if result is None:
            return
        plan, ball = result["plan"], result["ball"]

        def run():
            frames = 90
            for k in range(frames + 1):
                t = plan.time * k / frames
                with session.holding(generation) as current, session.atomic():
                    if not current:
                        return
                    session.scene.set_pose(plan.joint_motion([t])[:, 0])
                    session.scene.add_marker("catch_ball", [*ball.position(t), 0.0], (250, 170, 40))
                time.sleep(max(plan.time, 1.5) / frames)
        threading.Thread(target=run, daemon=True).start()

    plan_button.on_click(on_plan)
    play_button.on_click(on_play)
