"""Printable exam sheets (app/core/sheet.py) as HTML with MathML and as PDF.

``exam_html(sheet)`` is the sheet for the students: per exercise (each on its own page) the
question and the numbers of this sheet; ``solutions_html(sheet)`` adds every step of the engine's
solution of that variant and its answers. Both are standalone files: the STIX Two Math font is
embedded (``mathml.font_style``), formulas are MathML from the lab's LaTeX. ``print_pdf`` prints a
page with headless Chromium (Playwright, app/viewer/screenshot.py's ``Browser``), A4.

>>> from app.core.sheet import make_sheet
>>> html = exam_html(make_sheet(["2009-09-10#2"], seed=1))
>>> html.count("class='r2-sheet-exercise'"), "<math" in html
(1, True)
"""
from __future__ import annotations

import html
from pathlib import Path
from typing import Dict, List, Sequence, Tuple

import numpy as np
import sympy as sp

from app.core.errors import UserError
from app.core.latex import num
from app.core.steps import to_latex
from app.viewer import mathml

PAGE_CSS = """
@page { size: A4; margin: 16mm 15mm 16mm 15mm; }
body { font-family: 'DejaVu Serif', Georgia, serif; font-size: 11pt; color: #111; margin: 0; }
h1 { font-size: 15pt; margin: 0 0 2mm 0; }
h2 { font-size: 13pt; margin: 0 0 1mm 0; }
h3 { font-size: 11pt; margin: 3mm 0 0.5mm 0; }
.r2-sheet-exercise { break-before: page; }
.r2-sheet-exercise:first-of-type { break-before: auto; }
.r2-sheet-meta { color: #555; font-size: 9.5pt; margin-bottom: 2mm; }
.r2-sheet-question p { margin: 0 0 1.5mm 0; line-height: 1.35; }
.r2-sheet-data { border-collapse: collapse; margin: 2mm 0; font-size: 10pt; }
.r2-sheet-data td, .r2-sheet-data th { border: 1px solid #bbb; padding: 1mm 2.5mm; text-align: left; }
.r2-sheet-note { border-left: 3px solid #e8a317; background: #fff6e0; padding: 1.5mm 3mm; font-size: 9.5pt; margin: 2mm 0; }
.r2-sheet-step { break-inside: avoid; margin: 0 0 1mm 0; }
.r2-sheet-step .r2-text { font-size: 10pt; color: #333; }
.r2-math { overflow: visible !important; }
.r2-math math[display=block] { margin: 0.6mm 0; }
.r2-sheet-space { height: 60mm; }
"""


def _document(title: str, body: str) -> str:
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title>{mathml.font_style()}<style>{PAGE_CSS}</style></head>"
            f"<body>{body}</body></html>")


def _paragraphs(text: str) -> List[str]:
    """Lines joined into paragraphs; a blank line or an item mark like (a) starts a new one."""
    import re
    out: List[str] = []
    for line in text.strip().splitlines():
        if not line.strip():
            out.append("")
        elif not out or not out[-1] or re.match(r"^\s*(\([a-z0-9]+\)|[-*•]\s|\d+[.)]\s)", line):
            out.append(line.strip())
        else:
            out[-1] += " " + line.strip()
    return [p for p in out if p]


def _value_html(value) -> str:
    """A given value or a numeric answer: numbers to 4 significant digits, lists as vectors and
    matrices, symbolic answers typeset."""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, str):
        from app.core.expressions import parse_expression
        return mathml.math_html(to_latex(parse_expression(value)), display=False) if value.strip() else ""
    if isinstance(value, (int, float, np.integer, np.floating)):
        return mathml.math_html(mathml.number_latex(float(value)), display=False)
    if isinstance(value, (sp.Basic, sp.MatrixBase)):
        if isinstance(value, sp.Basic) and value.is_number:
            return mathml.math_html(mathml.number_latex(float(value)), display=False)
        return mathml.math_html(to_latex(value), display=False)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return html.escape(str(value))
    return mathml.math_html(mathml.numeric_latex(arr), display=False)


