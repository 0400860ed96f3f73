"""``python -m app robots``: the shipped robots, one line each (name, group, description)."""
NAME = "robots"
HELP = "list the shipped robots"


def add_arguments(p):
    p.add_argument("--json", action="store_true", help="print a JSON list")


def run(args) -> int:
    import json

    from app.core.catalog import robot_entries

    rows = robot_entries()
    if args.json:
        print(json.dumps(rows))
        return 0
    width = max(len(r["name"]) for r in rows) if rows else 10
    for r in rows:
        print(f"{r['name']:<{width}}  {r['group']:<8}  {r['title']} — {r['description']}")
    return 0
