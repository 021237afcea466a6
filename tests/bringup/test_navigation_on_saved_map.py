"""`maze_navigation map:=PATH.yaml`: the map server serves the saved map (its world cleared, whatever order the
arguments come in) while the simulator runs the world."""

from __future__ import annotations

import pytest

from amr_bringup.stack_config import BringupError, load_bringup, parse_bringup


@pytest.mark.parametrize("order", [("world", "map"), ("map", "world")])
def test_map_serves_the_file_and_the_simulator_keeps_the_world(order):
    values = {"world": "inner_maze.yaml", "map": "/tmp/inner_maze_map.yaml"}
    bringup = load_bringup("maze_navigation").with_overrides({key: values[key] for key in order})
    nodes = {node.name: node.parameters for node in bringup.nodes}
    assert nodes["map_server"]["yaml_filename"] == "/tmp/inner_maze_map.yaml"
    assert nodes["map_server"]["world"] == ""
    assert nodes["simulator"]["world"] == "inner_maze.yaml"


def test_without_map_the_world_is_the_map():
    nodes = {node.name: node.parameters for node in load_bringup("maze_navigation").with_overrides({}).nodes}
    assert nodes["map_server"].get("world") and not nodes["map_server"].get("yaml_filename")


def test_clears_must_name_parameters_of_the_stacks_nodes(tmp_path):
    document = {
        "nodes": [{"name": "a", "package": "amr_maps", "executable": "map_server"}],
        "arguments": {"map": {"sets": ["a.yaml_filename"], "clears": ["b.world"]}},
    }
    with pytest.raises(BringupError, match="arguments.map.clears"):
        parse_bringup(document, tmp_path / "stack.yaml")
