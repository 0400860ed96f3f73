"""The coverage section of docs/exercise-format.md: every catalog exercise (the ids listed at its
end) is shipped or has a row saying what is left out and why; rows are sorted and up to date."""
import re
from pathlib import Path

from app.core.exercise import list_exercises

DOC = Path(__file__).resolve().parents[1] / "docs" / "exercise-format.md"


def _section():
    text = DOC.read_text(encoding="utf-8")
    start = text.index("## Coverage of the exam collection")
    end = text.find("\n## ", start + 3)
    return text[start:end if end > 0 else len(text)]


def _ids_and_rows():
    sec = _section()
    block = re.search(r"Catalog ids \((\d+)\):\s*```text\n(.*?)```", sec, re.S)
    ids = block.group(2).split()
    assert len(ids) == int(block.group(1)) == len(set(ids))
    rows = [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in sec.splitlines() if re.match(r"\| \d{4}-", line)]
    return ids, rows


def test_every_catalog_exercise_is_shipped_or_listed():
    ids, rows = _ids_and_rows()
    shipped = {e.id for e in list_exercises()}
    listed = {r[0] for r in rows}
    assert shipped <= set(ids), f"shipped exercises missing from the id list: {sorted(shipped - set(ids))}"
    assert listed <= set(ids), f"rows for unknown ids: {sorted(listed - set(ids))}"
    missing = set(ids) - shipped - listed
    assert not missing, f"neither shipped nor listed: {sorted(missing)}"


def test_rows_are_sorted_and_agree_with_what_is_shipped():
    _ids, rows = _ids_and_rows()
    shipped = {e.id for e in list_exercises()}
    assert [r[0] for r in rows] == sorted(r[0] for r in rows)
    for id_, catalog, status, why in rows:
        assert catalog in ("yes", "partly", "no") and why, id_
        assert status in ("partly", "no", "not shipped"), f"{id_}: unknown status {status!r}"
        if status == "not shipped":
            assert id_ not in shipped, f"{id_} is shipped now: update its row (partly) or remove it"
        if status == "partly":
            assert id_ in shipped, f"{id_} is marked partly but is not shipped"
