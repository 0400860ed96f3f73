"""Model panel: M(q), c and C(q, q'), g(q), springs and friction, Christoffel matrices and the
linear parametrization, typeset, each with its numeric value at the current q, q' and parameters."""
from __future__ import annotations

from typing import Callable, Dict, List, NamedTuple, Tuple

import numpy as np
import sympy as sp

from app.core.answer_check import check_model_entry, model_entries
from app.core.numeric import NumericModel, compiled_model
from app.core.steps import shorthand_is_clear
from app.core.tex import model_tex
from app.viewer import AnswerBox, html_cache, mathml

TITLE = "Model"
ORDER = 10

_HTML: Dict[tuple, str] = {}     # typeset symbolic sections of robots without a file hash


def _cached(key: tuple, make: Callable[[], str]) -> str:
    """A typeset section, per robot file: from memory or the disk cache (app/viewer/html_cache.py)
    when the robot has a file hash, so that switching to a robot shown before is instant."""
    if key[0]:
        return html_cache.cached_html(key, make)
    html = _HTML.get(key)
    if html is None:
        html = _HTML[key] = make()
    return html


class Section(NamedTuple):
    """A folder of the Model tab: its typeset term (``blocks()``: LaTeX blocks), the name of its
    live value (a key of ``build``'s values; "" for none), whether it starts open, a note above."""
    title: str
    blocks: Callable[[], List[str]]
    value: str = ""
    expanded: bool = True
    note: str = ""


def _sections(robot, dyn, width: Callable[[], float], short: bool) -> List[Section]:
    """The Model tab's folders, laid out for ``width()`` em (read when typeset: presenter mode
    lays them out again)."""
    coords = list(robot.coordinates)

    def blocks(name, matrix, entry, symmetric=False):
        return mathml.matrix_latex_blocks(name, matrix, coords, entry, width_em=width(),
                                          symmetric=symmetric, short_trig=short)

    def christoffel():
        out = []
        for i, Ci in enumerate(dyn.christoffel):
            out += blocks(f"C_{{{i + 1}}}(q)", Ci, f"c_{{{i + 1},#}}", symmetric=True)
        return out

    par = dyn.parametrization
    known = ", ".join(par.known) or "none"
    out = [Section("Inertia matrix M(q)", lambda: blocks("M(q)", dyn.M, "m", symmetric=True), "M"),
           Section("Coriolis and centrifugal terms c(q, q̇)", lambda: blocks(r"c(q,\dot q)", dyn.c, "c"), "c"),
           Section("Factorization C(q, q̇) (Christoffel)", lambda: blocks(r"C(q,\dot q)", dyn.C, "c"), "C", False,
                   "c = C(q, q̇) q̇ with C from the Christoffel symbols: Ṁ − 2C is skew-symmetric."),
           Section("Gravity g(q)", lambda: blocks("g(q)", dyn.g, "g"), "g")]
    if any(e != 0 for e in dyn.spring):
        out.append(Section("Springs k(q)", lambda: blocks("k(q)", dyn.spring, "k"), "k"))
    if any(e != 0 for e in dyn.friction):
        out.append(Section("Friction", lambda: blocks(r"\tau_f", dyn.friction, r"\tau_f"), r"\tau_f"))
    out += [Section("Christoffel matrices", christoffel, "", False,
                    "c_i = q̇ᵀ C_i(q) q̇, with C_i = ½ (∂m_i/∂q + (∂m_i/∂q)ᵀ − ∂M/∂q_i)."),
            Section(f"Linear parametrization Y a ({par.count} coefficients)",
                    lambda: blocks(r"Y(q,\dot q,\ddot q)", par.Y, "y") + blocks("a", sp.Matrix(par.a), "a"), "a",
                    False, f"τ = Y a with a minimal set of dynamic coefficients (known data: {known})."),
            Section("Adaptive regressor Y(q, q̇, q̇r, q̈r)", lambda: blocks(r"Y_r", par.Y_ref, "y"), "", False,
                    "Y_r a = M q̈r + C(q, q̇) q̇r + g (+ springs, friction): the Slotine-Li regressor.")]
    return out


def _typeset(robot, title: str, make_blocks: Callable[[], List[str]], short: bool, width: float) -> str:
    """A section's MathML, made once per robot file and layout (``_cached``)."""
    return _cached((robot.content_hash, title, short, width), lambda: mathml.blocks_html(make_blocks()))


def warm(robot, dyn) -> None:
    """What building the tab for ``robot`` computes that outlives it, done ahead (the server calls
    it at idle: app/viewer/server.py): the compiled functions of its live values and its typeset
    sections in the default layout.

    >>> from app.core.dynamics import derive
    >>> from app.core.robot import load_robot
    >>> robot = load_robot("planar_2r")
    >>> warm(robot, derive(robot))
    """
    num = NumericModel(robot, dynamics=dyn)
    q, dq = np.zeros(robot.n), np.ones(robot.n)
    values = _value_functions(robot, dyn, num, lambda: q, lambda: dq, robot.parameter_values)
    short = shorthand_is_clear(robot.parameters)
    for spec in _sections(robot, dyn, lambda: mathml.PANEL_WIDTH_EM, short):
        _typeset(robot, spec.title, spec.blocks, short, mathml.PANEL_WIDTH_EM)
        if spec.value:
            values[spec.value]()


