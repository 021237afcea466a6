"""The maze_mapping stack through ROS, in lockstep on a small world: slam's /map grows as the explorer drives, and
~/save_map writes a map load_map reads, or says why it cannot (the map kept); a subscriber that joins while the
simulator is paused still gets the last map, graph and frontiers (all three latched)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from conftest import spin_until
from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from rclpy.node import Node
from std_srvs.srv import Trigger

from amr_bringup.composed import composed_stack
from amr_interfaces.msg import Frontiers, PoseGraph
from amr_interfaces.srv import SaveMap
from amr_maps.map_io import load_map
from amr_util.lean_executor import LeanExecutor
from amr_util.qos import LATCHED, reliable

WORLD = "inner_maze.yaml"
TIMEOUT = 90.0


def known_cells(message: OccupancyGridMessage) -> int:
    return int((np.asarray(message.data, dtype=np.int8) >= 0).sum())


def call(executor, client, path: str) -> SaveMap.Response:
    future = client.call_async(SaveMap.Request(path=path))
    assert spin_until(executor, future.done, 20.0), "no answer from /slam/save_map"
    return future.result()


def test_the_map_grows_while_exploring_and_save_map_writes_it(ros_context, tmp_path):
    with composed_stack(ros_context, "maze_mapping", arguments={"world": WORLD}) as (nodes, manager, _):
        assert all(step.ok for step in manager.startup()), "maze_mapping did not come up"
        probe = Node("mapping_probe", context=ros_context)
        executor = LeanExecutor(context=ros_context)
        executor.add_node(probe)
        maps: list[OccupancyGridMessage] = []
        frontiers: list[Frontiers] = []
        probe.create_subscription(OccupancyGridMessage, "/map", maps.append, LATCHED)
        probe.create_subscription(Frontiers, "/explorer/frontiers", frontiers.append, reliable())
        client = probe.create_client(SaveMap, "/slam/save_map")
        try:
            assert spin_until(executor, lambda: maps, 20.0), "no /map from slam"
            first = known_cells(maps[0])
            started = time.monotonic()
            assert spin_until(executor, lambda: known_cells(maps[-1]) > 3 * first, TIMEOUT), (
                f"/map did not grow: {first} -> {known_cells(maps[-1])} known cells in "
                f"{time.monotonic() - started:.0f} s"
            )
            assert maps[-1].header.frame_id == "map" and any(f.state == "exploring" for f in frontiers)
            assert all(np.isfinite([m.info.origin.position.x, m.info.origin.position.y]).all() for m in maps)
            assert client.wait_for_service(timeout_sec=10.0)
            answer = call(executor, client, str(tmp_path / "inner_maze_map"))
            assert answer.success, answer.message
            saved = load_map(tmp_path / "inner_maze_map.yaml")
            assert saved.resolution == pytest.approx(maps[-1].info.resolution, rel=1e-6)  # float32 on the wire
            assert (saved.data == 0).sum() > 0.5 * (np.asarray(maps[-1].data) == 0).sum() > 0
            poses = (tmp_path / "inner_maze_map.poses.csv").read_text().splitlines()
            assert len(poses) > 5
            blocker = tmp_path / "a_file"
            blocker.write_text("not a directory")
            refused = call(executor, client, str(blocker / "map"))
            assert not refused.success and str(blocker) in refused.message
            again = call(executor, client, str(tmp_path / "again"))  # the map was kept
            assert again.success and load_map(tmp_path / "again.yaml").data.shape[0] > 0
            pause = probe.create_client(Trigger, "/simulator/pause")
            assert pause.wait_for_service(timeout_sec=10.0)
            paused = pause.call_async(Trigger.Request())
            assert spin_until(executor, paused.done, 20.0) and paused.result().success, "/simulator/pause"
            time.sleep(1.0)  # the last graph and frontiers of the run are out
            late: dict[str, list] = {"map": [], "graph": [], "frontiers": []}
            for key, kind, topic in (
                ("map", OccupancyGridMessage, "/map"),
                ("graph", PoseGraph, "/slam/graph"),
                ("frontiers", Frontiers, "/explorer/frontiers"),
            ):
                probe.create_subscription(kind, topic, late[key].append, LATCHED)
            assert spin_until(executor, lambda: all(late.values()), 20.0), (
                f"a subscriber joining on a paused simulator got { ({k: len(v) for k, v in late.items()}) }"
            )
            assert len(late["graph"][-1].poses) > 5 and late["frontiers"][-1].header.frame_id == "map"
        finally:
            executor.remove_node(probe)
            probe.destroy_node()
            executor.shutdown()
