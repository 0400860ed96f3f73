"""``python -m app check-answer ROBOT|EXERCISE --entry m11 --answer "..." [--json] [--hint 2] [--skew]``

Checks a student's answer against the entry the engine derives (app/core/answer_check.py): a
model entry of a robot (m11, c1, g1, C12, c1_12, a1, Y12, Ycol1, or M, c, g, C, a, Y) or an answer
of an exercise (its answer names, with [i] or [i,j]). Exit code 0 when right, 1 when wrong, 2 when
the answer cannot be read or the entry does not exist. ``--json`` prints one object (docs/cli.md).
"""
from __future__ import annotations

import json
import sys

NAME = "check-answer"
HELP = "check a student's answer to a model entry or an exercise answer (exit 0 right, 1 wrong, 2 unreadable)"


def add_arguments(p):
    p.add_argument("target", help="robot (name or file) or exercise (id such as 2004-03-25#1, or file)")
    p.add_argument("--entry", required=True, help="m11, c1, g1, k1, C12, c1_12, C1, a1, Y12, Ycol1, M, c, g, C, a, Y, "
                                                  "or an exercise's answer name (with [i] or [i,j])")
    p.add_argument("--answer", required=True, help="the expression or number, in the course's notation")
    p.add_argument("--hint", type=int, default=1, choices=(1, 2), help="2: also the derivation step to recheck")
    p.add_argument("--skew", action="store_true", help="for C: require Mdot - 2C skew-symmetric")
    p.add_argument("--json", action="store_true", help="print one JSON object (see docs/cli.md)")


def run(args) -> int:
    from app.core.answer_check import check_answer
    verdict = check_answer(args.target, args.entry, args.answer, hint=args.hint, skew=args.skew)
    if args.json:
        json.dump(verdict.as_dict(), sys.stdout)
        sys.stdout.write("\n")
    else:
        print(verdict.text())
    return 0 if verdict.correct else 1
