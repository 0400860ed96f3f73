"""``python -m app exercises [--json]``: the shipped exercises with their topics and robots."""
NAME = "exercises"
HELP = "list the shipped exercises"


def add_arguments(p):
    p.add_argument("--json", action="store_true")


def run(args) -> int:
    import json

    from app.core.catalog import exercise_entries

    rows = exercise_entries()
    if args.json:
        print(json.dumps(rows))
        return 0
    for r in rows:
        print(f"{r['id']:<22} {r['robot']:<24} {', '.join(r['topics'])}  — {r['title']}")
    return 0
