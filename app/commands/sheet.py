"""``python -m app sheet EXERCISE... [--seed N] [--out DIR] [--no-pdf]``

A printable exam sheet of the chosen exercises with new numbers (a seeded, re-solved, physically
valid variant per exercise; app/core/sheet.py) and a separate solutions sheet with every step:
DIR/exam.html, DIR/solutions.html and their PDFs (A4, printed by headless Chromium). The same
seed gives the same sheets.
"""
from __future__ import annotations

NAME = "sheet"
HELP = "an exam sheet of exercises with new numbers, and its solutions (HTML and PDF)"


def add_arguments(p):
    p.add_argument("exercises", nargs="+", help="exercise ids (see `python -m app exercises`) or exercise files")
    p.add_argument("--seed", type=int, default=0, help="seed of the variants (default 0)")
    p.add_argument("--out", default="sheet", help="output folder (default ./sheet)")
    p.add_argument("--no-pdf", action="store_true", help="write the HTML files only")


def run(args) -> int:
    from app.core.sheet import make_sheet
    from app.viewer.sheets import write_sheet
    sheet = make_sheet(args.exercises, seed=args.seed)
    for k, entry in enumerate(sheet.entries, 1):
        what = (", ".join(f"{n} = {v}" for n, v in {**entry.changes, **entry.configuration}.items())
                if entry.status == "variant" else f"as is: {entry.reason}")
        print(f"{k}. {entry.exercise.id}: {what}")
    for path in write_sheet(sheet, args.out, pdf=not args.no_pdf):
        print(path)
    return 0
