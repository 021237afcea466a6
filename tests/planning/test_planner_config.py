"""The planner node's parameters: the shipped file, names and types checked, the parts validated."""

from pathlib import Path

import pytest

from amr_planning.planner import PlannerConfig, distance_to_path
from amr_util.parameter_file import node_parameters
from amr_util.parameter_spec import ConfigError

ROOT = Path(__file__).resolve().parents[2]


def test_the_shipped_parameter_file_is_valid_and_matches_the_defaults():
    config = PlannerConfig.from_params(node_parameters(ROOT / "config" / "planner.yaml", "planner"))
    assert config == PlannerConfig()


@pytest.mark.parametrize(
    "params, name",
    [
        ({"planner": "dijkstra"}, "planner"),
        ({"plnner": "astar"}, "plnner"),
        ({"resolution": 0}, "resolution"),
        ({"goal": [1.0]}, "goal"),
        ({"prm_node_count": 1.5}, "prm_node_count"),
        ({"safety_margin": -1.0}, "safety_margin"),
        ({"smoothing_smooth_weight": 0.9}, "smooth_weight"),
        ({"world": 3}, "world"),
    ],
)
def test_bad_parameters_are_refused_by_name(params, name):
    with pytest.raises(ConfigError, match=name):
        PlannerConfig.from_params(params)


def test_distance_to_a_polyline():
    points = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]
    assert distance_to_path(points, 0.5, 0.2) == pytest.approx(0.2)
    assert distance_to_path(points, 1.3, 0.5) == pytest.approx(0.3)
    assert distance_to_path(points, -1.0, 0.0) == pytest.approx(1.0)
    assert distance_to_path([(2.0, 2.0)], 2.0, 3.0) == pytest.approx(1.0)
