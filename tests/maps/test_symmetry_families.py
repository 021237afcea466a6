"""Generated square rooms whose four-fold symmetry one feature breaks, and truly symmetric controls."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_maps.rasterize import rasterize_world
from amr_maps.raycast import NumpyRayCaster
from amr_maps.symmetry_families import (
    BROKEN,
    KINDS,
    START_CLEARANCE,
    SYMMETRIC,
    FeatureView,
    SymmetryFamilyError,
    symmetry_case,
)
from amr_maps.world import world_from_dict


def _scans_at_rotations(world, rng, poses=20):
    """Noise-free ranges from random free poses and from the same poses turned by 90, 180 and 270 deg."""
    caster = NumpyRayCaster(world.faces)
    xmin, ymin, xmax, ymax = world.bounds
    out = []
    while len(out) < poses:
        x, y, theta = rng.uniform(xmin, xmax), rng.uniform(ymin, ymax), rng.uniform(-math.pi, math.pi)
        scans = []
        for k in range(4):
            c, s = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
            scans.append(
                np.minimum(
                    caster.cast(c * x - s * y, s * x + c * y, theta + k * math.pi / 2, 2 * math.pi / 240, 240, 3.5), 3.5
                )
            )
        if np.isfinite(scans[0]).all() and scans[0].min() > 0.05:
            out.append(scans)
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_loads_the_same_for_a_seed_with_a_free_start_by_a_wall(kind):
    for seed in range(3):
        case = symmetry_case(kind, seed)
        assert case == symmetry_case(kind, seed)
        world = world_from_dict(case.world)
        x, y, _ = case.world["start"]
        a, b = world.faces[:, :2], world.faces[:, 2:]
        t = np.clip(np.einsum("ij,ij->i", [x, y] - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0.0, 1.0)
        clearance = np.hypot(*(a + t[:, None] * (b - a) - [x, y]).T).min()
        assert START_CLEARANCE <= clearance <= 0.45 + 1e-9, "free, and by a wall"
    assert symmetry_case(kind, 0) != symmetry_case(kind, 1)


@pytest.mark.parametrize("kind", KINDS)
def test_on_the_lattice_a_symmetric_room_rasterizes_to_a_map_a_quarter_turn_leaves_unchanged(kind):
    case = symmetry_case(kind, 4)
    symmetric = rasterize_world(world_from_dict(case.symmetric), 0.02).data
    assert np.array_equal(np.rot90(symmetric), symmetric)
    world = rasterize_world(world_from_dict(case.world), 0.02).data
    if kind in BROKEN:  # the feature breaks every rotation, the half turn too
        assert not any(
            world.shape == np.rot90(world, k).shape and np.array_equal(np.rot90(world, k), world) for k in (1, 2, 3)
        )
    else:
        assert case.world == case.symmetric


@pytest.mark.parametrize("kind", SYMMETRIC)
def test_off_the_lattice_the_room_is_still_symmetric_but_its_map_is_not(kind):
    case = symmetry_case(kind, 2, lattice=False)
    world = world_from_dict(case.world)
    for scans in _scans_at_rotations(world, np.random.default_rng(0)):
        for turned in scans[1:]:
            np.testing.assert_allclose(turned, scans[0], atol=1e-6)
    grid = rasterize_world(world, 0.02).data
    assert grid.shape != grid.T.shape or not np.array_equal(np.rot90(grid), grid)


@pytest.mark.parametrize("kind", BROKEN)
def test_the_feature_is_in_view_from_some_poses_only_and_tells_the_rotations_apart(kind):
    case = symmetry_case(kind, 1)
    world, symmetric = world_from_dict(case.world), world_from_dict(case.symmetric)
    view = FeatureView(world, symmetric)
    rng = np.random.default_rng(1)
    seen = [
        view.differing_beams(*pose, 2 * math.pi / 240, 240, 3.5)
        for pose in rng.uniform([-1.5, -1.5, -math.pi], [1.5, 1.5, math.pi], size=(300, 3))
    ]
    assert max(seen) >= 3 and min(seen) == 0
    differs = [
        any(np.abs(turned - scans[0]).max() > 0.05 for turned in scans[1:])
        for scans in _scans_at_rotations(world, rng, poses=40)
    ]
    assert any(differs)


def test_options_fix_what_they_name():
    notch = symmetry_case("notch", 0, size=4.0, feature=0.4, depth=0.3, thickness=0.04)
    world = world_from_dict(notch.world)
    extent = world.bounds[2] - world.bounds[0], world.bounds[3] - world.bounds[1]
    assert sorted(round(e, 3) for e in extent) == [4.04, 4.34]  # 4 m + a wall, and 0.3 m deeper on one side
    door = symmetry_case("doorway", 0, size=5.0, feature=0.3, thickness=0.04)
    lengths = [math.hypot(w[2] - w[0], w[3] - w[1]) for w in door.world["walls"][4:]]
    assert sum(lengths) == pytest.approx(4 * max(lengths[:3]) - 0.3)  # the enclosure's sides less one doorway


@pytest.mark.parametrize(
    "kind, options, message",
    [
        ("hexagon", {}, "unknown symmetry family 'hexagon'"),
        ("notch", {"width": 0.3}, "unknown option 'width'"),
        ("island", {"size": 50.0}, "size must be a number in"),
        ("ring", {"lattice": "yes"}, "lattice must be true or false"),
    ],
)
def test_bad_requests_name_what_is_wrong(kind, options, message):
    with pytest.raises(SymmetryFamilyError, match=message):
        symmetry_case(kind, 0, **options)
    with pytest.raises(SymmetryFamilyError, match="seed"):
        symmetry_case("ring", -1)
