"""Exercises as data: loading exercise files and solving them with the engine.

An exercise file (YAML, app/exercises/<exam>_<n>.yaml, format in docs/exercise-format.md) says
which robot it uses, the paraphrased question, the data given, and the tasks: calls into the
engine (task kinds registered in app.core.tasks). ``solve`` runs the tasks in order and returns
the steps and the named answers. Expected answers live beside the exercise in
``<file>.expected.yaml`` and are read by the tests only, never by ``solve``.

>>> ex = load_exercise("2004-03-25#1")
>>> sol = solve(ex)
>>> sol.answers["regressor_count"]
3
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional


from . import reproducible_sympy
from .catalog import EXERCISE_SUFFIXES, EXERCISES_DIR, exercise_files, named_file, shipped_exercise
from .dynamics import Dynamics, derive
from .errors import UserError
from .expressions import ExpressionError, parse_expression
from .files import load_yaml, read_user_file
from .robot import ParameterError, RobotModel, load_robot, parse_robot, robot_path
from .steps import Step

class ExerciseError(UserError):
    """An exercise file is malformed or asks for something the engine cannot do."""


@dataclass
class Exercise:
    id: str
    title: str
    robot: str                      # shipped robot name or path (relative paths: to the file)
    question: str
    tasks: List[dict]
    exam: str = ""
    number: str = ""
    topics: List[str] = field(default_factory=list)
    given: Dict[str, Any] = field(default_factory=dict)      # parameter values and other data
    configuration: Dict[str, float] = field(default_factory=dict)
    notes: List[str] = field(default_factory=list)
    source: str = ""
    #: per note, what it concerns: {"answer": name} or {"step": title} (None: the whole exercise)
    note_targets: List[Optional[dict]] = field(default_factory=list)

    @property
    def robot_ref(self) -> str:
        p = Path(self.robot)
        if self.source and (p.suffix in (".yaml", ".yml") or "/" in self.robot):
            if not p.is_absolute():
                p = Path(self.source).parent / p
            return str(p)
        return self.robot

    def load_robot(self) -> RobotModel:
        return load_robot(self.robot_ref)


@dataclass
class Solution:
    exercise: Exercise
    steps: List[Step]
    answers: Dict[str, Any]
    notes: List[str]
    robot: RobotModel
    #: per note, the index of the step it concerns (None: about the whole exercise, shown at the end)
    note_steps: List[Optional[int]] = field(default_factory=list)
    #: answer name -> index of the step that shows it
    answer_steps: Dict[str, int] = field(default_factory=dict)

    def answer_step(self, name: str) -> Optional[int]:
        """Index of the step that shows the answer ``name`` (None when unknown)."""
        k = self.answer_steps.get(name)
        return None if k is None or k < 0 else k

    def step_notes(self, k: int) -> List[str]:
        """The notes on the printed solution that concern step ``k`` (0-based)."""
        return [n for n, s in zip(self.notes, self.note_steps) if s == k]

    def general_notes(self) -> List[str]:
        """The notes attached to no step (shown after the last step)."""
        steps = self.note_steps + [None] * (len(self.notes) - len(self.note_steps))
        return [n for n, s in zip(self.notes, steps) if s is None]

    def markdown(self) -> str:
        """The whole solution as Markdown: formulas in $$ ... $$, inline math in $ ... $ (the text
        convention of app/core/mathtext.py), numbers as the steps print them (rounded), each note
        on the printed solution under the step it concerns."""
        lines = [f"# {self.exercise.id}: {self.exercise.title}", "", f"Robot: {self.robot.title}", "",
                 "## Question", "", self.exercise.question.strip(), "", "## Solution", ""]
        for k, st in enumerate(self.steps):
            lines += [f"### {k + 1}. {st.title}", ""]
            if st.text:
                lines += [st.text, ""]
            if st.latex:
                lines += ["$$", st.latex, "$$", ""]
            lines += [f"> **Note on the printed solution:** {n}\n" for n in self.step_notes(k)]
        general = self.general_notes()
        if general:
            lines += ["## Notes on the printed solution", ""] + [f"- {n}" for n in general] + [""]
        return "\n".join(lines)


# ---------------------------------------------------------------------- task context
class TaskContext:
    """What a task sees: the robot, its (lazily derived) dynamics, the given data, and where to put
    steps and answers. Tasks call ``ctx.step(...)`` and ``ctx.answer(name, value)``."""

    def __init__(self, exercise: Exercise, robot: RobotModel, given: Mapping[str, Any],
                 progress: Optional[Callable[[float, str], None]] = None):
        self.exercise = exercise
        self.robot = robot
        self.given = dict(given)
        self.steps: List[Step] = []
        self.answers: Dict[str, Any] = {}
        self.notes: List[str] = list(exercise.notes)
        self.progress = progress or (lambda f, m: None)
        self._derived: Dict[tuple, Dynamics] = {}
        #: what earlier tasks leave for later ones by name (a jacobian task's symbolic and numeric J ...)
        self.objects: Dict[str, Any] = {}
        self.current = "task"                      # the task being solved, for messages
        self.answer_steps: Dict[str, int] = {}      # answer -> index of the step that shows it

    def dynamics(self, known=None) -> Dynamics:
        key = tuple(sorted(known)) if known is not None else None
        if key not in self._derived:
            self._derived[key] = derive(self.robot, known=known)
        return self._derived[key]

    @cached_property
    def numeric(self):
        from .numeric import NumericModel
        values = {k: v for k, v in self.given.items() if k in self.robot.parameters}
        return NumericModel(self.robot, values, self.dynamics())

    def step(self, title: str, latex: str = "", text: str = "", bodies=(), joints=(), **highlight) -> Step:
        hl = {k: list(v) for k, v in (("bodies", bodies), ("joints", joints)) if v}
        hl.update({k: v for k, v in highlight.items() if v})
        st = Step(title, latex, text, hl)
        self.steps.append(st)
        return st

    def answer(self, name: str, value) -> None:
        """Store a named answer; a name that is also a ``given`` entry is refused (later tasks
        read names as answers first, so the given value would be silently shadowed)."""
        if name in self.given:
            raise ExerciseError(f"{self.exercise.source or self.exercise.id}: {self.current}: the answer "
                                f"'{name}' has the same name as the given entry '{name}': rename the given "
                                f"entry (e.g. '{name}_max' or '{name}_given')")
        self.answers[name] = value
        self.answer_steps[name] = len(self.steps) - 1

    def expr(self, text, where: str = "expression"):
        """Parse an expression of the exercise (robot symbols and coordinates) safely."""
        try:
            return parse_expression(text)
        except ExpressionError as exc:
            raise ExerciseError(f"{self.exercise.source or self.exercise.id}: {where}: {exc}") from None


# ---------------------------------------------------------------------- loading
def exercise_path(id_or_path: str | Path) -> Path:
    path = named_file(id_or_path, shipped_exercise(id_or_path), EXERCISE_SUFFIXES, ExerciseError)
    if path is not None:
        return path
    raise ExerciseError(f"unknown exercise '{id_or_path}' (not a file, not a shipped exercise; "
                        "`python -m app exercises` lists them)")


_KEYS = {"id", "title", "robot", "question", "tasks", "exam", "number", "topics", "given",
         "configuration", "notes"}


def load_exercise(id_or_path: str | Path) -> Exercise:
    path = exercise_path(id_or_path)
    data = load_yaml(read_user_file(path, ExerciseError), str(path), ExerciseError,
                     shipped=path.resolve().parent == EXERCISES_DIR.resolve())
    return parse_exercise(data, str(path))


def parse_exercise(data, source: str = "<exercise>") -> Exercise:
    if not isinstance(data, dict):
        raise ExerciseError(f"{source}: expected a mapping")
    unknown = set(data) - _KEYS
    if unknown:
        raise ExerciseError(f"{source}: unknown field(s) {sorted(unknown)} (allowed: {sorted(_KEYS)})")
    for key in ("id", "robot", "question", "tasks"):
        if key not in data:
            raise ExerciseError(f"{source}: {key}: required field is missing")
    tasks = data["tasks"]
    if not isinstance(tasks, list) or not tasks:
        raise ExerciseError(f"{source}: tasks: expected a non-empty list")
    from .tasks import TASKS
    for i, t in enumerate(tasks):
        if isinstance(t, str):
            tasks[i] = t = {"kind": t}
        if not isinstance(t, dict) or not isinstance(t.get("kind"), str):
            raise ExerciseError(f"{source}: tasks[{i}]: expected a mapping with a kind (a name)")
        if t["kind"] not in TASKS:
            raise ExerciseError(f"{source}: tasks[{i}].kind: unknown task kind '{t['kind']}' "
                                f"(known: {', '.join(sorted(TASKS))})")
    for key, shape in (("given", dict), ("configuration", dict), ("topics", list), ("notes", (list, str))):
        if data.get(key) is not None and not isinstance(data[key], shape):
            raise ExerciseError(f"{source}: {key}: expected a {'mapping' if shape is dict else 'list'}")
    notes, targets = _parse_notes(data.get("notes") or [], source)
    return Exercise(id=str(data["id"]), title=str(data.get("title", data["id"])), robot=str(data["robot"]),
                    question=str(data["question"]), tasks=tasks, exam=str(data.get("exam", "")),
                    number=str(data.get("number", "")), topics=list(data.get("topics") or []),
                    given=dict(data.get("given") or {}), configuration=dict(data.get("configuration") or {}),
                    notes=notes, note_targets=targets, source=source)


def _parse_notes(raw, source: str):
    """Notes are strings, or mappings ``{note: text, answer: name}`` / ``{note: text, step: title}``
    tying the note to the step that gives that answer / the first step whose title starts so."""
    if isinstance(raw, str):
        raw = [raw]
    notes, targets = [], []
    for i, item in enumerate(raw):
        if isinstance(item, dict):
            extra = set(item) - {"note", "answer", "step"}
            if "note" not in item or extra or len(item) != 2:
                raise ExerciseError(f"{source}: notes[{i}]: expected a text or a mapping with 'note' and one "
                                    "of 'answer' (an answer name) or 'step' (the start of a step title)")
            notes.append(str(item["note"]))
            targets.append({k: str(v) for k, v in item.items() if k != "note"})
        else:
            notes.append(str(item))
            targets.append(None)
    return notes, targets


def _note_steps(exercise: "Exercise", steps: List[Step], answer_steps: Mapping[str, int]) -> List[Optional[int]]:
    """The step each note concerns (see ``_parse_notes``); a target that does not exist is an error."""
    out: List[Optional[int]] = []
    for i, target in enumerate(exercise.note_targets or [None] * len(exercise.notes)):
        if target is None:
            out.append(None)
        elif "answer" in target:
            if target["answer"] not in answer_steps:
                raise ExerciseError(f"{exercise.source or exercise.id}: notes[{i}]: no task gives the answer "
                                    f"'{target['answer']}' (answers: {', '.join(sorted(answer_steps))})")
            out.append(max(answer_steps[target["answer"]], 0))
        else:
            title = target["step"].lower()
            hits = [k for k, st in enumerate(steps) if st.title.lower().startswith(title)]
            if not hits:
                raise ExerciseError(f"{exercise.source or exercise.id}: notes[{i}]: no step title starts with "
                                    f"'{target['step']}'")
            out.append(hits[0])
    return out


def list_exercises() -> List[Exercise]:
    return [load_exercise(p) for p in exercise_files()]


def expected_path(exercise: Exercise) -> Path:
    return Path(exercise.source).with_suffix("").with_suffix(".expected.yaml")


# ---------------------------------------------------------------------- solving
def _check_variant(exercise: Exercise, robot: RobotModel, given: Mapping[str, Any]) -> None:
    """Changed numbers must name a given value of the exercise or a robot parameter, and robot
    parameters must pass the robot's parameter rule (``RobotModel.check_parameter_value``)."""
    for name, value in given.items():
        if name not in exercise.given and name not in robot.parameters:
            known = sorted(set(exercise.given) | set(robot.parameters))
            raise ExerciseError(f"{exercise.id}: '{name}' is neither a given value of the exercise nor a "
                                f"parameter of {robot.name} (known: {', '.join(known)})")
        if name not in robot.parameters:
            continue
        try:
            robot.check_parameter_value(name, value)
        except ParameterError as exc:
            raise ExerciseError(str(exc)) from None


