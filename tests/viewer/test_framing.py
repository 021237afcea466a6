"""Framing, where each browser's camera looks (no ROS, no viser): the robots from above or the arms at an angle,
the top view followed as a map grows and as the browser's canvas changes, until the user moves the camera."""

from __future__ import annotations

import pytest

from amr_viewer.framing import CAMERAS_KEPT, Framing, arms_origin, union
from amr_viewer.geometry import oblique_camera, top_down_camera

ROOM = (-1.0, -1.0, 1.0, 1.0)


def screen() -> tuple[float, float]:
    return 1.6, 0


def unknown_screen():
    raise AssertionError("a browser that has not reported its camera (viser asserts)")


def reported(camera):
    """A browser reporting `camera` back."""
    return lambda: (camera.position, camera.look_at)


def top(framing: Framing, client: int = 7, robots=(ROOM,), arms=()):
    return framing.camera(client, "top", robots=list(robots), arms=list(arms), screen=screen)


def test_nothing_is_framed_until_there_is_something_to_frame():
    framing = Framing()
    assert framing.camera(7, "top", robots=[None], arms=[], screen=unknown_screen) is None and not framing.framed
    assert framing.camera(7, "arms", robots=[], arms=[], screen=screen) is None, "no arms: the top view"
    assert top(framing) == top_down_camera(ROOM, 1.6) and 7 in framing.framed


def test_the_arms_are_seen_at_an_angle_and_their_view_is_not_followed():
    framing = Framing()
    top(framing)
    camera = framing.camera(
        7, "arms", robots=[ROOM], arms=[(2.0, -0.5, 3.0, 0.5), (3.0, -0.5, 4.0, 0.5)], screen=unknown_screen
    )
    assert camera == oblique_camera((2.0, -0.5, 4.0, 0.5)) and 7 not in framing.top_views
    assert not framing.stale(7, unknown_screen, [(-5.0, -5.0, 5.0, 5.0)], screen), "not asked: no top view to follow"


def test_a_grown_map_is_followed_while_the_camera_is_one_the_view_was_given():
    framing = Framing()
    first = top(framing)
    assert not framing.stale(7, unknown_screen, [], screen), "without a map the view stays"
    assert not framing.stale(7, unknown_screen, [ROOM], screen), "the map within the view"
    grown = [(-2.0, -1.0, 1.0, 1.0)]
    assert framing.stale(7, reported(first), grown, screen)
    second = top(framing, robots=grown)
    assert framing.stale(7, reported(first), [(-4.0, -1.0, 1.0, 1.0)], screen), (
        "a camera reported late, one given earlier, is not the user's"
    )
    assert len(framing.top_views[7][1]) == 2 and framing.top_views[7][1][-1] == second


def test_a_canvas_other_than_the_one_the_view_was_framed_for_frames_it_again():
    """A page reports its camera before its layout is done (width 0: the whole canvas taken as free); the view is
    framed again once its canvas is known, as after a window is resized, unless the user moved the camera."""
    framing = Framing()
    first = top(framing)
    assert not framing.stale(7, unknown_screen, [ROOM], screen), "the same canvas, the map within the view"
    laid_out = lambda: (1.6, 1280)  # noqa: E731
    assert framing.stale(7, reported(first), [ROOM], laid_out)
    second = framing.camera(7, "top", robots=[ROOM], arms=[], screen=laid_out)
    assert second != first and not framing.stale(7, reported(second), [ROOM], laid_out)
    assert framing.stale(7, reported(second), [], lambda: (1.2, 1280)), "a window resized, even without a map"
    assert not framing.stale(7, lambda: ((0.5, 0.5, 3.0), (0.0, 0.0, 0.0)), [ROOM], lambda: (1.2, 1280))
    assert 7 not in framing.top_views, "the user's camera is left alone"


def test_a_camera_the_user_moved_is_left_alone_until_the_top_view_is_asked_for():
    framing = Framing()
    top(framing)
    grown = [(-3.0, -1.0, 1.0, 1.0)]
    assert (
        not framing.stale(7, lambda: ((0.5, 0.5, 3.0), (0.0, 0.0, 0.0)), grown, screen) and 7 not in framing.top_views
    )
    camera = top(framing, robots=grown)
    assert framing.stale(7, reported(camera), [(-6.0, -1.0, 1.0, 1.0)], screen), "followed again"


def test_only_the_last_cameras_are_kept_per_browser_and_each_browser_has_its_own():
    framing = Framing()
    for size in range(1, CAMERAS_KEPT + 3):
        top(framing, robots=[(-size, -1.0, 1.0, 1.0)])
    assert len(framing.top_views[7][1]) == CAMERAS_KEPT
    top(framing, client=8)
    assert framing.top_views[8][0] == ROOM and framing.top_views[7][0] != ROOM
    framing.clear()
    assert not framing.framed and not framing.top_views


def test_union_and_the_arms_place():
    assert union([None, (0.0, 0.0, 1.0, 1.0), (-1.0, 0.5, 0.5, 2.0)]) == (-1.0, 0.0, 1.0, 2.0)
    assert union([None]) is None
    assert arms_origin([]) == (0.0, 0.0, 0.0)
    assert arms_origin([None, (-1.0, -2.0, 3.0, 0.0), (0.0, 0.0, 5.0, 1.0)]) == pytest.approx((6.0, -1.0, 0.0))
