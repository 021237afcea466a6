"""A click as the browser gives it (a ray), where its pose goes and what the viewer says (ClickTool's own choice of
pose: test_panel_models.py)."""

from __future__ import annotations

import math

import pytest

from amr_util.geometry import Pose2D
from amr_viewer.clicks import GOAL, INITIAL_POSE, ClickTool, pose_topic, sent_text

DOWN = (0.0, 0.0, -1.0)


def nowhere() -> None:
    """No robot drawn yet."""
    return None


def unasked() -> None:
    raise AssertionError("a ray that misses the floor asks for no robot")


def test_a_ray_onto_the_floor_is_a_click_there():
    chosen, said = ClickTool().ray((1.25, -0.5, 3.0), DOWN, nowhere)
    assert said is None and chosen == (GOAL, Pose2D(1.25, -0.5, 0.0))
    chosen, _ = ClickTool().ray((0.0, 0.0, 2.0), (1.0, 0.0, -1.0), lambda: Pose2D(0.0, 0.0, 0.0))
    assert chosen[1].x == pytest.approx(2.0) and chosen[1].theta == pytest.approx(0.0)


def test_a_ray_that_misses_the_floor_is_no_click():
    tool = ClickTool(two_clicks=True)
    assert tool.ray((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), unasked) == (None, None), "the horizon"
    assert tool.ray((0.0, 0.0, 1.0), (0.0, 0.0, 1.0), unasked) == (None, None), "the sky"
    assert tool.pending is None


def test_the_first_of_two_clicks_asks_for_the_heading():
    tool = ClickTool(INITIAL_POSE, two_clicks=True)
    assert tool.ray((1.0, 2.0, 3.0), DOWN, nowhere) == (None, "(1.00, 2.00): now click the heading")
    chosen, said = tool.ray((1.0, 3.0, 3.0), DOWN, nowhere)
    assert said is None and chosen == (INITIAL_POSE, Pose2D(1.0, 2.0, pytest.approx(math.pi / 2)))


def test_a_pose_goes_to_the_robots_goal_or_initial_pose_topic():
    assert pose_topic(GOAL) == "/goal_pose" and pose_topic(INITIAL_POSE, "/r2") == "/r2/initialpose"
    assert sent_text("/goal_pose", Pose2D(1.0, -0.5, math.pi / 2)) == "sent /goal_pose: (1.00, -0.50), 90 deg"
