"""The scene of a fleet in a real viser server (no browser): a colour and a name label per robot, trails in it."""

import contextlib
import io
import math

import numpy as np
import pytest
import viser

from amr_util.geometry import Pose2D
from amr_viewer.cdr import StampedTransform
from amr_viewer.scene import COLORS, MIN_COLOR_DISTANCE, ROBOT_COLOR_NAMES, ROBOT_COLORS, Scene
from amr_viewer.state import RobotState


@pytest.fixture
def server():
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield server
    server.stop()


def robot(namespace: str, x: float) -> RobotState:
    state = RobotState(namespace, trail_spacing=0.01)
    for k in range(5):
        state.on_ground_truth(StampedTransform("map", "base_footprint", 0.1 * k, Pose2D(x + 0.05 * k, 1.0, 0.0)))
    return state


def test_each_robot_of_a_fleet_has_its_colour_and_its_name(server):
    scene = Scene(server, robot_radius=0.1)
    fleet = [robot(f"/r{k + 1}", float(k)) for k in range(4)]
    for state in fleet:
        assert scene.draw(state) > 0
    colors = [scene.color_of(state.namespace) for state in fleet]
    assert colors == list(ROBOT_COLORS[:4]) and len(set(colors)) == 4
    for k in range(len(fleet)):
        root = f"/robots/r{k + 1}"
        label = scene._handles[f"{root}/labels"]
        assert label.text == f"r{k + 1}" and label.visible
        assert label.position[1] > 1.0, "above the disc"
        assert tuple(scene._handles[f"{root}/robot/body"].color) == colors[k]
        trail = scene._handles[f"{root}/trail/chunk0"]
        assert np.all(trail.colors == np.array(colors[k], dtype=np.uint8)), "the trail in the robot's colour"
    assert scene.color_name_of("/r2") == "maroon" and Scene.label_of("") == "robot"
    scene.forget("/r2")
    assert "/robots/r2/labels" not in scene._handles
    scene.set_hidden("labels", True)
    assert not scene._handles["/robots/r1/labels"].visible and scene._handles["/robots/r1/robot"].visible


def test_every_robot_colour_stands_apart_from_the_others_and_from_every_layer():
    """A searching estimate once drew within 5 of the second robot's colour: an unlocalized robot's arrow read as its
    trail."""
    assert len(ROBOT_COLOR_NAMES) == len(ROBOT_COLORS)
    for index, color in enumerate(ROBOT_COLORS):
        for other in ROBOT_COLORS[index + 1 :]:
            assert math.dist(color, other) >= MIN_COLOR_DISTANCE, (color, other)
        for layer, drawn in COLORS.items():
            assert math.dist(color, drawn) >= MIN_COLOR_DISTANCE, (ROBOT_COLOR_NAMES[index], layer)
