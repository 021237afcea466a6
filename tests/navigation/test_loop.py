"""The navigation loop (amr_navigation.loop): the Navigator's hand-over and planning decisions carried out with
the controllers and the planner in process, and one whole run."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from amr_control.path_follower import PathFollower
from amr_control.path_follower_config import read_parameter_file as read_follower_file
from amr_control.wall_follower import Command, WallFollower
from amr_control.wall_follower_config import read_parameter_file as read_wall_file
from amr_localization.particle_filter import ParticleFilter
from amr_localization.particle_filter_parameters import config_of
from amr_maps.occupancy_grid import OccupancyGrid
from amr_maps.rasterize import rasterize_world
from amr_maps.world import load_world
from amr_navigation.loop import NavigationLoop, run_navigation
from amr_navigation.navigator import Mode
from amr_planning.planner import Planner, PlannerConfig
from amr_simulation.config import LidarConfig, SimulationConfig
from amr_simulation.simulator import Simulator
from amr_util.parameter_file import node_parameters
from amr_util.scan import ScanData

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "config"
NO_RETURNS = ScanData(np.full(240, np.inf), 0.0, 2 * math.pi / 240, 0.12, 3.5)


def walled(rows: int, cols: int) -> np.ndarray:
    """A free rows x cols area at 0.05 m closed by a one-cell wall (int8 occupancy data)."""
    data = np.zeros((rows, cols), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return data


def grid(data: np.ndarray) -> OccupancyGrid:
    return OccupancyGrid(data, 0.05, (0.0, 0.0, 0.0))


class RecordingWallFollower:
    """Stands in for the wall follower: a fixed command, and the stamps it was asked at."""

    def __init__(self) -> None:
        self.stamps: list[float] = []

    def compute(self, scan, v, w, stamp) -> Command:
        self.stamps.append(stamp)
        return Command(0.1, 0.3)


def navigator(goal=(2.5, 0.5)) -> tuple[NavigationLoop, RecordingWallFollower]:
    data = walled(20, 60)  # 1 x 3 m at 0.05 m
    wall = RecordingWallFollower()
    return NavigationLoop(Planner(grid(data), PlannerConfig(resolution=0.05)), wall, PathFollower(), goal), wall


def test_explores_until_localized_then_plans_once_and_follows():
    nav, wall = navigator()
    command = nav.step((0.5, 0.5, 0.0), False, NO_RETURNS, 0.0, 0.0, 0.0)
    assert command.mode is Mode.EXPLORE and (command.v, command.w) == (0.1, 0.3)
    assert nav.plans == 0 and nav.planned_path is None
    command = nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.05)
    assert command.mode is Mode.FOLLOW and command.v > 0.0 and nav.plans == 1
    assert "localized" in command.events
    nav.step((0.52, 0.5, 0.0), True, NO_RETURNS, 0.2, 0.0, 0.1)
    assert nav.plans == 1  # on the path: no replanning
    assert wall.stamps == [0.0]  # the wall follower answered only the unlocalized observation


def test_replans_when_strayed_or_the_goal_changes():
    nav, _ = navigator()
    nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.0)
    command = nav.step((1.0, 0.2, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.05)  # 0.3 m off the straight path
    assert nav.plans >= 2 and any("strayed" in event for event in command.events)
    assert abs(nav.planned_path[0][1] - 0.2) < 0.1  # planned again from where the estimate is
    nav.set_goal((0.3, 0.3))
    nav.step((1.0, 0.2, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.1)
    assert np.allclose(nav.path_follower.goal, (0.3, 0.3), atol=0.05)


def test_withdrawn_localization_explores_again_and_keeps_the_path():
    nav, wall = navigator()
    nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.0)
    command = nav.step((0.55, 0.5, 0.0), False, NO_RETURNS, 0.0, 0.0, 0.05)
    assert command.mode is Mode.EXPLORE and nav.localization_losses == 1 and wall.stamps == [0.05]
    command = nav.step((0.6, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.1)
    assert command.mode is Mode.FOLLOW and nav.plans == 1  # back on the same path


def test_no_path_stops_and_is_retried_unless_the_goal_itself_is_refused():
    nav, _ = navigator(goal=(10.0, 10.0))  # off the map: the goal itself is refused
    command = nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.0)
    assert command.mode is Mode.NO_PATH and (command.v, command.w) == (0.0, 0.0)
    assert any("off the map" in event for event in command.events)
    command = nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.05)
    assert command.mode is Mode.NO_PATH and len(nav.planning_failures) == 1 and not command.events  # said once
    nav.set_goal((2.5, 0.5))
    assert nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.1).mode is Mode.FOLLOW
    nav, _ = navigator()
    blocked = nav.step((0.02, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.0)  # the estimate inside the wall
    assert blocked.mode is Mode.NO_PATH and "start" in nav.planning_failures[-1]
    nav.step((0.02, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.05)
    assert len(nav.planning_failures) == 2  # a start problem is tried again at the next observation
    assert nav.step((0.5, 0.5, 0.0), True, NO_RETURNS, 0.0, 0.0, 0.1).mode is Mode.FOLLOW


def test_pillar_goal_whole_loop_reaches_the_goal_without_collision():
    """Wall following, global localization, planning from the estimate, pure pursuit: the goal beside the
    pillar that no wall follower reaches."""
    world = load_world(CONFIG / "worlds" / "pillar_goal.yaml")
    filter_params = node_parameters(CONFIG / "particle_filter.yaml", "particle_filter")
    pf = ParticleFilter(rasterize_world(world, 0.02), config_of(filter_params), range_max=3.5)
    planner_config = PlannerConfig.from_params(node_parameters(CONFIG / "planner.yaml", "planner"))
    planner = Planner(rasterize_world(world, planner_config.resolution), planner_config)
    nav = NavigationLoop(
        planner,
        WallFollower(read_wall_file(CONFIG / "wall_follower_sim.yaml")),
        PathFollower(read_follower_file(CONFIG / "path_follower_sim.yaml")),
        (world.goal.x, world.goal.y),
    )
    sim = Simulator(world, SimulationConfig(seed=0, lidar=LidarConfig(noise_std=0.01)))
    run = run_navigation(sim, pf, nav, limit=60.0)
    assert run.reached and run.collisions == 0, run
    assert run.first_localized is not None and run.first_localized < run.time
    assert run.cross_track and run.mean_cross_track < 0.03