def _data_table(entry) -> str:
    rows = [(k, v) for k, v in entry.changes.items()] + [(k, v) for k, v in entry.configuration.items()]
    if not rows:
        return ""
    robot = entry.solution.robot
    cells = "".join(f"<tr><td>{mathml.text_html('$' + _symbol(name, robot) + '$')}</td><td>{_value_html(v)}</td>"
                    f"<td>{html.escape(_unit(name, robot))}</td></tr>" for name, v in rows)
    return ("<p><b>Numbers of this sheet</b> (they replace those written in the text):</p>"
            f"<table class='r2-sheet-data'><tr><th>name</th><th>value</th><th>unit</th></tr>{cells}</table>")


def _symbol(name: str, robot) -> str:
    from app.core.steps import symbol_latex
    return symbol_latex(name, robot.coordinates)


def _unit(name: str, robot) -> str:
    p = robot.parameters.get(name)
    if p is not None:
        return p.unit
    return ""


def _header(sheet, kind: str) -> str:
    n = len(sheet.entries)
    return (f"<h1>Robotics II — {kind}</h1><div class='r2-sheet-meta'>{n} exercise{'s' if n != 1 else ''}, "
            f"variant seed {sheet.seed}; numbers drawn and re-solved by the Robotics II Lab engine "
            "(python -m app sheet).</div>")


def _exercise_head(k: int, entry) -> str:
    ex = entry.exercise
    question = "".join(f"<p>{html.escape(p)}</p>" for p in _paragraphs(ex.question))
    status = ("" if entry.status == "variant" else
              f"<div class='r2-sheet-note'>Reprinted as is: {html.escape(entry.reason)}.</div>")
    return (f"<h2>Exercise {k + 1}: {html.escape(ex.title)}</h2>"
            f"<div class='r2-sheet-meta'>after exam {html.escape(ex.exam or ex.id)} ({html.escape(ex.id)}); robot: "
            f"{html.escape(entry.solution.robot.title)}</div>"
            f"<div class='r2-sheet-question'>{question}</div>{status}{_data_table(entry)}")


def exam_html(sheet) -> str:
    """The students' sheet: questions and numbers, one exercise per page."""
    parts = [_header(sheet, "exam")]
    for k, entry in enumerate(sheet.entries):
        parts.append(f"<section class='r2-sheet-exercise' data-exercise='{html.escape(entry.exercise.id)}'>"
                     + _exercise_head(k, entry) + "<div class='r2-sheet-space'></div></section>")
    return _document(f"Exam sheet (seed {sheet.seed})", "".join(parts))


def solutions_html(sheet) -> str:
    """The instructor's sheet: every step of the engine's solution of each variant, and its answers."""
    parts = [_header(sheet, "solutions")]
    for k, entry in enumerate(sheet.entries):
        sol = entry.solution
        steps = "".join(_step_html(i, st) for i, st in enumerate(sol.steps))
        parts.append(f"<section class='r2-sheet-exercise' data-exercise='{html.escape(entry.exercise.id)}'>"
                     f"{_exercise_head(k, entry)}<h3>Solution</h3>{steps}{_answers_html(sol.answers)}</section>")
    return _document(f"Solutions (seed {sheet.seed})", "".join(parts))


def _step_html(i: int, step) -> str:
    formulas = "".join(mathml.math_html(p) for p in (mathml.split_top_level(step.latex) if step.latex else []))
    text = f"<div class='r2-text'>{mathml.text_html(step.text)}</div>" if step.text else ""
    return (f"<div class='r2-sheet-step'><b>{i + 1}. {mathml.text_html(step.title)}</b>{text}{formulas}</div>")


def _answers_html(answers) -> str:
    rows = []
    for name, value in answers.items():
        if isinstance(value, (sp.Basic, sp.MatrixBase)) and not (isinstance(value, sp.Basic) and value.is_number):
            continue        # symbolic answers are in the steps
        rows.append(f"<tr><td>{html.escape(name)}</td><td data-answer='{html.escape(name)}'>{_value_html(value)}</td></tr>")
    if not rows:
        return ""
    return ("<h3>Numeric answers</h3><table class='r2-sheet-data'><tr><th>answer</th><th>value</th></tr>"
            + "".join(rows) + "</table>")


