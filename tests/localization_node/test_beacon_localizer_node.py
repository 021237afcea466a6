"""The beacon_localizer node with the simulator publishing /beacons: relocalizes from a wrong initial
pose to within 2 cm, one /pose per reading; an empty beacon list is refused by the world loader."""

from __future__ import annotations

import pytest
import yaml
from lifecycle_msgs.msg import Transition
from rclpy.parameter import Parameter
from support.localizer_driver import STEPS, Driver, stamp_ns
from support.ros import spin_for, spin_until

from amr_localization.beacon_localizer_node import BeaconLocalizerNode
from amr_maps.world import WorldError, load_world
from amr_simulation.simulator_node import SimulatorNode

BEACONS = [[-1.9, -1.4], [1.9, -1.4], [1.9, 1.4], [-1.9, 1.4]]
ROOM = {
    "name": "beacon_room",
    "wall_thickness": 0.05,
    "walls": [[-2.0, -1.5, 2.0, -1.5], [2.0, -1.5, 2.0, 1.5], [2.0, 1.5, -2.0, 1.5], [-2.0, 1.5, -2.0, -1.5]],
    "start": [0.7, -0.4, 0.5],
    "beacons": BEACONS,
}


def test_relocalizes_from_beacons_and_tracks_with_one_pose_per_reading(executor, tmp_path):
    world = tmp_path / "beacon_room.yaml"
    world.write_text(yaml.safe_dump(ROOM))
    context = executor.context
    simulator = SimulatorNode(
        context=context,
        parameter_overrides=[
            Parameter("world", value=str(world)),
            Parameter("lockstep_resend_period", value=0.0),
            Parameter("beacons.range_noise_std", value=0.003),
            Parameter("beacons.compass_noise_std", value=0.005),
        ],
    )
    localizer = BeaconLocalizerNode(context=context)
    driver = Driver(context)
    for node in (simulator, localizer, driver):
        executor.add_node(node)
    for node in (localizer, simulator):
        assert node.try_transition(Transition.TRANSITION_CONFIGURE), node.get_name()
    assert localizer.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: simulator.count_subscribers("beacons") >= 2, 5.0)
    assert simulator.try_transition(Transition.TRANSITION_ACTIVATE)
    assert spin_until(executor, lambda: len(driver.poses) >= STEPS, 30.0), f"{len(driver.poses)} poses"
    spin_for(executor, 0.2)

    assert [stamp_ns(p) for p in driver.poses] == [stamp_ns(r) for r in driver.readings]
    reading = driver.readings[0]
    assert [[b.x, b.y] for b in reading.beacons] == BEACONS and len(reading.ranges) == len(BEACONS)
    for pose in driver.poses:
        assert driver.error(pose)[0] <= 0.02
        assert pose.localized and pose.header.frame_id == "map"


def test_an_empty_beacon_list_is_refused_by_name(tmp_path):
    world = tmp_path / "no_beacons.yaml"
    world.write_text(yaml.safe_dump({**ROOM, "beacons": []}))
    with pytest.raises(WorldError, match="beacons: must be a non-empty list"):
        load_world(world)