def build(session) -> None:
    gui = session.gui
    dyn, robot = session.dynamics, session.robot
    coords = list(robot.coordinates)
    n = robot.n
    dq_state = {"dq": np.ones(n)}
    updaters: List[Tuple[object, Callable[[], str]]] = []

    short = shorthand_is_clear(robot.parameters)

    presenter = session.presenter
    layout = {"width": presenter.math_width_em(mathml.PANEL_WIDTH_EM)}
    symbolic: List[Tuple[object, str, Callable[[], List[str]]]] = []

    def typeset(title, make_blocks):
        return _typeset(robot, title, make_blocks, short, layout["width"])

    legend = (" Shorthand: c₁ = cos q₁, s₁₂ = sin(q₁ + q₂), and so on." if short and
              all(len(c) == 2 for c in coords) else "")
    gui.add_html(f'<span class="r2-model" data-robot="{robot.name}"></span>' + mathml.label_html(
        "Symbolic model of the robot file; the blue values are evaluated at the sliders' q, the "
        "velocity q̇ below, and the current parameters." + legend))
    _velocity_fields(gui, coords, dq_state, lambda: refresh())

    num = session.numeric
    values = _value_functions(robot, dyn, num, lambda: session.q, lambda: dq_state["dq"], lambda: session.params)

    for spec in _sections(robot, dyn, lambda: layout["width"], short):
        # a folder with the typeset symbolic term and its live value
        with gui.add_folder(spec.title, expand_by_default=spec.expanded):
            if spec.note:
                gui.add_html(mathml.label_html(spec.note))
            symbolic.append((gui.add_html(typeset(spec.title, spec.blocks)), spec.title, spec.blocks))
            if spec.value:
                updaters.append((gui.add_html(""), _live_value(spec.value, values[spec.value])))

    session.state["model_answer"] = AnswerBox(
        session, model_entries(robot, dyn),
        lambda entry, text, hint: check_model_entry(robot, dyn, entry, text, hint=hint), expand=True)

    _download_button(gui, robot, dyn)

    def refresh(*_):
        for handle, fn in updaters:
            handle.content = fn()

    generation = session.generation
    session.on_presenter_change(lambda on: _relayout(session, generation, layout, symbolic, typeset))
    refresh()
    session.on_q_change(refresh)
    session.on_parameters_change(refresh)


def _value_functions(robot, dyn, num, q: Callable, dq: Callable, params: Callable) -> Dict[str, Callable]:
    """The live value of each section (``Section.value`` -> a function of no argument), at the
    state ``q()``, ``dq()`` and parameter values ``params()`` read when called."""
    a_fn = compiled_model(robot, dyn).coefficients()
    return {"M": lambda: num.M(q()), "c": lambda: num.c(q(), dq()), "C": lambda: num.C(q(), dq()),
            "g": lambda: num.g(q()), "k": lambda: num.spring(q()), r"\tau_f": lambda: num.friction(dq()),
            "a": lambda: np.asarray(a_fn([params()[k] for k in robot.parameters]), float).ravel()}


def _live_value(name_latex: str, fn: Callable[[], np.ndarray]) -> Callable[[], str]:
    """The blue line under a term: ``name = value`` typeset (``fn()`` gives the value)."""
    return lambda: mathml.math_html(f"{name_latex} = {mathml.numeric_latex(fn())}", css_class="r2-num")


def _velocity_fields(gui, coords, dq_state, refresh) -> None:
    """The folder of the velocity q̇ used for C and c (``dq_state["dq"]``, then ``refresh()``)."""
    with gui.add_folder("Velocity q̇ for C and c", expand_by_default=False):
        fields = []
        for i, name in enumerate(coords):
            field = gui.add_number(f"d{name}", 1.0, step=0.1, hint=f"velocity of {name} used for C(q, q̇) and c")
            fields.append(field)

        def velocity_changed(_event):
            dq_state["dq"] = np.array([float(f.value) for f in fields])
            refresh()

        for field in fields:
            field.on_update(velocity_changed)


def _download_button(gui, robot, dyn) -> None:
    download = gui.add_button("Download the model (LaTeX)", hint="a .tex fragment (amsmath) of the formulas above "
                              "and the derivation steps")
    download.on_click(lambda event: event.client.send_file_download(
        f"{robot.name}_model.tex", model_tex(robot, dyn, steps=True).encode("utf-8"), save_immediately=True))


def _relayout(session, generation: int, layout: Dict, symbolic: List, typeset: Callable) -> None:
    """Presenter mode: the formulas laid out again for the width of the larger math."""
    if session.generation != generation:
        return
    width = session.presenter.math_width_em(mathml.PANEL_WIDTH_EM)

    def work(progress):
        progress(0.0, "formulas")
        return [typeset(title, make_blocks) for _, title, make_blocks in symbolic]

    def done(htmls):
        with session.holding(generation) as current:
            if current and layout["width"] == width:
                for (handle, _, _), html in zip(symbolic, htmls):
                    handle.content = html

    layout["width"] = width
    session.run_in_background(work, "Laying out the formulas", on_done=done)