def answer_number_texts(value) -> List[str]:
    """The numbers of an answer as the sheet prints them (4 significant digits), for checking."""
    if isinstance(value, (bool, np.bool_)):
        return []
    arr = np.atleast_1d(np.asarray(value, dtype=float)).reshape(-1)
    return [mathml.number_latex(float(x)) for x in arr]


def _render(document: str, out: str | Path, browser, action, **context_options) -> Path:
    """Load a document into a fresh page of ``browser`` (a new one when None), wait for its fonts,
    then ``action(page, path)``."""
    from app.viewer.screenshot import Browser
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    own = browser is None
    browser = browser or Browser()
    try:
        context = browser.browser.new_context(**context_options)
        try:
            page = context.new_page()
            page.emulate_media(media="print")
            page.set_content(document, wait_until="load")
            page.evaluate("() => document.fonts.ready.then(() => true)")
            action(page, str(out))
        finally:
            context.close()
    finally:
        if own:
            browser.close()
    return out


def print_pdf(document: str, out: str | Path, browser=None) -> Path:
    """Print an HTML document to an A4 PDF with headless Chromium (fonts loaded first)."""
    return _render(document, out, browser,
                   lambda page, path: page.pdf(path=path, format="A4", print_background=True, prefer_css_page_size=True))


def page_png(document: str, out: str | Path, browser=None, width: int = 794, height: int = 1123) -> Path:
    """A picture of the first printed page of a document (print media, A4 at 96 dpi), e.g. for
    the docs (a PDF cannot be screenshotted by headless Chromium)."""
    first_page_only = "<style>.r2-sheet-exercise ~ .r2-sheet-exercise{display:none}</style></head>"
    document = document.replace("</head>", first_page_only, 1).replace("<body>", "<body style='padding:16mm 15mm'>", 1)
    return _render(document, out, browser,
                   lambda page, path: page.screenshot(path=path, clip={"x": 0, "y": 0, "width": width, "height": height}),
                   viewport={"width": width, "height": height})


def verdict_html(verdict) -> str:
    """A check-answer verdict as a standalone HTML card (message, findings, the step of hint 2)."""
    color = "#2c8a2c" if verdict.correct else "#b3261e"
    items = "".join(f"<li>{mathml.text_html(f.message)}</li>" for f in verdict.findings)
    items += "".join(f"<li><i>{mathml.text_html(r)}</i></li>" for r in verdict.remarks)
    step = ""
    if verdict.step is not None:
        parts = mathml.split_top_level(verdict.step.latex) if verdict.step.latex else []
        step = (f"<div class='r2-sheet-note'><b>Recheck: {mathml.text_html(verdict.step.title)}</b>"
                f"<div>{mathml.text_html(verdict.step.text)}</div>{''.join(mathml.math_html(p) for p in parts)}</div>")
    body = (f"<div style='border:2px solid {color};border-radius:8px;padding:4mm 5mm;max-width:170mm'>"
            f"<div class='r2-sheet-meta'>check-answer {html.escape(verdict.target)} --entry {html.escape(verdict.entry)}"
            f" --answer \"{html.escape(verdict.answer)}\"</div>"
            f"<div style='font-weight:600;color:{color}'>{'Right' if verdict.correct else 'Not right'}: "
            f"{mathml.text_html(verdict.message)}</div><ul>{items}</ul>{step}</div>")
    return _document("check-answer", body)


def pdf_page_count(path: str | Path) -> int:
    """Pages of a PDF, counted by its page objects (``/Type /Page``, not ``/Pages``)."""
    import re
    data = Path(path).read_bytes()
    return len(re.findall(rb"/Type\s*/Page(?![s\w])", data))


