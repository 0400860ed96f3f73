"""Exercises panel: walk through the shipped exam exercises (app/exercises) one step at a time.

Pick an exercise (filter by exam, topic or robot); the page switches to its robot in the
configuration the exercise describes and shows the question and the notes on the printed
solution. "Next" reveals the solution step by step, each typeset, with the links, joints,
arrows (velocities, forces), joint values against their bounds, points and paths of the step
drawn in 3D. The numbers of the exercise can be changed (a variant): the solution is recomputed
in the background, and a bad value is refused with a message while the last good solution
stays. The solution downloads as Markdown with LaTeX, or as a LaTeX fragment (app/core/tex.py).

``session.state["exercises"]["panel"]`` is the tab's ``ExercisesPanel``; ``open(id)``,
``show(k)`` and ``solve_variant({name: text})`` drive it from outside (tests, screenshots).
"""
from __future__ import annotations

import html
import threading
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from app.core.answer_check import check_exercise_answer, exercise_entries
from app.core.errors import UserError
from app.core.exercise import EXERCISES_DIR, Exercise, load_exercise
from app.core.expressions import ExpressionError, parse_number
from app.core.tex import solution_tex
from app.panels.exercise_scene import HintDrawer
from app.panels.exercise_variant import SOLUTIONS, Field, fields, format_value, parse_field
from app.panels.exercise_view import answers_html, notes_html, question_html, step_html, variant_html
from app.viewer import AnswerBox, JobCancelled, mathml

TITLE = "Exercises"
ORDER = 30
REBUILD = False          # the panel switches the robot itself: keep it across robot switches

ALL = "all"
HEADING = '<div style="font-weight:600;font-size:0.9em;color:#2e5eaa;margin:8px 0 2px 0">{}</div>'
EARLIER_HEADING = HEADING.format("Steps revealed so far")
ANSWERS_HEADING = HEADING.format("Numeric answers")
PICK = "(choose an exercise)"

_CATALOG: Dict[str, Tuple[float, Exercise]] = {}
_CATALOG_LOCK = threading.Lock()


def shipped_exercises() -> Tuple[List[Exercise], List[str]]:
    """Every exercise file in app/exercises (re-read when it changes) and a message for each one
    that does not load (it is left out of the list)."""
    out, errors = [], []
    for path in sorted(EXERCISES_DIR.glob("*.yaml")):
        if path.name.endswith(".expected.yaml"):
            continue
        try:
            mtime = path.stat().st_mtime
            with _CATALOG_LOCK:
                cached = _CATALOG.get(str(path))
            if cached is None or cached[0] != mtime:
                cached = (mtime, load_exercise(path))
                with _CATALOG_LOCK:
                    _CATALOG[str(path)] = cached
            out.append(cached[1])
        except (UserError, OSError) as exc:
            errors.append(f"{path.name}: {exc}")
    return out, errors


def option_label(ex: Exercise, width: int = 60) -> str:
    """The exercise dropdown's text: id and (shortened) title."""
    title = ex.title if len(ex.title) <= width else ex.title[: width - 1].rstrip() + "…"
    return f"{ex.id} · {title}"


def build(session) -> None:
    ExercisesPanel(session)


