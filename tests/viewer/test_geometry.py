"""The viewer's plane geometry: poses, ellipses, the floor under a click, the top-down camera."""

import math

import numpy as np
import pytest

from amr_util.geometry import quaternion_from_yaw
from amr_viewer.geometry import (
    PANEL_PIXELS,
    covariance_ellipse,
    floor_point,
    free_share,
    oblique_camera,
    scan_points,
    top_down_camera,
    wxyz_of,
)

RNG = np.random.default_rng(21)


@pytest.mark.parametrize("theta", np.linspace(-math.pi, math.pi, 9))
def test_wxyz_is_the_yaw_quaternion_in_visers_order(theta):
    w, x, y, z = wxyz_of(theta)
    assert (x, y, z, w) == pytest.approx(quaternion_from_yaw(theta))


def test_scan_points_drop_invalid_returns():
    ranges = np.array([1.0, np.inf, np.nan, 0.05, 2.0, 5.0])
    points = scan_points(ranges, -math.pi / 2, math.pi / 2, 0.12, 3.5)
    assert points == pytest.approx(np.array([[0.0, -1.0], [0.0, -2.0]]), abs=1e-12)  # beams 0 (-90 deg), 4 (270 deg)


def test_covariance_ellipse_has_the_gaussians_axes():
    for _ in range(20):
        angle, a, b = RNG.uniform(-math.pi, math.pi), RNG.uniform(0.01, 1), RNG.uniform(0.01, 1)
        rotation = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
        covariance = rotation @ np.diag([a * a, b * b]) @ rotation.T
        ellipse = covariance_ellipse(1.0, -2.0, covariance[0, 0], covariance[0, 1], covariance[1, 1], sigmas=2.0)
        local = (ellipse - [1.0, -2.0]) @ rotation  # in the principal axes
        assert np.allclose((local[:, 0] / (2 * a)) ** 2 + (local[:, 1] / (2 * b)) ** 2, 1.0)
        assert ellipse[0] == pytest.approx(ellipse[-1]), "closed"
    assert covariance_ellipse(0, 0, 1.0, 2.0, 1.0) is None, "not positive semi-definite"
    assert covariance_ellipse(0, 0, math.nan, 0.0, 1.0) is None
    assert covariance_ellipse(0, 0, 0.0, 0.0, 0.0) == pytest.approx(np.zeros((49, 2))), "a point estimate"


def test_floor_point():
    assert floor_point((1.0, 2.0, 5.0), (0.0, 0.6, -0.8)) == pytest.approx((1.0, 5.75))
    assert floor_point((1.0, 2.0, 5.0), (1.0, 0.0, 0.0)) is None, "parallel"
    assert floor_point((1.0, 2.0, 5.0), (0.0, 0.0, 1.0)) is None, "looking up"
    assert floor_point((0.0, 0.0, 1.0), (0.0, 0.0, -1.0), height=0.5) == pytest.approx((0.0, 0.0))


def project(camera, point, aspect):
    """Pixel fractions (0..1, y down) of a world point for a camera looking straight down with +y up on screen."""
    height = camera.position[2] - point[2]
    half_h = height * math.tan(camera.fov / 2)
    return (
        0.5 + (point[0] - camera.look_at[0]) / (2 * half_h * aspect),
        0.5 - (point[1] - camera.look_at[1]) / (2 * half_h),
    )


@pytest.mark.parametrize("aspect", [0.5, 1.0, 1.6, 3.0])
def test_the_top_down_camera_shows_the_whole_box_and_little_else(aspect):
    for _ in range(10):
        x0, y0 = RNG.uniform(-10, 10, 2)
        w, h = RNG.uniform(0.5, 20, 2)
        camera = top_down_camera((x0, y0, x0 + w, y0 + h), aspect, margin=0.1)
        assert camera.position[0] == pytest.approx(x0 + w / 2) and camera.look_at[2] == 0.0
        assert abs(camera.position[1] - camera.look_at[1]) < 1e-3 < camera.position[2]
        corners = [project(camera, (x, y, 0.0), aspect) for x in (x0, x0 + w) for y in (y0, y0 + h)]
        us, vs = [c[0] for c in corners], [c[1] for c in corners]
        assert min(us) > 0.0 and max(us) < 1.0 and min(vs) > 0.0 and max(vs) < 1.0
        spread = max(max(us) - min(us), max(vs) - min(vs))
        assert spread == pytest.approx(1 / 1.2, rel=1e-6), "the box fills the canvas but for its margins"
    with pytest.raises(ValueError, match="bad bounds"):
        top_down_camera((0, 0, math.nan, 1), 1.0)


def test_the_oblique_camera_looks_down_at_the_box():
    camera = oblique_camera((0.0, -0.5, 7.0, 0.5))
    direction = np.subtract(camera.look_at, camera.position)
    assert direction[2] < 0 and 3.0 < camera.look_at[0] < 4.0


@pytest.mark.parametrize("width", [800.0, 1024.0, 1400.0])
def test_the_top_down_camera_keeps_the_box_left_of_the_panel(width):
    aspect = width / 640.0
    free = free_share(width)
    assert free == pytest.approx(1.0 - PANEL_PIXELS / width)
    for _ in range(10):
        x0, y0 = RNG.uniform(-10, 10, 2)
        w, h = RNG.uniform(0.5, 20, 2)
        camera = top_down_camera((x0, y0, x0 + w, y0 + h), aspect, free=free)
        corners = [project(camera, (x, y, 0.0), aspect) for x in (x0, x0 + w) for y in (y0, y0 + h)]
        us, vs = [c[0] for c in corners], [c[1] for c in corners]
        assert min(us) > 0.0 and max(us) * width < width - PANEL_PIXELS, "the box left of the panel"
        assert min(vs) > 0.0 and max(vs) < 1.0
        assert 0.5 * (min(us) + max(us)) == pytest.approx(free / 2), "centred in the free share"
        spread = max((max(us) - min(us)) / free, max(vs) - min(vs))
        assert spread == pytest.approx(1 / 1.2, rel=1e-6), "the box fills the free share but for its margins"


def test_the_free_share_is_the_whole_canvas_until_its_width_is_known():
    assert free_share(0.0) == 1.0 and free_share(math.nan) == 1.0
    assert free_share(400.0) == pytest.approx(1 / 3), "at least a third, however narrow the canvas"
    with pytest.raises(ValueError, match="free share"):
        top_down_camera((0, 0, 1, 1), 1.0, free=0.0)
