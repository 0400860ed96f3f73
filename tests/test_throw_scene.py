"""The throw studio's ground line stays a few dozen ticks however far the ball flies (a spring
of 1e9 N m/rad once asked for a tick every 0.5 m over 1e8 m: the server filled its memory)."""
import math

import pytest

from app.panels.throw_scene import MAX_GROUND, ThrowDrawing


class RecordedNodes:
    """Stands in for the scene nodes: remembers the last call of each name."""

    def __init__(self):
        self.calls = {}

    def __getattr__(self, kind):
        def record(name, *args, **kwargs):
            self.calls[name] = (kind, args)
        return record


@pytest.mark.parametrize("landing, ticks, labels", [(2.6, 6, 3), (47.3, 23, 4), (1e8, 19, 9), (math.inf, 19, 9)])
def test_ground_has_few_ticks_and_labels_at_their_ticks(landing, ticks, labels):
    nodes = RecordedNodes()
    ThrowDrawing(nodes, shoulder_height=0.3).ground(landing)
    kind, (segments, *_rest) = nodes.calls["ground_ticks"]
    xs = [s[0][0] for s in segments]
    line_end = nodes.calls["ground"][1][0][0][1][0]
    assert len(xs) == ticks and line_end <= MAX_GROUND + 1.0
    assert min(line_end, MAX_GROUND) >= min(landing, MAX_GROUND) and xs[-1] <= line_end
    shown = [(args[0], args[1][0]) for name, (k, args) in nodes.calls.items() if name.startswith("ground_label") and k == "label"]
    assert len(shown) == labels
    for text, x in shown:      # a label reads the distance of the tick it stands under
        assert text == f"{x:g} m" and any(abs(x - t) < 1e-9 * max(1.0, x) for t in xs)
