"""Series of the Control tab's plots as plain arrays (no GUI): a run sampled at a time, two runs
merged on one time axis for comparison, and a vertical time marker added to a plot's data.

uPlot needs one shared, sorted x column; a series that has no value at some x holds NaN there
(the browser draws nothing for it)."""
from __future__ import annotations

from typing import List, Sequence, Tuple

import numpy as np


def index_at(t: np.ndarray, time: float) -> int:
    """The sample of a run shown at ``time``: the first with t >= time, clamped to the run.

    >>> index_at(np.array([0.0, 0.1, 0.2]), 0.15), index_at(np.array([0.0, 0.1, 0.2]), 5.0)
    (2, 2)
    """
    return int(min(len(t) - 1, max(0, np.searchsorted(t, time))))


def sample_at(t: np.ndarray, values: np.ndarray, time: float) -> np.ndarray:
    """The run's values (one row per sample, or one column) linearly interpolated at ``time``,
    clamped to the run's ends.

    >>> round(float(sample_at(np.array([0.0, 1.0]), np.array([0.0, 2.0]), 0.25)), 6)
    0.5
    """
    values = np.asarray(values, dtype=float)
    time = float(np.clip(time, t[0], t[-1]))
    if values.ndim == 1:
        return np.asarray(np.interp(time, t, values))
    return np.array([np.interp(time, t, values[:, j]) for j in range(values.shape[1])])


def resample(t: np.ndarray, values: np.ndarray, x: np.ndarray) -> np.ndarray:
    """One series of a run given at times ``t`` onto the times ``x``: linear in between, NaN
    outside the run's time span."""
    out = np.interp(x, t, np.asarray(values, dtype=float))
    out[(x < t[0] - 1e-12) | (x > t[-1] + 1e-12)] = np.nan
    return out


def merge_runs(t_new: np.ndarray, new: Sequence[np.ndarray], t_old: np.ndarray, old: Sequence[np.ndarray]
               ) -> Tuple[np.ndarray, List[np.ndarray]]:
    """The series of two runs on one time axis (the union of both runs' sample times): the
    new run's columns then the old run's, each NaN where its run has no sample (a shorter run).

    >>> x, cols = merge_runs(np.array([0.0, 1.0, 2.0]), [np.array([0.0, 1.0, 2.0])],
    ...                      np.array([0.0, 0.5]), [np.array([5.0, 6.0])])
    >>> [(np.round(c, 6) + 0.0).tolist() for c in (x, cols[0], cols[1])]
    [[0.0, 0.5, 1.0, 2.0], [0.0, 0.5, 1.0, 2.0], [5.0, 6.0, nan, nan]]
    """
    x = np.union1d(np.asarray(t_new, dtype=float), np.asarray(t_old, dtype=float))
    return x, [resample(t_new, v, x) for v in new] + [resample(t_old, v, x) for v in old]


def with_time_marker(x: np.ndarray, columns: Sequence[np.ndarray], time: float, low: float, high: float
                     ) -> Tuple[np.ndarray, List[np.ndarray]]:
    """A plot's data with a vertical line at ``time`` from ``low`` to ``high`` (the plot's fixed
    y range): two samples at x = time are inserted (where x stays sorted), holding the other
    columns' values there, and one more column that is ``low`` then ``high`` at those samples and
    far below the plot everywhere else (drawn outside the plot, so only the vertical line shows;
    not NaN, which uPlot's pixel binning would let swallow the line).

    >>> x, cols = with_time_marker(np.array([0.0, 1.0]), [np.array([3.0, 4.0])], 0.5, -1.0, 1.0)
    >>> [(np.round(c, 6) + 0.0).tolist() for c in (x, cols[0], cols[1][1:3])], bool(max(cols[1][[0, 3]]) < -100)
    ([[0.0, 0.5, 0.5, 1.0], [3.0, 3.5, 3.5, 4.0], [-1.0, 1.0]], True)
    """
    x = np.asarray(x, dtype=float)
    time = float(np.clip(time, x[0], x[-1])) if len(x) else float(time)
    k = int(np.searchsorted(x, time))
    x2 = np.insert(x, k, [time, time])
    out = []
    for c in columns:
        c = np.asarray(c, dtype=float)
        v = float(np.interp(time, x, c)) if len(x) else np.nan
        out.append(np.insert(c, k, [v, v]))
    marker = np.full(len(x2), low - 1000.0 * (high - low))
    marker[k], marker[k + 1] = low, high
    return x2, out + [marker]


def value_range(columns: Sequence[np.ndarray]) -> Tuple[float, float]:
    """The finite extremes of a plot's columns (a span of 1 around a constant, (-1, 1) for none).

    >>> [round(v, 6) for v in value_range([np.array([1.0, np.nan, 3.0]), np.array([-2.0])])]
    [-2.0, 3.0]
    """
    finite = [c[np.isfinite(c)] for c in (np.asarray(c, dtype=float) for c in columns)]
    finite = [c for c in finite if c.size]
    if not finite:
        return -1.0, 1.0
    lo, hi = float(min(c.min() for c in finite)), float(max(c.max() for c in finite))
    if hi - lo < 1e-12:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi


def base_title(title: str) -> str:
    """A plot's title without its parenthesised remark or scale note, to match a kept run's plot
    with the new run's.

    >>> base_title("Estimates â (dashed: true values)  [× 1e-3]")
    'Estimates â'
    """
    return title.split("  [×")[0].split(" (")[0].strip()