def _run_task(exercise: Exercise, ctx, spec) -> None:
    """One task of an exercise. In a file of the user's (not a shipped exercise, which the tests
    solve), a field of the wrong shape that the task kind trips over (a number where a list is due,
    a list where a name is) is reported as the user's error, naming the task."""
    from .tasks import TASKS
    try:
        TASKS[spec["kind"]](ctx, {k: v for k, v in spec.items() if k != "kind"})
    except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
        shipped = exercise.source and Path(exercise.source).resolve().parent == EXERCISES_DIR.resolve()
        if isinstance(exc, UserError) or shipped or not exercise.source:
            raise
        raise ExerciseError(f"{exercise.source}: {ctx.current}: a field has the wrong shape or value "
                            f"({type(exc).__name__}: {str(exc)[:80]})") from None


def solve(exercise: Exercise, given: Optional[Mapping[str, Any]] = None,
          progress: Optional[Callable[[float, str], None]] = None) -> Solution:
    """Run every task of an exercise; ``given`` overrides the exercise's data (a variant)."""
    robot = exercise.load_robot()
    data = dict(exercise.given)
    if given:
        _check_variant(exercise, robot, given)
        data.update(given)
    ctx = TaskContext(exercise, robot, data, progress)
    reproducible_sympy.restart()
    for i, spec in enumerate(exercise.tasks):
        ctx.progress(i / len(exercise.tasks), spec["kind"])
        ctx.current = f"tasks[{i}] ({spec['kind']})"
        first, before = len(ctx.steps), set(ctx.answers)
        _run_task(exercise, ctx, spec)
        for name in set(ctx.answers) - before:      # an answer given before its task's first step
            if ctx.answer_steps[name] < first and len(ctx.steps) > first:
                ctx.answer_steps[name] = first
    ctx.progress(1.0, "done")
    return Solution(exercise, ctx.steps, ctx.answers, ctx.notes, robot,
                    _note_steps(exercise, ctx.steps, ctx.answer_steps), dict(ctx.answer_steps))
