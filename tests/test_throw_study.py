"""One throw studied for display (app/core/throw/study.py, no GUI): the editable draft, the arm of a
session's parameter values, the evaluated throw (samples, portrait, flights) and where arm and
ball are during the animation."""
import math

import numpy as np
import pytest

from app.core.errors import UserError
from app.core.throw.arm import ThrowingArm
from app.core.throw.config import load_throw_config, thesis_throw
from app.core.throw.study import (PORTRAIT_RESTS, ThrowDraft, ThrowStudy, ball_at, evaluate, parse_points,
                                  portrait_range, wrist_curve)


@pytest.fixture(scope="module")
def arm():
    return ThrowingArm()


@pytest.fixture(scope="module")
def view_one(arm):
    return evaluate(arm, thesis_throw("throw1"))


def test_the_ball_leaves_the_hand_and_lands_on_the_marker(view_one):
    T = view_one.duration
    _q, at_release = ball_at(view_one, T)
    _q, just_after = ball_at(view_one, T + 1e-6)
    assert np.allclose(at_release, view_one.release.position, atol=1e-9)
    assert np.linalg.norm(just_after - at_release) < 1e-5
    q_end, landed = ball_at(view_one, T + view_one.flight_time() + 1.0)
    assert landed[1] == 0 and landed[0] == pytest.approx(view_one.release.distance_from_base, abs=1e-9)  # y set to 0
    assert np.allclose(q_end, view_one.samples.q[:, -1])                    # the arm holds its release pose
    # mid-swing: the arm at the sampled pose of that time, the ball at the tip of link 3
    t = 0.5 * T
    q, ball = ball_at(view_one, t)
    assert np.allclose(view_one.throw.arm.ball_position(q[:, None])[:, 0], ball, atol=2e-3)


def test_the_evaluated_throw_is_the_solved_throw(arm, view_one):
    throw = arm.solve(thesis_throw("throw1"))
    assert view_one.throw.theta_dot_e == pytest.approx(throw.theta_dot_e, rel=1e-12)
    assert view_one.samples.t[0] == 0 and view_one.samples.t[-1] == pytest.approx(throw.duration, rel=1e-12)
    assert len(view_one.portrait.curves) == PORTRAIT_RESTS + 1
    lo, hi = portrait_range(arm, view_one.spec)
    assert view_one.portrait.theta[0] == pytest.approx(lo, abs=1e-12) and view_one.portrait.theta[-1] == pytest.approx(hi, abs=1e-12)
    inside = np.isfinite(view_one.throw_curve)
    assert np.allclose(view_one.throw_curve[inside], throw.theta_dot(view_one.portrait.theta[inside]), rtol=1e-12)
    # both flights start at the release; the thesis's launches theta_dot along psi
    rel = view_one.release
    assert view_one.flights["true"].landing_x == pytest.approx(rel.distance_from_base, rel=1e-9)
    assert view_one.flights["thesis"].landing_x == pytest.approx(rel.distance_from_base_thesis, rel=1e-9)


def test_a_draft_makes_the_throw_it_was_made_from_or_says_why():
    spec = load_throw_config("optimized_thesis").spec
    draft = ThrowDraft.of(spec)
    back = draft.spec()
    assert back.a == pytest.approx(spec.a, abs=0) and back.psi == pytest.approx(spec.psi, rel=1e-15)
    copy = draft.copy()
    copy.a[0] += 1.0                                  # a copy shares no list with its original
    assert draft.a[0] == pytest.approx(spec.a[0], abs=0)
    draft.theta_dot_b = -1.0
    with pytest.raises(UserError, match="initial speed must not be negative"):
        draft.spec()
    raised = ThrowDraft.of(spec).raised()
    assert raised.degree_of("a") == len(spec.a) and raised.degree_of("b") == len(spec.b)
    s = np.linspace(0.0, 1.0, 7)
    from app.core.throw.bezier import bernstein
    assert np.allclose(bernstein(len(spec.a), s) @ raised.a, bernstein(len(spec.a) - 1, s) @ np.array(spec.a))
    with pytest.raises(UserError, match="expected 'a' or 'b'"):
        draft.points("c")
    with pytest.raises(UserError, match="at least two control points"):
        parse_points("1.5", "a")


def test_the_study_rebuilds_the_arm_only_when_the_parameters_change():
    study = ThrowStudy("throwing_arm")
    first = study.arm({"platform": 0.63})
    assert study.arm({"platform": 0.63}) is first
    lower = study.arm({"platform": 0.0})
    assert lower is not first and lower.shoulder_height == pytest.approx(first.shoulder_height - 0.63, abs=1e-12)
    with pytest.raises(UserError):
        study.arm({"l1": -1.0})


def test_the_wrist_curve_has_gaps_where_the_ball_cannot_be_reached(arm):
    spec = thesis_throw("throw3")                    # unreachable for s in about [0, 0.086]
    s, q3 = wrist_curve(arm, spec)
    assert np.isnan(q3[(s > 0.005) & (s < 0.08)]).all() and np.isfinite(q3[s > 0.1]).all()
    st = arm.constraint(spec, spec.theta_b + s[-1] * (spec.theta_e - spec.theta_b), dynamics=False)
    assert q3[-1] == pytest.approx(float(st.q[2, 0, 0]), abs=1e-12)
    assert math.isfinite(q3[-1])


def test_each_module_of_the_throw_package_imports_only_those_before_it():
    """The order of docs/throwing.md's table of app/core/throw/ (annotation-only imports aside)."""
    import ast
    from pathlib import Path

    order = ["bezier", "config", "reduced", "arm", "portrait", "simulation", "optimize", "thesis", "plants",
             "closed_loop", "montecarlo", "robust", "catch", "study"]
    root = Path(__file__).resolve().parents[1] / "app" / "core" / "throw"
    assert sorted(p.stem for p in root.glob("*.py") if p.stem != "__init__") == sorted(order)
    for name in order:
        tree = ast.parse((root / f"{name}.py").read_text(encoding="utf-8"))
        typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                       and getattr(node.test, "id", "") == "TYPE_CHECKING" for n in ast.walk(node)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level == 1 and id(node) not in typing_only:
                used = [node.module] if node.module else [a.name for a in node.names]
                for mod in used:
                    assert order.index(mod) < order.index(name), f"{name}.py imports {mod} (line {node.lineno})"
