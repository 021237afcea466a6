"""GraphSlam in a dead end (a tree-shaped maze's branch): driving back out, the robot sees again what it saw on the
way in, a few metres of path earlier; loop_min_travel 4 m lets the closure search bind the chain there, where the
default 8 m searches nothing (a perfect maze's first closure came at its 637th node). Each candidate searched is
counted with its outcome (slam.closure_outcomes: bench/bench_slam_replay.py judges them against the truth)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_mapping.slam import GraphSlam, SlamConfig
from amr_maps.raycast import NumpyRayCaster
from amr_maps.world import world_from_dict
from amr_util.geometry import compose, relative_pose
from amr_util.scan import ScanData

BEAMS = 180
INCREMENT = 2.0 * math.pi / BEAMS
MAX_RANGE = 3.5
CENTRE = 0.0
"""lidar_x: the scans here are ray cast from the robot's own pose."""


@pytest.fixture(scope="module")
def dead_end():
    return _dead_end()


def _dead_end():
    """A corridor 1.2 m wide and 6 m long, closed at its far end, boxes along its walls; 4.5 m in (0.25 m
    steps), a turn on the spot (18 deg steps), 4.5 m back out."""
    world = world_from_dict(
        {
            "walls": [[0, 0, 6, 0], [6, 0, 6, 1.2], [6, 1.2, 0, 1.2], [0, 1.2, 0, 0]],
            "wall_thickness": 0.1,
            "start": [0.5, 0.6, 0],
            "boxes": [[1.5, 0, 1.8, 0.2], [2.6, 1.0, 2.8, 1.2], [3.9, 0, 4.3, 0.25], [4.9, 0.95, 5.1, 1.2]],
        }
    )
    truth = [(0.5 + 0.25 * k, 0.6, 0.0) for k in range(19)]
    truth += [(5.0, 0.6, 0.1 * math.pi * k) for k in range(1, 11)]
    truth += [(5.0 - 0.25 * k, 0.6, math.pi) for k in range(1, 19)]
    return NumpyRayCaster(world.faces), np.array(truth)


def _run(dead_end, config: SlamConfig) -> tuple[GraphSlam, int]:
    caster, truth = dead_end
    rng = np.random.default_rng(3)
    odometry = [np.zeros(3)]
    for k in range(1, len(truth)):  # 2 % long, 2 deg a metre or a radian of heading bias
        step = np.array(relative_pose(truth[k - 1], truth[k]))
        step[:2] *= 1.02
        step[2] += math.radians(2.0) * (math.hypot(step[0], step[1]) + abs(step[2]))
        odometry.append(np.array(compose(odometry[-1], step)))
    slam = GraphSlam(config)
    closures = 0
    for k, (pose, odom) in enumerate(zip(truth, odometry, strict=True)):
        ranges = caster.cast(pose[0], pose[1], pose[2] - math.pi, INCREMENT, BEAMS, MAX_RANGE)
        scan = ScanData(ranges + rng.normal(0.0, 0.01, BEAMS), -math.pi, INCREMENT, 0.1, MAX_RANGE)
        closures += len(slam.add(k * 100_000_000, odom, scan).loop_closures)
    return slam, closures


def test_backing_out_of_a_dead_end_closes_loops_with_the_way_in(dead_end):
    slam, closures = _run(dead_end, SlamConfig(max_range_used=MAX_RANGE, loop_min_travel=4.0, lidar_x=CENTRE))
    assert closures > 0
    outcomes = [outcome for *_, outcome, _ in slam.closure_outcomes]
    assert len(outcomes) == slam.searched_closures and outcomes.count("kept") == closures
    _, edges, loop = slam.graph()
    _, truth = dead_end
    assert len(slam.node_stamps) == len(truth)  # every scan a node: node k is truth[k]
    # a closure ties a node of the way back to a submap of the way in
    assert all(i < 19 and j > 29 for i, j in edges[loop])
    # and it is right: the closure's measurement is the true relative pose to a few centimetres
    for (i, j), measured in zip(edges[loop], slam._graph.measurements[loop], strict=True):
        true = np.array(relative_pose(truth[i], truth[j]))
        assert math.hypot(*(measured[:2] - true[:2])) < 0.05
        assert abs(math.remainder(measured[2] - true[2], math.tau)) < math.radians(1.0)


def test_the_default_eight_metres_of_path_search_nothing_there(dead_end):
    assert SlamConfig().loop_min_travel == 8.0
    slam, closures = _run(dead_end, SlamConfig(max_range_used=MAX_RANGE, lidar_x=CENTRE))
    assert closures == 0 and slam.searched_closures == 0
