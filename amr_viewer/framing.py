"""Where each browser's camera looks: the robots from above, or the arms at an angle; the top view followed as a
SLAM map grows, until the user moves the camera. No ROS, no viser: a browser is its client id and its camera's
numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np

from amr_viewer.geometry import Camera, free_share, oblique_camera, outgrown, top_down_camera

Bounds = tuple[float, float, float, float]
"""(xmin, ymin, xmax, ymax) on the floor."""
CAMERAS_KEPT = 4
"""cameras a browser's top view was last given (a camera it reports that is one of them is not the user's)."""
SAME = 0.01
"""m within which a camera the browser reports is one it was given."""


def union(boxes: Iterable[Bounds | None]) -> Bounds | None:
    """The bounds of every box given (None ones left out); None for none."""
    boxes = [box for box in boxes if box is not None]
    if not boxes:
        return None
    return (
        min(b[0] for b in boxes),
        min(b[1] for b in boxes),
        max(b[2] for b in boxes),
        max(b[3] for b in boxes),
    )


def arms_origin(robot_extents: Iterable[Bounds | None]) -> tuple[float, float, float]:
    """Where a new set of arms stands: 1 m east of the robots' extents, level with the first one (the origin
    without robots)."""
    extents = [extent for extent in robot_extents if extent is not None]
    if not extents:
        return (0.0, 0.0, 0.0)
    return (max(e[2] for e in extents) + 1.0, 0.5 * (extents[0][1] + extents[0][3]), 0.0)


class Framing:
    """The cameras given to each browser: which browsers were framed, and the top views that follow a map."""

    def __init__(self) -> None:
        self.framed: set[int] = set()
        """Browsers given a camera (one connected before there was anything to frame is framed at a draw)."""
        self.top_views: dict[int, tuple[Bounds, list[Camera], tuple[float, float]]] = {}
        """client -> (the bounds, the cameras, the browser's canvas (aspect, width in px)) of the top view it was last
        given: followed as a SLAM map grows and as the canvas changes."""

    def clear(self) -> None:
        self.framed.clear()
        self.top_views.clear()

    def camera(
        self,
        client: int,
        view: str,
        *,
        robots: Iterable[Bounds | None],
        arms: Sequence[Bounds],
        screen: Callable[[], tuple[float, float]],
    ) -> Camera | None:
        """The camera for browser `client`'s `view`: 'arms' at an angle over the arms' cells (when there are
        arms), else top-down over the robots' extents; None when there is nothing to frame yet. `screen()` gives
        the browser's canvas (aspect, width in px), asked for a top view only (a browser that has not reported its
        camera yet has none)."""
        if view == "arms" and arms:
            bounds = union(arms)
            camera = oblique_camera(bounds)
        else:
            bounds = union(robots)
            if bounds is None:
                return None
            canvas = screen()
            camera = top_down_camera(bounds, canvas[0], free=free_share(canvas[1]))
        self.framed.add(client)
        if view == "arms" and arms:
            self.top_views.pop(client, None)
        else:
            earlier = self.top_views.get(client, (None, [], None))[1]
            # the cameras this view was given, latest last: the browser reports its camera back late, so a report of
            # an earlier one is ours too, not the user's
            self.top_views[client] = (bounds, [*earlier[-(CAMERAS_KEPT - 1) :], camera], canvas)
        return camera

    def stale(
        self,
        client: int,
        reported: Callable[[], tuple],
        maps: Iterable[Bounds],
        screen: Callable[[], tuple[float, float]],
    ) -> bool:
        """The browser's top view should be framed again: the maps have grown out of it, or the browser's canvas
        (`screen()`: aspect, width in px) is not the one it was framed for (a page whose first report came before its
        layout did, a window resized), and its camera (`reported()`: (position, look_at) as the browser reports
        them, asked for only then) is still one it was given. A camera the user moved is left alone from now on
        (until the top view is asked for again); without a map the view stays where it was put unless the canvas
        changed."""
        view = self.top_views.get(client)
        if view is None:
            return False
        bounds = union(maps)
        grown = bounds is not None and outgrown(view[0], bounds)
        if not grown and not reshaped(view[2], screen()):
            return False
        position, look_at = reported()
        if not any(
            np.allclose(position, camera.position, atol=SAME) and np.allclose(look_at, camera.look_at, atol=SAME)
            for camera in view[1]
        ):
            self.top_views.pop(client)  # the user's camera from now on, until Top view is pressed
            return False
        return True


def reshaped(framed: tuple[float, float], now: tuple[float, float]) -> bool:
    """Whether a browser's canvas (aspect, width in px) `now` is not the one a view was `framed` for."""
    return not math.isclose(framed[0], now[0], rel_tol=1e-3) or free_share(framed[1]) != free_share(now[1])