def write_sheet(sheet, out_dir: str | Path, pdf: bool = True, browser=None) -> List[Path]:
    """exam.html, solutions.html (and their PDFs, printed by ``browser`` or a Chromium of its own)
    in ``out_dir``; returns the paths written."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    docs = {"exam": exam_html(sheet), "solutions": solutions_html(sheet)}
    paths = []
    for name, doc in docs.items():
        p = out_dir / f"{name}.html"
        p.write_text(doc, encoding="utf-8")
        paths.append(p)
    if pdf and browser is not None:
        paths += [print_pdf(doc, out_dir / f"{name}.pdf", browser) for name, doc in docs.items()]
    elif pdf:
        from app.viewer.screenshot import Browser
        with Browser() as own:
            paths += [print_pdf(doc, out_dir / f"{name}.pdf", own) for name, doc in docs.items()]
    return paths



def parse_exercise_ids(text: str, default: Sequence[str] = ()) -> List[str]:
    """Exercise ids typed in a field (separated by commas or spaces); ``default`` when empty.

    >>> parse_exercise_ids("2009-09-10#2, 2020-06-05#1 2009-09-10#2")
    ['2009-09-10#2', '2020-06-05#1']
    >>> parse_exercise_ids("  ", ["2004-03-25#1"])
    ['2004-03-25#1']
    """
    import re
    ids = list(dict.fromkeys(t for t in re.split(r"[,\s]+", text or "") if t))
    return ids or list(default)


def sheet_files(exercise_ids: Sequence[str], seed: int = 0, pdf: bool = True, progress=None,
                browser=None) -> Tuple[Dict[str, bytes], str]:
    """The exam sheet of the exercises (``make_sheet``) as files for a download: exam.html and
    solutions.html, and exam.pdf and solutions.pdf when ``pdf`` and a headless Chromium can be
    started (``browser`` or one of its own). Returns (name -> bytes, a note saying why there is no
    PDF, or ""). Raises UserError for an unknown exercise."""
    import tempfile

    from app.core.sheet import make_sheet
    if not exercise_ids:
        raise UserError("exam sheet: no exercise chosen (open one, or type exercise ids)")
    sheet = make_sheet(list(exercise_ids), seed=int(seed),
                       progress=(lambda f, m: progress(0.8 * f, f"solving a variant of {m}")) if progress else None)
    docs = {"exam": exam_html(sheet), "solutions": solutions_html(sheet)}
    files = {f"{name}.html": doc.encode("utf-8") for name, doc in docs.items()}
    if not pdf:
        return files, "PDF not asked for"
    if progress:
        progress(0.85, "printing the PDFs")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            if browser is None:
                from app.viewer.screenshot import Browser
                with Browser() as own:
                    paths = {name: print_pdf(doc, Path(tmp) / f"{name}.pdf", own) for name, doc in docs.items()}
            else:
                paths = {name: print_pdf(doc, Path(tmp) / f"{name}.pdf", browser) for name, doc in docs.items()}
            files.update({f"{name}.pdf": path.read_bytes() for name, path in paths.items()})
    except Exception as exc:         # no Chromium (or Playwright) here: the HTML prints from a browser
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return files, f"no PDF ({first[:160]}): print the HTML from your browser"
    return files, ""


#: the sheet and the check-answer diagnoses pictured in the docs (docs/cli.md, docs/panels.md)
DOC_SHEET = (["2020-04-15-mid#Q3", "2009-09-10#2", "2020-06-05#1", "2007-04-19#1", "2022-07-08#3"], 3)
DOC_CHECKS = [("check_answer_steiner.png", "planar_2r", "m11", "I1 + I2 + m2 (l1^2 + d2^2 + l1 d2 s2)"),
              ("check_answer_coriolis.png", "planar_2r", "c1", "m2 l1 d2 s2 (2 q1' q2' + q2'^2)")]


def save_doc_screenshots(out_dir) -> List[Path]:
    """The first page of an exam sheet and of its solutions, and two check-answer diagnoses
    (hint level 2), for the docs (``python -m app screenshot --all-docs``)."""
    from app.core.answer_check import check_answer
    from app.core.sheet import make_sheet
    from app.viewer.screenshot import Browser
    out_dir = Path(out_dir)
    sheet = make_sheet(*DOC_SHEET)
    paths = []
    with Browser() as browser:
        paths.append(page_png(exam_html(sheet), out_dir / "sheet_exam_page1.png", browser))
        paths.append(page_png(solutions_html(sheet), out_dir / "sheet_solutions_page1.png", browser))
        for filename, target, entry, answer in DOC_CHECKS:
            verdict = check_answer(target, entry, answer, hint=2)
            paths.append(page_png(verdict_html(verdict), out_dir / filename, browser, height=600))
    return paths
