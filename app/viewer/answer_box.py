""""Check my answer": a small folder with a dropdown of checkable entries, a text field for the
student's expression (course notation) and a verdict line.

The text is read when the edit is committed (``CommittedField``: the typing paused) and checked
off the event thread (``session.run_in_background``) by app/core/answer_check.py, which parses it
with the lab's whitelist parser (never ``eval``). The verdict says right or wrong and, when wrong,
where (a missing term, a sign, a factor, a dependence ...), without the whole answer; the box
"Show the step to recheck" asks for hint level 2 (the derivation step to look at again). An
unreadable answer gets one clear line and the field keeps the text, so the typo can be fixed.

The verdict's HTML carries ``class="r2-verdict"`` and ``data-state`` (``right``, ``wrong``,
``unreadable``, ``checking``, ``idle``) and ``data-seq`` (the number of the check it shows) for
tests and styles.
"""
from __future__ import annotations

import html
import threading
from typing import Callable, List, Optional, Sequence, Tuple

from app.core.errors import UserError
from app.viewer import mathml
from app.viewer.fields import CommittedField

MAX_ANSWER = 2000      # characters: an answer to one entry is never longer; a paste of more is refused
PROMPT = "Pick an entry, type your expression (e.g. m2*l1*d2*cos(q2), c2, s12, q2', θ) and pause."


def verdict_html(verdict, seq: int = 0) -> str:
    """The verdict line: right / not right, the findings, remarks and (hint 2) the step to recheck."""
    state = "right" if verdict.correct else "wrong"
    mark = "✓" if verdict.correct else "✗"
    color = "#1b7f3b" if verdict.correct else "#b3261e"
    parts = [f'<div style="color:{color};font-weight:600">{mark} {mathml.text_html(verdict.message)}</div>']
    items = [mathml.text_html(f.message) for f in verdict.findings] + [mathml.text_html(r) for r in verdict.remarks]
    if items:
        parts.append('<ul style="margin:2px 0 2px 1.1em;padding:0">' + "".join(f"<li>{i}</li>" for i in items) + "</ul>")
    if verdict.step is not None:
        parts.append('<div style="margin-top:4px">Recheck this step: <b>' + mathml.text_html(verdict.step.title) + "</b></div>")
        if verdict.step.text:
            parts.append(f"<div>{mathml.text_html(verdict.step.text)}</div>")
        if verdict.step.latex:
            parts.append(mathml.math_html(verdict.step.latex))
    return _wrap(state, "".join(parts), seq)


def message_html(state: str, text: str, seq: int = 0) -> str:
    if len(text) > 300:            # the parser's messages quote the answer: keep the line short
        text = text[:280] + " … " + text[-15:]
    color = {"unreadable": "#b3261e"}.get(state, "#444")
    return _wrap(state, f'<div style="color:{color}">{html.escape(text)}</div>', seq)


def _wrap(state: str, inner: str, seq: int) -> str:
    return (f'<div class="r2-verdict" data-state="{state}" data-seq="{seq}" '
            f'style="font-size:0.9em;margin:4px 0;min-height:1.2em">{inner}</div>')


