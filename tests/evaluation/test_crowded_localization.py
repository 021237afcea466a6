"""A robot localizing while other robots crowd its scan, at library level: the shipped filter config,
a fleet in one simulator, the others standing close around it or following walls near it."""

from __future__ import annotations

from dataclasses import replace

import pytest

from amr_control.wall_follower_config import WallFollowerConfig
from amr_evaluation import configs
from amr_evaluation.crowded_localization import crowded_world, figures, run_crowded
from amr_localization.particle_filter_parameters import config_of
from amr_maps.maze_families import generate

_, PARAMETERS = configs.resolve("localization", "default")
ROOM = {  # 4 x 3 m, a table and a pillar: nothing symmetric
    "name": "crowded_room",
    "wall_thickness": 0.05,
    "walls": [[-2.0, -1.5, 2.0, -1.5], [2.0, -1.5, 2.0, 1.5], [2.0, 1.5, -2.0, 1.5], [-2.0, 1.5, -2.0, -1.5]],
    "boxes": [[0.8, 0.5, 1.4, 0.9], [-0.15, -0.15, 0.15, 0.15]],
    "start": [-1.2, -0.6, 0.0],
}


def filter_config(**changes):
    return replace(config_of({**PARAMETERS["particle_filter"], "seed": 4}), **changes)


def follower():
    return WallFollowerConfig.from_params(dict(PARAMETERS["wall_follower"]))


def test_tracking_stays_declared_and_right_with_robots_standing_close_around():
    world = crowded_world(ROOM, 4, seed=1, near=(0.3, 0.8))
    trace = run_crowded(
        world, filter_config(), follower(), 12.0, mode="stand", lidar_noise=0.02, seed=1, known_start=True
    )
    run = figures(trace)
    assert run.occluded_mean > 0.15, f"the others fill a fifth of the scan ({run.occluded_mean:.2f})"
    assert run.first_localized is not None and run.first_localized < 3.0, run
    assert run.tracking_within and run.false_localized == 0, run
    assert run.localized_share > 0.95 and run.withdrawals == 0, run


@pytest.mark.parametrize("family, seed", [("perfect", 0)])
def test_global_localization_among_robots_following_walls_converges_without_a_false_declaration(family, seed):
    world = crowded_world(generate(family, seed, width=0.7), 3, seed=seed)
    trace = run_crowded(world, filter_config(), follower(), 15.0, mode="drive", lidar_noise=0.03, seed=seed)
    run = figures(trace)
    assert run.occluded_max > 0.15, run
    assert run.first_localized is not None, run
    assert run.false_localized == 0 and run.tracking_within, run
