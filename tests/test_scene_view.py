"""A panel's camera request made before the browser reported its view waits for that report, and
the last request wins (app/viewer/scene_view.py ``point_camera``): the Throw studio's framing of the
whole throw is not undone by the robot framing asked for when the robot loaded. Presenter mode's
line scale thickens the lines on display too, not only the ones drawn afterwards."""
import contextlib
from types import SimpleNamespace

import numpy as np
import pytest

from app.viewer.scene_view import SceneView


class Camera(SimpleNamespace):
    def on_update(self, callback):
        self.callbacks.append(callback)

    def report(self, width, height):
        """What viser does when the browser sends its first camera message."""
        self.update_timestamp, self.image_width, self.image_height = 1.0, width, height
        for callback in self.callbacks:
            callback(self)


class Client(SimpleNamespace):
    def atomic(self):
        return contextlib.nullcontext()


@pytest.fixture
def view():
    camera = Camera(update_timestamp=0.0, image_width=0, image_height=0, callbacks=[],
                    fov=None, up_direction=None, position=None, look_at=None)
    ignore = lambda *args, **kwargs: None      # noqa: E731 (the lights SceneView sets up)
    scene = SimpleNamespace(configure_default_lights=ignore, configure_environment_map=ignore,
                            add_light_ambient=ignore)
    return SceneView(Client(camera=camera, scene=scene))


def pose_at(x):
    return lambda width, height: (0.5, (x, width, height), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def test_a_request_before_the_first_report_waits_and_the_last_one_wins(view):
    camera = view.client.camera
    view.point_camera(pose_at(1.0))
    view.point_camera(pose_at(2.0))
    assert camera.position is None                      # nothing is known of the view yet
    camera.report(1280, 900)
    assert camera.position == pytest.approx((2.0, 1280, 900))         # the last request, for the reported size
    assert camera.fov == pytest.approx(0.5)
    assert len(camera.callbacks) == 1                   # hooked once


def test_after_the_report_a_request_is_carried_out_at_once(view):
    camera = view.client.camera
    camera.report(800, 600)
    view.point_camera(pose_at(3.0))
    assert camera.position == pytest.approx((3.0, 800, 600))
    camera.report(800, 600)                             # a later report does not replay it
    view.point_camera(lambda w, h: None)                # None leaves the camera
    assert np.allclose(camera.position[:1], [3.0])


class Line(SimpleNamespace):
    def remove(self):
        self.removed = True


def test_presenter_line_scale_thickens_the_lines_on_display(view):
    lines = []

    def add_line_segments(name, segments, colors, thickness, thickness_units):
        lines.append(Line(name=name, thickness=thickness))
        return lines[-1]

    view.scene.add_line_segments = add_line_segments
    view._node = lambda name: f"/overlays/{name}"
    view.add_line("path", [[0, 0, 0], [1, 0, 0]], width=3.0)
    view.set_line_scale(2.0)
    assert lines[0].thickness == pytest.approx(6.0)                # the line on display
    view.add_line("later", [[0, 0, 0], [0, 1, 0]], width=2.0)
    assert lines[1].thickness == pytest.approx(4.0)                # and the ones drawn afterwards
    view.remove_overlay("path")
    view.set_line_scale(1.0)
    assert lines[1].thickness == pytest.approx(2.0) and lines[0].thickness == pytest.approx(6.0)
