"""The evidence ledger alone (issue 20): places with accumulated log-evidence, on synthetic scans, no simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_localization.distance_field import DistanceField
from amr_localization.evidence_ledger import EvidenceLedger, LedgerParams
from amr_localization.free_space import FreeSpace
from amr_localization.likelihood_field import LikelihoodField, LikelihoodFieldParams
from amr_localization.scan_beams import select_beams
from amr_localization.sensor_mount import SensorMount
from amr_maps.rasterize import rasterize_world
from amr_maps.raycast import NumpyRayCaster
from amr_maps.symmetry_families import symmetry_case
from amr_maps.world import world_from_dict
from amr_util.scan import ScanData

BEAMS = 240


def _ledger(case_world, **params):
    world = world_from_dict(case_world)
    field = DistanceField(rasterize_world(world, 0.02))
    model = LikelihoodField(field, LikelihoodFieldParams(), SensorMount(), 3.5)
    return world, EvidenceLedger(model, FreeSpace(field, 0.08), LedgerParams(**params))


def _scan(world, pose, rng, noise=0.01) -> ScanData:
    ranges = NumpyRayCaster(world.faces).cast(pose[0], pose[1], pose[2], 2 * math.pi / BEAMS, BEAMS, 3.5)
    ranges = np.where(ranges <= 3.5, ranges + rng.normal(0.0, noise, BEAMS), np.inf)
    return ScanData(ranges, 0.0, 2 * math.pi / BEAMS, 0.12, 3.5)


def _turns(pose):
    x, y, theta = pose
    return [np.array([math.cos(k * math.pi / 2) * x - math.sin(k * math.pi / 2) * y,
                      math.sin(k * math.pi / 2) * x + math.cos(k * math.pi / 2) * y, theta + k * math.pi / 2])
            for k in range(4)]


def test_a_place_is_entered_once_and_keeps_its_evidence():
    _, ledger = _ledger(symmetry_case("island", 0).world)
    first = ledger.add(np.array([1.0, 1.0, 0.0]), 0.0)
    assert ledger.add(np.array([1.1, 0.95, 0.2]), -5.0) == first, "within match_distance and match_angle"
    assert ledger.evidence[first] == 0.0
    other = ledger.add(np.array([-1.0, 1.0, 0.0]), -3.0)
    assert other != first and len(ledger) == 2
    assert ledger.find(np.array([-1.0, 1.0, math.pi])) == -1, "same position, another heading: another place"
    assert ledger.ruled_out().tolist() == [False, False]


def test_the_least_supported_place_is_forgotten_when_the_ledger_is_full():
    _, ledger = _ledger(symmetry_case("island", 0).world, max_entries=3)
    for k, evidence in enumerate([0.0, -1.0, -6.0]):
        ledger.add(np.array([-1.2 + 0.8 * k, -1.2, 0.0]), evidence)
    ledger.add(np.array([1.2, 1.2, 0.0]), -2.0)
    assert len(ledger) == 3
    assert ledger.find(np.array([0.4, -1.2, 0.0])) == -1, "the entry at -6 went"
    assert ledger.find(np.array([1.2, 1.2, 0.0])) >= 0


def test_an_entry_moved_into_a_wall_is_ruled_out_for_good_and_not_entered_again():
    room = {"walls": [[-2, -2, 2, -2], [2, -2, 2, 2], [2, 2, -2, 2], [-2, 2, -2, -2]], "boxes": [[-1, -1, 1, 1]],
            "wall_thickness": 0.04, "start": [-1.5, -1.5, 0.0]}
    _, ledger = _ledger(room)
    ledger.add(np.array([0.0, -1.5, 0.0]), 0.0)  # below the island, heading +x
    ledger.add(np.array([-1.5, 0.0, 0.0]), -3.0)  # left of it
    ledger.move(np.array([0.0, 1.0, 0.0]))  # one metre to the robot's left: the first into the island
    inside = ledger.find(np.array([0.0, -0.5, 0.0]))
    free = ledger.find(np.array([-1.5, 1.0, 0.0]))
    assert inside >= 0 and free >= 0
    assert ledger.ruled_out()[inside] and not ledger.ruled_out()[free]
    assert ledger.evidence[free] == 0.0, "the best remaining place is the reference"
    assert ledger.add(np.array([0.0, -0.5, 0.0]), 0.0) == inside, "its place found again stays ruled out"
    assert ledger.ruled_out()[inside]


def test_new_entries_settle_before_their_evidence_counts():
    case = symmetry_case("notch", 3)
    world, ledger = _ledger(case.world, settle_updates=5)
    rng = np.random.default_rng(0)
    start = np.array(case.world["start"])
    for pose in _turns(start):
        ledger.add(pose, 0.0)
    for _ in range(5):
        ledger.observe(select_beams(_scan(world, start, rng), 180, keep_no_return=True), 0.1)
    assert (ledger.evidence == 0.0).all()


@pytest.mark.parametrize("kind, seed", [("notch", 0), ("extra_pillar", 2), ("doorway", 1)])
def test_scans_of_the_feature_rule_out_the_quarter_turns_from_everywhere_it_is_in_view(kind, seed):
    case = symmetry_case(kind, seed)
    world, ledger = _ledger(case.world)
    symmetric = NumpyRayCaster(world_from_dict(case.symmetric).faces)
    caster = NumpyRayCaster(world.faces)
    rng = np.random.default_rng(seed)
    xmin, ymin, xmax, ymax = world.bounds
    for _ in range(2000):  # a free pose from which the feature is in view (10 beams differ from the room without it)
        pose = rng.uniform([xmin, ymin, -math.pi], [xmax, ymax, math.pi])
        if world.clearance(pose[None, :2])[0] < 0.25:
            continue
        ranges = [np.minimum(c.cast(*pose, 2 * math.pi / BEAMS, BEAMS, 3.5), 3.5) for c in (caster, symmetric)]
        if np.count_nonzero(np.abs(ranges[0] - ranges[1]) > 0.05) >= 10:
            break
    else:
        pytest.fail("no pose sees the feature")
    for turned in _turns(pose):
        ledger.add(turned, 0.0)
    for _ in range(40):  # standing still: the same view, new noise each scan
        ledger.observe(select_beams(_scan(world, pose, rng), 180, keep_no_return=True), 0.1 * 60 / 180)
    truth = ledger.find(pose)
    assert truth >= 0 and ledger.evidence[truth] == 0.0
    assert ledger.ruled_out().sum() == 3, f"evidence {ledger.evidence}"


def test_in_a_truly_symmetric_room_no_scan_tells_the_quarter_turns_apart():
    case = symmetry_case("ring", 2)
    world, ledger = _ledger(case.world)
    rng = np.random.default_rng(2)
    pose = np.array(case.world["start"])
    for turned in _turns(pose):
        ledger.add(turned, 0.0)
    for step in range(60):
        moved = pose + np.array([0.02 * step * math.cos(pose[2]), 0.02 * step * math.sin(pose[2]), 0.0])
        if step:
            ledger.move(np.array([0.02, 0.0, 0.0]))
        ledger.observe(select_beams(_scan(world, moved, rng, noise=0.03), 180, keep_no_return=True), 0.1)
    assert len(ledger) == 4 and (ledger.evidence == 0.0).all()


def test_clear_forgets_everything():
    _, ledger = _ledger(symmetry_case("island", 0).world)
    ledger.add(np.array([1.0, 1.0, 0.0]), 0.0)
    ledger.clear()
    assert len(ledger) == 0 and ledger.find(np.array([1.0, 1.0, 0.0])) == -1
