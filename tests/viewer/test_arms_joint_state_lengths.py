"""A JointState without one position per name (efforts only, or malformed) moves no arm and raises nothing."""

from pathlib import Path

import pytest

from amr_util.parameter_file import dotted, node_parameters
from amr_viewer.arms import ArmSet

ROOT = Path(__file__).resolve().parents[2]
PARAMETERS = {"use_sim_time": False, **dotted(node_parameters(ROOT / "config" / "ik_chains.yaml", "ik_service"))}


@pytest.mark.parametrize(
    ("names", "positions"),
    [(["rr2/q1", "rr2/q2"], []), (["rr2/q1", "rr2/q2"], [0.5]), (["rr2/q1"], [0.5, -1.0])],
    ids=["no positions", "fewer positions", "more positions"],
)
def test_a_message_without_one_position_per_name_changes_nothing(names, positions):
    arms = ArmSet.from_parameters(PARAMETERS, origin=(0.0, 0.0, 0.0))
    before = list(arms.arms["rr2"].positions)
    assert arms.on_joint_state(names, positions) == set()
    assert list(arms.arms["rr2"].positions) == before
    assert arms.on_joint_state(["rr2/q1", "rr2/q2"], [0.5, -1.0]) == {"rr2"}, "a whole message still moves it"
