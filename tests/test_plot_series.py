"""The Control tab's plot data without a browser (app/core/plot_series.py): a run sampled at a
time, two runs merged for comparison, the time marker."""
import numpy as np
import pytest

from app.core.plot_series import (base_title, index_at, merge_runs, resample, sample_at, value_range,
                                  with_time_marker)


def test_sample_and_index_at_a_time():
    t = np.linspace(0.0, 1.0, 11)
    q = np.column_stack([t ** 2, np.sin(t)])
    assert sample_at(t, q, 0.35) == pytest.approx([0.5 * (0.09 + 0.16), 0.5 * (np.sin(0.3) + np.sin(0.4))],
                                                  abs=1e-12)
    assert sample_at(t, q, -1.0) == pytest.approx([0.0, 0.0], abs=1e-12)          # clamped
    assert sample_at(t, q, 9.0) == pytest.approx([1.0, np.sin(1.0)], abs=1e-12)
    assert [index_at(t, v) for v in (-0.5, 0.0, 0.301, 1.0, 2.0)] == [0, 0, 4, 10, 10]


def test_two_runs_of_different_lengths_share_one_time_axis():
    t_new = np.linspace(0.0, 2.0, 201)
    t_old = np.linspace(0.0, 1.0, 37)                 # shorter, other sampling
    x, cols = merge_runs(t_new, [np.cos(t_new), t_new], t_old, [3.0 * t_old])
    assert np.all(np.diff(x) > 0) and x[0] == pytest.approx(0.0, abs=1e-15) and x[-1] == pytest.approx(2.0)
    assert all(len(c) == len(x) for c in cols)
    # the new run's values unchanged at its own samples, the old run's too
    at_new = np.searchsorted(x, t_new)
    assert np.allclose(cols[0][at_new], np.cos(t_new), atol=1e-12)
    at_old = np.searchsorted(x, t_old)
    assert np.allclose(cols[2][at_old], 3.0 * t_old, atol=1e-12)
    # the old run is linear in between and absent after its end
    inside = x <= 1.0
    assert np.allclose(cols[2][inside], 3.0 * x[inside], atol=1e-12)
    assert np.all(np.isnan(cols[2][~inside])) and not np.any(np.isnan(cols[0]))


def test_resample_outside_the_run_is_nan():
    out = resample(np.array([1.0, 2.0]), np.array([10.0, 20.0]), np.array([0.5, 1.5, 2.5]))
    assert np.isnan(out[0]) and np.isnan(out[2]) and out[1] == pytest.approx(15.0, abs=1e-12)


def test_time_marker_is_a_vertical_segment_at_the_time():
    x = np.linspace(0.0, 4.0, 401)
    cols = [np.sin(x), np.cos(x)]
    lo, hi = value_range(cols)
    assert (lo, hi) == pytest.approx((-1.0, 1.0), abs=1e-3)
    for t in (0.0, 1.234, 4.0, 7.0):
        x2, out = with_time_marker(x, cols, t, lo, hi)
        assert len(out) == 3 and all(len(c) == len(x2) == len(x) + 2 for c in out)
        assert np.all(np.diff(x2) >= 0)                             # still sorted for uPlot
        marked = np.flatnonzero(out[2] >= lo)
        assert len(marked) == 2 and x2[marked] == pytest.approx([min(t, 4.0)] * 2, abs=1e-12)
        assert out[2][marked] == pytest.approx([lo, hi], abs=1e-12)
        assert np.all(out[2][np.setdiff1d(np.arange(len(x2)), marked)] < lo - 100 * (hi - lo))   # off the plot
        assert out[0][marked] == pytest.approx([np.sin(min(t, 4.0))] * 2, abs=1e-4)     # the curves go on
        keep = np.setdiff1d(np.arange(len(x2)), marked)
        assert np.allclose(x2[keep], x, atol=0) and np.allclose(out[1][keep], cols[1], atol=0)


def test_value_range_and_titles():
    assert value_range([np.array([2.0, 2.0])]) == pytest.approx((1.5, 2.5), abs=1e-12)
    assert value_range([np.array([np.nan])]) == pytest.approx((-1.0, 1.0), abs=1e-12)
    assert base_title("Tracking error e = q_d - q  [× 1e-5]") == "Tracking error e = q_d - q"
    assert base_title("Collision residual r (dashed: Jᵀ F)") == "Collision residual r"