class ExercisesPanel:
    """The widgets, the walkthrough state and the 3D hints of one tab's Exercises panel."""

    def __init__(self, session):
        self.session = session
        self.gui = session.gui
        self.state = session.state.setdefault("exercises", {})
        self.hints = HintDrawer(session)
        self._lock = threading.RLock()
        self._fields: List[Tuple[Field, Any]] = []
        self._earlier_html = None
        self.exercises, errors = shipped_exercises()
        self._by_label = {option_label(ex): ex for ex in self.exercises}
        self._build(errors)
        self.state["panel"] = self
        session.on_robot_change(self._robot_changed)
        session.on_parameters_change(lambda _values: self._redraw())
        if self.exercise is not None:           # rebuilt (e.g. the tabs changed): restore
            self._show_exercise(self.exercise, keep=True)

    # -------------------------------------------------------------- state
    @property
    def exercise(self) -> Optional[Exercise]:
        return self.state.get("exercise")

    @property
    def solution(self):
        return self.state.get("solution")

    @property
    def index(self) -> int:
        return int(self.state.get("index", -1))

    def _alive(self) -> bool:
        return self.state.get("panel") is self and not self.session.closed

    # -------------------------------------------------------------- widgets
    def _build(self, errors: List[str]) -> None:
        gui = self.gui
        exams = sorted({ex.exam for ex in self.exercises if ex.exam})
        gui.add_html(mathml.label_html(
            f"{len(self.exercises)} exam exercises from {len(exams)} exams, solved by the engine. Read the "
            "question, try it, then reveal the solution one step at a time."))
        if errors:
            gui.add_html(mathml.label_html("Not loaded: " + "; ".join(errors)))
        filters = self.state.setdefault("filters", {"exam": ALL, "topic": ALL, "robot": ALL})
        topics = sorted({t for ex in self.exercises for t in ex.topics})
        robots = sorted({ex.robot for ex in self.exercises})
        with gui.add_folder("Filter the list", expand_by_default=False):
            self.exam = gui.add_dropdown("By exam", [ALL] + exams, initial_value=_valid(filters["exam"], exams),
                                         hint="exam date (and -mid for midterms)")
            self.topic = gui.add_dropdown("By topic", [ALL] + topics, initial_value=_valid(filters["topic"], topics))
            self.robot = gui.add_dropdown("By robot", [ALL] + robots, initial_value=_valid(filters["robot"], robots),
                                          hint="the robot file the exercise uses")
        options = self._options()
        current = option_label(self.exercise) if self.exercise is not None else PICK
        self.picker = gui.add_dropdown("Exercise", options, initial_value=current if current in options else PICK,
                                       hint="exam date # number · title")
        self.header = gui.add_html("")
        self.notes = gui.add_html("")
        self.variant_line = gui.add_html("")
        self.back_button = gui.add_button("Show the exercise's robot", visible=False,
                                          hint="another robot was picked: switch back to the exercise's")
        self.variant_folder = gui.add_folder("Change the numbers (variant)", expand_by_default=False)
        with self.variant_folder:
            self.variant_help = gui.add_html(mathml.label_html(
                "Type other values (numbers, expressions such as pi/4, lists like the originals) and "
                "press Solve. Symbolic steps keep the robot's parameters as symbols: their numbers change "
                "the numeric steps and the drawing."))
            self.variant_buttons = gui.add_button_group("", ("Solve this variant", "Exam's numbers"))
        self.nav = gui.add_button_group("", ("◀ Previous", "Next ▶", "Show all"))
        self.status = gui.add_html("")
        self.card = gui.add_html("")
        self.answers = gui.add_html("")
        self.check_box = AnswerBox(self.session, (), self._check_answer, follow_robot=False)
        self.download = gui.add_button("Download the solution (Markdown)", disabled=True,
                                       hint="steps and answers as Markdown with LaTeX ($$ ... $$)")
        self.download_tex = gui.add_button("Download the solution (LaTeX)", disabled=True,
                                           hint="steps as a .tex fragment (amsmath)")
        self.sheet_folder = gui.add_folder("Printable exam sheet", expand_by_default=False)
        with self.sheet_folder:
            gui.add_html(mathml.label_html(
                "A printable sheet of the exercise(s) with new numbers (each variant re-solved) and its "
                "solutions, as HTML and PDF (python -m app sheet)."))
            self.sheet_ids = gui.add_text("Exercises", "", hint="exercise ids separated by commas, e.g. "
                                                                "2009-09-10#2, 2020-06-05#1; empty: the one shown")
            self.sheet_seed = gui.add_number("Seed", 0, min=0, max=10 ** 6, step=1,
                                             hint="the same seed gives the same numbers")
            self.sheet_pdf = gui.add_checkbox("PDF too", True, hint="print PDFs with headless Chromium (slower)")
            self.sheet_button = gui.add_button("Exam sheet", hint="make the sheet (in the background)")
            self.sheet_status = gui.add_html("")
        self._sheet_downloads = None
        self._earlier_html = gui.add_html("")

        for dropdown, key in ((self.exam, "exam"), (self.topic, "topic"), (self.robot, "robot")):
            dropdown.on_update(lambda event, key=key: self._filter_changed(key, event))
        self.picker.on_update(self._picked)
        self.nav.on_click(self._navigate)
        self.variant_buttons.on_click(self._variant_clicked)
        self.download.on_click(self._download)
        self.download_tex.on_click(self._download_tex)
        self.back_button.on_click(lambda _: self._ensure_robot())
        self.sheet_button.on_click(lambda _: self.make_sheet())
        self._render()

    def _options(self) -> List[str]:
        f = self.state["filters"]
        chosen = [ex for ex in self.exercises
                  if (f["exam"] == ALL or ex.exam == f["exam"]) and (f["topic"] == ALL or f["topic"] in ex.topics)
                  and (f["robot"] == ALL or ex.robot == f["robot"])]
        return [PICK] + [option_label(ex) for ex in chosen]

    def _filter_changed(self, key: str, event) -> None:
        if event.client is None:
            return
        self.state["filters"][key] = event.target.value
        options = self._options()
        self.picker.options = options
        if self.exercise is not None and option_label(self.exercise) in options:
            self.picker.value = option_label(self.exercise)
        elif len(options) > 1:
            self.picker.value = options[1]
            self.open(self._by_label[options[1]].id)
        else:
            self.picker.value = PICK

    def _picked(self, event) -> None:
        if event.client is None:
            return
        ex = self._by_label.get(self.picker.value)
        if ex is not None and ex is not self.exercise:
            self.open(ex.id)

    # -------------------------------------------------------------- opening an exercise
    def open(self, exercise_id: str) -> None:
        """Show an exercise (by id, e.g. ``2004-03-25#1``): question, robot, and its solution
        (solved in the background)."""
        ex = next((e for e in self.exercises if e.id == exercise_id), None)
        if ex is None:
            raise UserError(f"unknown exercise '{exercise_id}'")
        with self._lock:
            self.state.update(exercise=ex, values={}, texts={}, index=-1, solution=None, solved_values=None)
        self.session.remember(exercise=ex.id, step=None)
        self.check_box.reset()
        label = option_label(ex)
        if label in self.picker.options and self.picker.value != label:
            self.picker.value = label
        self._show_exercise(ex)

    def _show_exercise(self, ex: Exercise, keep: bool = False) -> None:
        try:
            robot = self.session.robot_named(ex.robot_ref)
        except UserError as exc:
            self.session.notify(f"Cannot open {ex.id}", str(exc), error=True)
            return
        self.header.content = question_html(ex, robot.title)
        self.notes.content = ""            # notes appear with their step, general ones after the last step
        self._build_fields(ex, robot)
        self._render()
        if keep and self.session.robot_name != ex.robot_ref:    # rebuilt while another robot is shown
            self.back_button.visible = True
        elif self._ensure_robot():
            self._apply_scene()
        if not keep or self.solution is None:
            self._solve(dict(self.state.get("values") or {}))

    def _ensure_robot(self) -> bool:
        """Switch the session to the exercise's robot; True when it is already shown."""
        ex = self.exercise
        if ex is None:
            return False
        if self.session.robot_name == ex.robot_ref:
            self.back_button.visible = False
            return True
        self.hints.clear()
        self.session.load_robot(ex.robot_ref)
        return False

    def _robot_changed(self, _robot) -> None:
        ex = self.exercise
        if ex is None:
            return
        if self.session.robot_name == ex.robot_ref:
            self.session.remember(exercise=ex.id, step=str(self.index + 1) if self.index >= 0 else None)
            self.back_button.visible = False
            self._apply_scene()
        else:                                 # the student picked another robot
            self.hints.clear()
            self.session.scene.clear_highlight()
            self.back_button.visible = True

    # -------------------------------------------------------------- the robot as the exercise describes it
    def _numbers(self) -> Dict[str, Any]:
        """The exercise's given data with the variant applied."""
        ex = self.exercise
        data = dict(ex.given)
        conf = dict(ex.configuration)
        for key, value in (self.state.get("solved_values") or self.state.get("values") or {}).items():
            section, name = key.split(":", 1)
            (conf if section == "configuration" else data)[name] = value
        return {"given": data, "configuration": conf}

    def display_q(self) -> np.ndarray:
        """The configuration of the exercise: coordinates given as data, else its
        ``configuration``, else the robot's current ones."""
        session = self.session
        numbers = self._numbers()
        q = session.q.copy()
        for i, c in enumerate(session.robot.coordinates):
            for source in (numbers["given"], numbers["configuration"]):
                if c in source:
                    value = _constant(source[c])
                    if value is not None:
                        q[i] = value
                        break
        return q

    def _parameters(self) -> Dict[str, float]:
        robot = self.session.robot
        values = robot.parameter_values()
        for name, value in self._numbers()["given"].items():
            if name in values:
                number = _constant(value)
                if number is not None:
                    values[name] = number
        return values

    def _apply_scene(self) -> None:
        """Parameters and configuration of the exercise (or of the current step), and its hints."""
        if not self._alive() or self.exercise is None or self.session.robot_name != self.exercise.robot_ref:
            return
        params = self._parameters()
        if any(abs(self.session.params.get(k, v) - v) > 0 for k, v in params.items()):
            try:
                self.session.set_parameters(params)     # the hints follow via on_parameters_change
            except UserError as exc:
                self.session.notify("Parameters of the exercise", str(exc), error=True)
        self._redraw()

    def _redraw(self) -> None:
        """Draw the current step's hints (or none) with the robot where the step wants it."""
        with self._lock:
            ex, sol, k = self.exercise, self.solution, self.index
            if ex is None or not self._alive() or self.session.robot_name != ex.robot_ref:
                return
            q = self.display_q()
            highlight = sol.steps[k].highlight if sol is not None and 0 <= k < len(sol.steps) else {}
            conf = highlight.get("configuration") or {}
            for i, c in enumerate(self.session.robot.coordinates):
                if c in conf:
                    q[i] = float(conf[c])
            if not np.allclose(q, self.session.q):
                self.session.set_q(q)
            self.hints.draw(highlight, q)
            if sol is not None and 0 <= k < len(sol.steps):
                self.card.content = step_html(sol.steps[k], k, len(sol.steps), current=True,
                                              arrow_scale=self.hints.arrow_scale, notes=sol.step_notes(k))

    # -------------------------------------------------------------- variants
    def _build_fields(self, ex: Exercise, robot) -> None:
        for _, handle in self._fields:
            handle.remove()
        self._fields = []
        texts = self.state.get("texts") or {}
        with self.variant_folder:
            given = [f for f in fields(ex, robot) if f.section != "parameter"]
            params = [f for f in fields(ex, robot) if f.section == "parameter"]
            for f in given + params:
                unit = f" [{f.unit}]" if f.unit else ""
                label = f"{f.name}{unit}" if f.section != "parameter" else f"{f.name}{unit} (robot)"
                handle = self.gui.add_text(label, texts.get(f.key, f.text), hint=f"{f.doc} (exam: {f.text})")
                self._fields.append((f, handle))
        self.variant_buttons.remove()           # keep the buttons below the fields
        with self.variant_folder:
            self.variant_buttons = self.gui.add_button_group("", ("Solve this variant", "Exam's numbers"))
        self.variant_buttons.on_click(self._variant_clicked)

    def _variant_clicked(self, event) -> None:
        if event.target.value.startswith("Exam"):
            self.reset_variant()
        else:
            self.solve_variant({f.name: h.value for f, h in self._fields})

    def reset_variant(self) -> None:
        """Back to the exercise's own numbers."""
        for f, handle in self._fields:
            handle.value = f.text
        self.state["texts"] = {}
        self._solve({})

    def solve_variant(self, typed: Dict[str, str]) -> bool:
        """Solve with the typed values (field name -> text; fields not named keep their text).
        A bad value is a notification and changes nothing; returns whether solving started."""
        ex = self.exercise
        if ex is None:
            return False
        robot = self.session.robot_named(ex.robot_ref)
        values, texts = {}, {}
        try:
            for f, handle in self._fields:
                text = typed.get(f.name, handle.value)
                if handle.value != text:
                    handle.value = text
                if text.strip() == f.text:
                    continue
                value = parse_field(f, text, robot)
                if format_value(value) != format_value(f.original):
                    values[f.key] = value
                    texts[f.key] = text
        except UserError as exc:
            self.session.notify("Variant not solved", str(exc), error=True)
            self.status.content = _message(f"Not solved: {exc}. The solution shown is still the last good one.",
                                           error=True)
            return False
        self.state["texts"] = texts
        self._solve(values)
        return True

    def _solve(self, values: Dict[str, Any]) -> None:
        ex = self.exercise
        if ex is None:
            return
        self.state["values"] = values
        self.status.content = _message(f"Solving {ex.id} ...")

        def work(progress):
            try:
                return SOLUTIONS.solve(ex, values, progress)
            except JobCancelled:
                if self._alive() and self.exercise is ex:
                    self.status.content = _message(f"Solving {ex.id}: cancelled.")
                raise
            except Exception as exc:
                self._failed(ex, exc)
                raise

        def done(sol):
            with self._lock:
                if not self._alive() or self.exercise is not ex or self.state.get("values") != values:
                    return
                previous = self.solution
                self.state["solution"] = sol
                self.state["solved_values"] = values
                if previous is not None and self.index == len(previous.steps) - 1:
                    self.state["index"] = len(sol.steps) - 1          # the whole solution stays revealed
                else:
                    self.state["index"] = min(self.index, len(sol.steps) - 1)
                self._render()
            self._apply_scene()

        self.session.run_in_background(work, f"Solving {ex.id}", on_done=done)

    def _failed(self, ex: Exercise, exc: Exception) -> None:
        if not self._alive() or self.exercise is not ex:
            return
        kept = " The solution shown is still the last good one." if self.solution is not None else ""
        self.status.content = _message(f"Could not solve: {exc}.{kept}", error=True)

    # -------------------------------------------------------------- steps
    def _navigate(self, event) -> None:
        sol = self.solution
        if sol is None:
            self.session.notify("Still solving", "the solution appears in a moment")
            return
        value = event.target.value
        if value.startswith("Next"):
            self.show(self.index + 1)
        elif value.startswith("◀"):
            self.show(self.index - 1)
        else:
            self.show(len(sol.steps) - 1)

    def show(self, k: int) -> None:
        """Reveal steps 1..k+1 (k = -1: none) and light up step k in 3D."""
        sol = self.solution
        if sol is None:
            return
        with self._lock:
            self.state["index"] = max(-1, min(len(sol.steps) - 1, int(k)))
            self._render()
            self._redraw()
        self.session.remember(step=str(self.index + 1) if self.index >= 0 else None)

    def _render(self) -> None:
        with self._lock:          # callbacks run in a thread pool: one rendering at a time
            self._render_locked()

    def _check_answer(self, entry: str, text: str, hint: int):
        """"Check my answer" on a revealed step's answer (runs in a background job)."""
        sol = self.solution
        if sol is None:
            raise UserError("the solution is still being computed: check again in a moment")
        return check_exercise_answer(sol, entry, text, hint=hint)

    def _render_locked(self) -> None:
        ex, sol, k = self.exercise, self.solution, self.index
        self.check_box.set_entries(exercise_entries(sol, upto_step=k) if sol is not None and k >= 0 else ())
        self.download.disabled = self.download_tex.disabled = sol is None
        if ex is None:
            self.status.content = ""
            self.card.content = mathml.label_html("Choose an exercise above.")
            self._earlier_html.content = ""
            self.answers.content = ""
            self.variant_line.content = ""
            return
        solved = self.state.get("solved_values") or {}
        self.variant_line.content = variant_html({key.split(":", 1)[1]: format_value(v) for key, v in solved.items()})
        if sol is None:
            self.card.content = mathml.label_html("Solving ...")
            self._earlier_html.content = ""
            self.answers.content = ""
            return
        n = len(sol.steps)
        self.status.content = _message(f"{k + 1} of {n} steps revealed" +
                                       (" — the whole solution." if k == n - 1 else ". Next ▶ reveals the next one."))
        if k < 0:
            self.card.content = (f'<div class="r2-step" data-step="-1" style="color:#444;font-size:0.9em;margin:4px 0">'
                                 f"Read the question and try it yourself; then press <b>Next ▶</b>. "
                                 f"The solution has {n} steps.</div>")
        else:
            self.card.content = step_html(sol.steps[k], k, n, current=True, arrow_scale=self.hints.arrow_scale,
                                          notes=sol.step_notes(k))
        earlier = "".join(step_html(sol.steps[i], i, n, notes=sol.step_notes(i)) for i in range(max(k, 0)))
        self._earlier_html.content = (EARLIER_HEADING + earlier) if earlier else ""
        if k == n - 1:
            types = [b.joint.type for b in sol.robot.bodies if b.joint.type != "fixed"]
            self.answers.content = ANSWERS_HEADING + answers_html(sol.answers, types) + notes_html(sol.general_notes())
        else:
            self.answers.content = ""

    # -------------------------------------------------------------- download
    def markdown(self) -> str:
        """The solution shown, as Markdown with LaTeX (with the variant's numbers when changed)."""
        sol = self.solution
        md = sol.markdown()
        solved = self.state.get("solved_values") or {}
        if solved:
            lines = "\n".join(f"- {key.split(':', 1)[1]} = {format_value(v)}" for key, v in solved.items())
            md = md.replace("\n## Solution\n", f"\n## Numbers of this variant\n\n{lines}\n\n## Solution\n", 1)
        return md

    def _stem(self) -> str:
        return self.exercise.id.replace("#", "_") + ("_variant" if self.state.get("solved_values") else "")

    def _download(self, event) -> None:
        if self.solution is None:
            return
        event.client.send_file_download(f"{self._stem()}.md", self.markdown().encode("utf-8"), save_immediately=True)

    def _download_tex(self, event) -> None:
        if self.solution is None:
            return
        solved = self.state.get("solved_values") or {}
        variant = {key.split(":", 1)[1]: format_value(v) for key, v in solved.items()}
        event.client.send_file_download(f"{self._stem()}.tex", solution_tex(self.solution, variant).encode("utf-8"),
                                        save_immediately=True)


    # -------------------------------------------------------------- exam sheet
    def make_sheet(self, wait: bool = False):
        """Make the exam sheet of the typed exercises (or the one shown) in the background, then
        offer its files as downloads (app/viewer/sheets.py ``sheet_files``)."""
        from app.viewer import parse_exercise_ids, sheet_files
        ids = parse_exercise_ids(self.sheet_ids.value, [self.exercise.id] if self.exercise is not None else [])
        known = {ex.id for ex in self.exercises}
        unknown = [i for i in ids if i not in known]
        if not ids or unknown:
            text = (f"unknown exercise(s): {', '.join(unknown)}" if unknown
                    else "open an exercise or type exercise ids first")
            self.sheet_status.content = _message(text, error=True)
            self.session.notify("Exam sheet", text, error=True)
            return None
        seed, pdf = int(self.sheet_seed.value), bool(self.sheet_pdf.value)
        self.sheet_button.disabled = True
        self.sheet_status.content = _message(f"making the sheet of {', '.join(ids)} ...")
        self.state["sheet_files"] = None

        def work(progress):
            try:
                return sheet_files(ids, seed, pdf=pdf, progress=progress)
            finally:
                self.sheet_button.disabled = False

        def done(result):
            files, note = result
            if not self._alive():
                return
            self.state["sheet_files"] = files
            stem = "sheet_" + "_".join(i.replace("#", "-") for i in ids[:3]) + ("_etc" if len(ids) > 3 else "")
            if self._sheet_downloads is not None:
                self._sheet_downloads.remove()
            with self.sheet_folder:
                self._sheet_downloads = self.gui.add_button_group("Download", tuple(files))
            self._sheet_downloads.on_click(
                lambda event: event.client.send_file_download(f"{stem}_{event.target.value}",
                                                              files[event.target.value], save_immediately=True))
            self.sheet_status.content = _message(f"sheet of {', '.join(ids)}, seed {seed}: "
                                                 + ", ".join(files) + (f" ({note})" if note else ""))

        future = self.session.run_in_background(work, "Exam sheet", on_done=done)
        if wait:
            future.result()
        return future


def _valid(value: str, options: List[str]) -> str:
    return value if value in options else ALL


def _constant(value) -> Optional[float]:
    """A number from a given value (number or constant expression such as pi/4), else None."""
    if isinstance(value, bool):
        return None
    try:
        return parse_number(value if isinstance(value, str) else float(value))
    except (ExpressionError, TypeError, ValueError):
        return None


def _message(text: str, error: bool = False) -> str:
    color = "#b3261e" if error else "#444"
    return f'<div class="r2-exercise-status" style="font-size:0.86em;color:{color};margin:2px 0">{html.escape(text)}</div>'
