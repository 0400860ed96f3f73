"""The Python API (app/lab.py, docs/api.md, issue 18 part 1): every public name has an example
that runs (the doctests of app/lab.py), docs/api.md's session runs as written, and the example
notebook (docs/examples/lab_tour.ipynb) runs headlessly in a fresh kernel (nbclient, ipykernel)
and prints what it shows: its stored outputs are the ones a run gives, and they hold real values."""
import doctest
import re
from pathlib import Path

import nbformat
from nbclient import NotebookClient

from app import lab

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "docs" / "examples" / "lab_tour.ipynb"


def printed(notebook) -> list:
    """The text each code cell printed (standard output), in order."""
    return ["".join(o.get("text", "") for o in cell.outputs if o.get("output_type") == "stream"
                    and o.get("name") == "stdout")
            for cell in notebook.cells if cell.cell_type == "code"]


def test_the_notebook_runs_and_prints_what_it_shows():
    """About 8 s: a kernel starts, imports the lab, derives nothing (disk cache), simulates 1.5 s of
    computed torque, solves a throw and an exam exercise."""
    stored = nbformat.read(NOTEBOOK, as_version=4)
    fresh = nbformat.read(NOTEBOOK, as_version=4)
    NotebookClient(fresh, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(ROOT)}}).execute()
    assert all(o.get("output_type") != "error" for cell in fresh.cells if cell.cell_type == "code" for o in cell.outputs)
    out = printed(fresh)
    assert out == printed(stored)                    # the stored outputs are what a run prints
    model, numbers, control, throw, exercise = out
    assert "m22 = I2 + d2**2*m2" in model and "g2  = d2*g0*m2*cos(q1 + q2)" in model
    # M(q) with m2 = 8 kg at q = (0.3, -0.2): m22 = I2 + d2^2 m2 = 0.35 + 0.16 * 8, m12 = m22 + d2 l1 m2 cos q2
    assert "1.63" in numbers and "4.7662" in numbers and "symbolic = pinocchio: True" in numbers
    error = float(re.search(r"final error: (\S+) rad", control).group(1))
    assert "completed: True" in control and error < 1e-3
    assert "theta_dot = 3.7762 m/s after 0.2863 s" in throw and "feasible: False" in throw
    # the RP arm of 2004-03-25#1: link 2's centre of mass at (l1, q2) in link 1's frame
    assert "M(q) = [[I1 + I2 + d1**2*m1 + m2*(l1**2 + q2**2), l1*m2], [l1*m2, m2]]" in exercise
    assert "regressor_count = 3" in exercise


def test_every_public_name_has_an_example_and_is_in_the_guide():
    """Cheap: a docstring with a doctest example for each name of app.lab's __all__, each named in
    docs/api.md (the examples themselves run with the module's doctests)."""
    guide = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    for name in lab.__all__:
        assert ">>> " in (getattr(lab, name).__doc__ or ""), name
        assert f"lab.{name}(" in guide, name


def test_the_guide_session_runs_as_written():
    """About 1 s with a warm cache: the session in docs/api.md (model, numbers, the pinocchio twin,
    an error message)."""
    result = doctest.testfile(str(ROOT / "docs" / "api.md"), module_relative=False, verbose=False,
                              optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 9 and result.failed == 0, result