class AnswerBox:
    """Build inside a container (a folder). ``entries()`` gives ``(entry, description)`` pairs;
    ``check(entry, text, hint)`` returns an answer_check ``Verdict`` or raises ``UserError``
    (``AnswerError``) for an unreadable answer or an unknown entry. ``set_entries`` refreshes the
    dropdown (e.g. when an exercise reveals another step)."""

    def __init__(self, session, entries: Sequence[Tuple[str, str]], check: Callable, title: str = "Check my answer",
                 expand: bool = False, follow_robot: bool = True):
        self.session, self.check = session, check
        gui = session.gui
        self._lock = threading.Lock()
        self._seq = 0
        # a Model tab's box belongs to one robot; an Exercises box lives on (its entries follow)
        self._generation = session.generation if follow_robot else None
        self._labels: dict = {}
        self.folder = gui.add_folder(title, expand_by_default=expand)
        with self.folder:
            self.hint = gui.add_html(mathml.label_html(PROMPT))
            self.entry = gui.add_dropdown("Entry", ("(none)",), hint="the entry your answer is for")
            self.text = gui.add_text("Your answer", "", hint="course notation; checked when you pause typing")
            self.more = gui.add_checkbox("Show the step to recheck", False,
                                         hint="hint level 2: the derivation step where it goes wrong")
            self.verdict = gui.add_html(message_html("idle", ""))
        self.set_entries(entries)
        self.field = CommittedField(self.text, self._parse, self._commit, self._refuse)
        self.entry.on_update(self._entry_changed)
        self.more.on_update(self._hint_changed)

    # -------------------------------------------------------------- entries
    def set_entries(self, entries: Sequence[Tuple[str, str]]) -> None:
        labels = {}
        for entry, description in entries:
            labels[f"{entry} · {description}" if description else entry] = entry
        with self._lock:
            if labels == self._labels and labels:
                return
            self._labels = labels
            self._seq += 1             # a check still running is for the old entries: dropped
        options = tuple(labels) or ("(nothing to check yet)",)
        current = self.entry.value
        self.entry.options = options
        if current in options:
            self.entry.value = current
        else:
            self.entry.value = options[0]
        self.entry.disabled = not labels
        self.text.disabled = not labels

    def entries(self) -> List[str]:
        with self._lock:
            return list(self._labels.values())

    def choose(self, entry: str) -> None:
        """Select ``entry`` in the dropdown (tests, pictures)."""
        with self._lock:
            label = next((k for k, v in self._labels.items() if v == entry), None)
        if label is None:
            raise UserError(f"'{entry}' is not offered here")
        self.entry.value = label

    # -------------------------------------------------------------- checking
    def _current_entry(self) -> Optional[str]:
        with self._lock:
            return self._labels.get(self.entry.value)

    def _parse(self, text: str) -> str:
        return text           # read by answer_check's whitelist parser in the background job

    def _refuse(self, message: str) -> None:
        self.verdict.content = message_html("unreadable", message, self._seq)

    def _entry_changed(self, event) -> None:
        """Another entry: the old answer and verdict go (the student types the new one)."""
        if event.client is not None:
            self.reset()

    def _hint_changed(self, event) -> None:
        if event.client is not None and self.text.value.strip():
            self._commit(self.text.value)

    def _commit(self, text: str) -> None:
        entry = self._current_entry()
        if entry is None:
            return
        text = str(text).strip()
        hint = 2 if self.more.value else 1
        seq = self._next_seq()
        if not text:
            self.verdict.content = message_html("idle", "", seq)
            return
        if len(text) > MAX_ANSWER:
            self.verdict.content = message_html("unreadable", f"the answer is {len(text)} characters long; "
                                                f"one entry needs at most {MAX_ANSWER}", seq)
            return
        self.verdict.content = message_html("checking", "Checking ...", seq)

        def work(progress):
            progress(0.0, f"checking {entry}")
            try:
                return seq, verdict_html(self.check(entry, text, hint), seq)
            except UserError as exc:      # AnswerError: unreadable or unknown entry, one clear line
                return seq, message_html("unreadable", str(exc), seq)

        def done(result):
            seq_done, content = result
            with self._lock:
                if seq_done != self._seq or self._generation not in (None, self.session.generation):
                    return
            self.verdict.content = content

        self.session.run_in_background(work, f"Checking {entry}", on_done=done)

    def reset(self) -> None:
        """Empty the answer and the verdict (another entry chosen, another exercise opened)."""
        seq = self._next_seq()
        self.field.set("")
        self.verdict.content = message_html("idle", "", seq)

    def _next_seq(self) -> int:
        """The number of a new check or reset: a check still running for an older one is dropped."""
        with self._lock:
            self._seq += 1
            return self._seq

    def close(self) -> None:
        self.field.close()
