"""GraphSlam's statistical tests on matches and closures: a weak scan match with a second mode in its window is
widened to span both (the odometry decides between them), one that disagrees with the odometry is not used; the
closure gate uses the graph's own uncertainty (a closure found earlier shortens the chain it compounds); a loop
closure that the optimized graph disagrees with is removed; the pose graph's marginals and edge removal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from amr_mapping import slam as slam_module
from amr_mapping.errors import MappingError
from amr_mapping.pose_graph import PoseGraph
from amr_mapping.slam import GraphSlam
from amr_maps.occupancy_grid import OCCUPIED, OccupancyGrid
from amr_maps.scan_matcher import CorrelativeMatcher, ScoreMap
from amr_util.geometry import compose, relative_pose, wrap_angle

STEP_COVARIANCE = np.diag([0.02**2, 0.02**2, math.radians(1.0) ** 2])


def _chain(graph: PoseGraph, steps, covariance=STEP_COVARIANCE) -> np.ndarray:
    """Nodes along `steps` (dx, dy, dtheta) from the origin, exact sequential edges; returns the poses."""
    poses = [np.zeros(3)]
    graph.add_node(poses[0])
    for k, step in enumerate(steps, start=1):
        poses.append(np.array(compose(poses[-1], step)))
        graph.add_node(poses[-1])
        graph.add_edge(k - 1, k, step, np.linalg.inv(covariance))
    return np.array(poses)


def _square(side: int = 5, laps: int = 1):
    """Steps of `laps` laps of a square of `side` 1 m steps, a 90 deg turn at each corner."""
    return [(1.0, 0.0, math.pi / 2 if k % side == side - 1 else 0.0) for k in range(4 * side * laps)]


def test_marginals_equal_the_chain_and_shrink_with_a_closure():
    """Along a chain the last node's covariance is the steps' compounded (x along: 20 steps of 2 cm); a closure
    back to node 0 cuts it to about what the closure says."""
    graph = PoseGraph()
    _chain(graph, [(1.0, 0.0, 0.0)] * 20)
    alone = graph.marginal_covariance([20])
    assert alone[0, 0] == pytest.approx(20 * 0.02**2, rel=1e-6)
    lever = sum(k**2 for k in range(20)) * math.radians(1.0) ** 2  # heading errors swing the end sideways
    assert alone[1, 1] == pytest.approx(20 * 0.02**2 + lever, rel=1e-6)
    graph.add_edge(0, 20, (20.0, 0.0, 0.0), np.linalg.inv(STEP_COVARIANCE), loop=True)
    closed = graph.marginal_covariance([0, 20])
    assert np.all(closed[:3] == 0.0) and np.all(closed[:, :3] == 0.0)  # node 0 is fixed
    assert closed[3, 3] < 1.1 * 0.02**2 and closed[4, 4] < 1.1 * 0.02**2


def test_remove_edges_keeps_the_others_in_order():
    graph = PoseGraph()
    _chain(graph, [(1.0, 0.0, 0.0)] * 3)
    graph.add_edge(0, 3, (3.0, 0.0, 0.0), np.eye(3), loop=True)
    graph.remove_edges([1])
    assert graph.edges.tolist() == [[0, 1], [2, 3], [0, 3]]
    assert graph.loop.tolist() == [False, False, True]
    with pytest.raises(MappingError, match="remove_edges"):
        graph.remove_edges([3])


def test_the_gate_counts_the_closures_already_in_the_graph():
    """Two nodes 56 steps apart along the path, tied by a closure 40 steps in: their relative pose is the last 16
    steps' uncertainty, not the 56 steps' the chain compounded (a closure 1.2 m off passed that gate, at the chain's
    claim; the gate takes it GATE_DRIFT_SCALE times over, so the offset here is as many times the root longer)."""
    slam = GraphSlam()
    poses = _chain(slam._graph, _square(5, 3), STEP_COVARIANCE)
    before = slam._relative_covariance(slam._graph.marginals(), 2, 58)
    slam._graph.add_edge(2, 42, relative_pose(poses[2], poses[42]), np.linalg.inv(STEP_COVARIANCE), loop=True)
    after = slam._relative_covariance(slam._graph.marginals(), 2, 58)
    assert math.sqrt(before[0, 0] + before[1, 1]) > 0.5
    assert math.sqrt(after[0, 0] + after[1, 1]) < 0.65 * math.sqrt(before[0, 0] + before[1, 1])
    scale = slam_module.GATE_DRIFT_SCALE
    innovation = np.array([1.2 * math.sqrt(scale), 0.0, 0.0])
    assert innovation @ np.linalg.solve(scale * before, innovation) < slam_module.LOOP_CHI2
    assert innovation @ np.linalg.solve(scale * after, innovation) > slam_module.LOOP_CHI2


def test_the_gate_weighs_a_closure_against_the_chains_drift_at_gate_drift_scale_times_its_claim(monkeypatch):
    """The links claim less than they err on real logs, so the gate takes the chain's uncertainty GATE_DRIFT_SCALE
    times over: a closure as far off as a chain of calibrated links would err (chi-square 30 at the chain's claim,
    refused before: intel played backwards refused 271 right closures) passes; one twice as far off again does not."""
    slam = GraphSlam()
    poses = _chain(slam._graph, _square(5, 3), STEP_COVARIANCE)
    monkeypatch.setattr(slam, "_closure_covariance", lambda *args: np.diag([1e-6, 1e-6, 1e-8]))
    claim = slam._relative_covariance(slam._graph.marginals(), 2, 58)
    predicted = np.array(relative_pose(poses[2], poses[58]))
    direction = np.array([1.0, 0.0, 0.0])
    unit = float(direction @ np.linalg.solve(claim, direction))

    def gated(chi2_at_claim: float) -> bool:
        matched = predicted + direction * math.sqrt(chi2_at_claim / unit)
        candidate = slam_module._Candidate(submap=0, node=58, points=np.zeros((0, 2)), prior=predicted, matched=matched)
        return slam._gate(slam_module._Submap(anchor=2, last=11), candidate, []) is not None

    assert slam_module.LOOP_CHI2 < 30.0 < slam_module.GATE_DRIFT_SCALE * slam_module.LOOP_CHI2
    assert gated(30.0)
    assert not gated(4.0 * slam_module.GATE_DRIFT_SCALE * slam_module.LOOP_CHI2)


def test_a_closure_the_optimized_graph_disagrees_with_is_removed():
    """Two laps of a square with true closures at every node of the second lap and one false closure 1.5 m off:
    the kernel turns it down, its residual stays far out, it is removed; the true ones stay."""
    slam = GraphSlam()
    steps = _square(5, 2)
    poses = _chain(slam._graph, steps)
    information = np.linalg.inv(np.diag([0.01**2, 0.01**2, math.radians(0.5) ** 2]))
    for k in range(21, 41):
        slam._graph.add_edge(k - 20, k, relative_pose(poses[k - 20], poses[k]), information, loop=True)
    false = np.array(relative_pose(poses[3], poses[30])) + (1.5, 0.0, 0.0)
    slam._graph.add_edge(3, 30, false, information, loop=True)
    events: list[str] = []
    slam._optimize(30, events)
    assert slam.dropped_closures == 1
    assert slam._graph.loop.sum() == 20
    assert [3, 30] not in slam._graph.edges.tolist()
    assert any("(3, 30)" in event and "removed" in event for event in events)
    error = slam._graph.poses - poses
    assert np.abs(error[:, :2]).max() < 0.05 and np.abs(wrap_angle(error[:, 2])).max() < 0.01


def test_an_update_takes_a_bounded_share_of_the_optimization_and_the_next_ones_the_rest(monkeypatch):
    """The optimization a closure starts is carried over the updates (OPTIMIZE_BUDGET an update, one iteration at
    least): with a budget of one iteration, each update runs one; the run ends as a whole one does, the false
    closure 1.5 m off removed and the graph optimized again without it."""
    monkeypatch.setattr(slam_module, "OPTIMIZE_BUDGET", 0.0)
    slam = GraphSlam()
    poses = _chain(slam._graph, _square(5, 2))
    information = np.linalg.inv(np.diag([0.01**2, 0.01**2, math.radians(0.5) ** 2]))
    for k in range(21, 41):
        slam._graph.add_edge(k - 20, k, relative_pose(poses[k - 20], poses[k]), information, loop=True)
    slam._graph.add_edge(3, 30, np.array(relative_pose(poses[3], poses[30])) + (1.5, 0.0, 0.0), information, loop=True)
    events: list[str] = []
    slam._start_optimization(events, drops=1)
    updates, iterations = 0, []
    while slam._run is not None and updates < 50:
        run = slam._run
        before = run.iterations
        slam._advance_optimization(40, events)
        iterations.append(run.iterations - before)
        updates += 1
    assert slam._run is None and updates > 3 and set(iterations) == {1}
    assert slam.dropped_closures == 1 and [3, 30] not in slam._graph.edges.tolist()
    error = slam._graph.poses - poses
    assert np.abs(error[:, :2]).max() < 0.05 and np.abs(wrap_angle(error[:, 2])).max() < 0.01
    assert np.allclose(slam.pose, slam._graph.pose(40))


def _two_walls(gap: float | None) -> CorrelativeMatcher:
    """A likelihood field of a 3 m wall at x = 2 (and a parallel one `gap` m further), 5 cm cells."""
    data = np.zeros((120, 160), dtype=np.int8)  # x -2..6, y -3..3
    ys = np.arange(-1.5, 1.5, 0.025)
    for x in (2.0,) if gap is None else (2.0, 2.0 + gap):
        data[np.floor((ys + 3.0) / 0.05).astype(int), int(math.floor((x + 2.0) / 0.05))] = OCCUPIED
    grid = OccupancyGrid(data, 0.05, (-2.0, -3.0, 0.0))
    return CorrelativeMatcher(ScoreMap.from_occupancy(grid, sigma=0.075))


def test_a_weak_match_with_a_second_mode_has_a_rival():
    """A scan of a lone wall ahead, in a submap with a parallel wall 0.6 m behind the first: placing it on either
    wall scores alike, so the match has a rival mode 0.6 m off; with one wall it has none (sliding along the wall
    is the match's own slope, its information says so)."""
    points = np.column_stack([np.full(100, 2.0), np.linspace(-1.5, 1.5, 100)])
    for gap, expected in ((0.6, True), (None, False)):
        matcher = _two_walls(gap)
        match = matcher.match(points, np.zeros(3), 1.0, 0.2)
        rival = slam_module._local_rival(matcher, points, match.pose, np.zeros(3), 1.0, 0.2, match.score)
        assert (rival is not None) == expected, (gap, rival)
        if expected:
            assert abs(abs(rival[0] - match.pose[0]) - 0.6) < 0.1 and abs(rival[2]) < 0.1, rival


def test_a_weak_match_is_widened_by_its_rivals_share_and_refused_when_the_odometry_disagrees():
    """The front end's test of a weak match. With a second wall 0.6 m behind, both placements score alike: the
    covariance grows along x by the rival's posterior share, about half with the odometry prior halfway between
    them, next to nothing with the prior on the match (the rival 6 odometry sigmas off); on a lone wall it is used
    when the odometry prior lies 10 cm off, refused 60 cm off (odometry sigma 10 cm: chi-square 36)."""
    points = np.column_stack([np.full(100, 2.0), np.linspace(-1.5, 1.5, 100)])
    odometry_information = np.diag([1.0 / 0.1**2, 1.0 / 0.1**2, 1.0 / 0.05**2])
    cases = ((0.6, 0.3, "half", True), (0.6, None, "none", True), (None, 0.1, None, True), (None, 0.6, None, False))
    for gap, prior_x, widened, used in cases:
        matcher = _two_walls(gap)
        match = matcher.match(points, np.zeros(3), 1.0, 0.2)  # on either wall (x 0 or 0.6): they score alike
        prior_x = match.pose[0] if prior_x is None else prior_x  # on the match, or halfway between the two
        information = slam_module._match_information(matcher, points, match.pose, 0.05)
        events: list[str] = []
        result = slam_module._weak_match(
            matcher,
            points,
            match,
            match.pose,
            information,
            np.array([prior_x, 0.0, 0.0]),
            odometry_information,
            events,
            (1.0, 0.2),
        )
        assert (result is not None) == used, (gap, prior_x, events)
        assert any("rival" in event for event in events) == (widened is not None), events
        if widened == "half":  # the second moment about the match: its own plus half of 0.6^2 along x
            assert 0.3 * 0.6**2 < np.linalg.inv(result)[0, 0] < 0.7 * 0.6**2 + np.linalg.inv(information)[0, 0]
        if widened == "none":
            assert np.linalg.inv(result)[0, 0] < np.linalg.inv(information)[0, 0] + 1e-4, events
        if not used:
            assert any("disagrees with the odometry" in event for event in events), events


def test_a_rivals_share_is_a_probability_however_far_apart_the_modes_score():
    """The rival's share of the two modes' posterior: a half when the odometry sits halfway between two placements
    that score alike, and 0 or 1, never an overflow, when the odometry puts one of them thousands of nats behind."""
    points = np.column_stack([np.full(100, 2.0), np.linspace(-1.5, 1.5, 100)])
    matcher = _two_walls(0.6)
    match, rival = np.zeros(3), np.array([0.6, 0.0, 0.0])
    share = slam_module._rival_share
    loose = np.diag([1.0 / 0.3**2, 1.0 / 0.3**2, 1.0 / 0.1**2])
    assert share(matcher, points, match, rival, np.array([0.3, 0.0, 0.0]), loose) == pytest.approx(0.5, abs=0.05)
    tight = np.diag([1e6, 1e6, 1e6])  # the odometry certain to a millimetre: the other mode 180,000 nats behind
    assert share(matcher, points, match, rival, np.zeros(3), tight) == 0.0
    assert share(matcher, points, match, rival, rival, tight) == 1.0


def test_a_closure_match_on_its_windows_edge_is_no_peak():
    """The best pose of a loop-closure window found on its side (3.1 m off with a +-3 m window, or at the angular
    window's end) is the window's maximum, not the score's: not a closure; inside the window it may be one."""
    config = GraphSlam().config
    prior = np.array([1.0, 2.0, 0.3])
    window, turn = config.loop_linear_window, config.loop_angular_window
    assert slam_module._on_edge(prior + (window + 0.1, 0.0, 0.0), prior, config)
    assert slam_module._on_edge(prior + (0.0, -window, 0.0), prior, config)
    assert slam_module._on_edge(prior + (0.0, 0.0, turn), prior, config)
    assert not slam_module._on_edge(prior + (window - 0.3, 1.0, turn - 0.1), prior, config)
