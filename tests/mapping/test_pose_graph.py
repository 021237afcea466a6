"""The Pose2 pose graph: a known trajectory recovered from drifting odometry and loop closures, a false closure
survived by the robust kernel (and not without it), divergence refused with the poses kept, bad edges refused."""

from __future__ import annotations

import numpy as np
import pytest

import amr_mapping.pose_graph as pose_graph_module
from amr_mapping.errors import MappingError
from amr_mapping.pose_graph import PoseGraph
from amr_util.geometry import compose, relative_pose

SIGMA = np.array([0.02, 0.02, np.radians(0.5)])
INFO = np.diag(1.0 / SIGMA**2)
ODOMETRY_SIGMA = np.array([0.05, 0.05, np.radians(2.0)])
"""Odometry's stated uncertainty covers its noise (SIGMA) and its heading bias (1 deg a step)."""


def _square_loops(laps: int = 2, side: int = 6) -> np.ndarray:
    """True poses: `laps` laps of a square of `side` 1 m steps, turning 90 deg at each corner."""
    poses = [np.zeros(3)]
    for _ in range(laps):
        for _ in range(4):
            for step in range(side):
                turn = np.pi / 2 if step == side - 1 else 0.0
                poses.append(np.array(compose(poses[-1], (1.0, 0.0, turn))))
    return np.array(poses)


def _graph(truth: np.ndarray, seed: int, loop_kernel: str = "cauchy") -> tuple[PoseGraph, np.ndarray]:
    """Odometry with noise and a heading bias chained into the initial guess; loop closures (exact up to the
    noise) between poses at the same true place."""
    rng = np.random.default_rng(seed)
    graph = PoseGraph(loop_kernel=loop_kernel)
    guess = truth[0].copy()
    graph.add_node(guess)
    for k in range(1, len(truth)):
        z = np.array(relative_pose(truth[k - 1], truth[k])) + rng.normal(0.0, SIGMA) + (0.0, 0.0, np.radians(1.0))
        guess = np.array(compose(guess, z))
        graph.add_node(guess)
        graph.add_edge(k - 1, k, z, np.diag(1.0 / ODOMETRY_SIGMA**2))
    for j in range(len(truth)):
        for i in range(j - 5):
            if np.hypot(*(truth[i, :2] - truth[j, :2])) < 1e-6:
                z = np.array(relative_pose(truth[i], truth[j])) + rng.normal(0.0, SIGMA)
                graph.add_edge(i, j, z, INFO, loop=True)
    return graph, guess


def _position_error(graph: PoseGraph, truth: np.ndarray) -> float:
    return float(np.max(np.hypot(*(graph.poses[:, :2] - truth[:, :2]).T)))


def test_loop_closures_recover_the_trajectory_from_drifting_odometry():
    truth = _square_loops()
    graph, _ = _graph(truth, seed=1)
    drift = _position_error(graph, truth)
    assert drift > 1.0  # 1 deg a step of heading bias
    result = graph.optimize()
    assert result.converged and result.final_cost < result.initial_cost
    assert _position_error(graph, truth) < 0.1
    assert graph.loop.sum() > 0 and graph.edges.shape == (graph.edge_count, 2)


def _with_false_closure(loop_kernel: str) -> float:
    truth = _square_loops()
    graph, _ = _graph(truth, seed=2, loop_kernel=loop_kernel)
    # a false closure: node 9 (on the second side) said to be 0.5 m ahead of node 0, 4 m from where it is
    graph.add_edge(0, 9, (0.5, 0.0, 0.0), INFO, loop=True)
    graph.optimize(max_iterations=50)
    return _position_error(graph, truth)


def test_the_robust_kernel_survives_a_false_closure():
    assert _with_false_closure("cauchy") < 0.15  # 0.07 m without the false closure


def test_without_the_kernel_the_false_closure_wrecks_the_map_and_huber_only_softens_it():
    wrecked = _with_false_closure("none")
    assert wrecked > 2.0
    assert 0.15 < _with_false_closure("huber") < wrecked / 2  # convex: the false closure still pulls


def _with_a_wrong_match(edge_kernel_width: float | None) -> float:
    """Two laps, every edge (the scan matches and the closures) at SIGMA, but one scan match 10 deg off (a
    wrong heading mode in a fast turn); the largest position error after optimizing."""
    truth = _square_loops()
    rng = np.random.default_rng(3)
    graph = PoseGraph(edge_kernel_width=edge_kernel_width)
    guess = truth[0].copy()
    graph.add_node(guess)
    for k in range(1, len(truth)):
        z = np.array(relative_pose(truth[k - 1], truth[k])) + rng.normal(0.0, SIGMA)
        if k == 30:
            z[2] += np.radians(10.0)
        guess = np.array(compose(guess, z))
        graph.add_node(guess)
        graph.add_edge(k - 1, k, z, INFO)
    for j in range(len(truth)):
        for i in range(j - 5):
            if np.hypot(*(truth[i, :2] - truth[j, :2])) < 1e-6:
                graph.add_edge(i, j, np.array(relative_pose(truth[i], truth[j])) + rng.normal(0.0, SIGMA), INFO, True)
    assert graph.optimize(max_iterations=50).converged
    return _position_error(graph, truth)


def test_a_kernel_on_the_scan_matches_lets_one_far_off_give_way_to_the_closures():
    """Least squares spreads the wrong match's 10 deg over the loop (0.14 m off); with the Cauchy kernel on the
    scan-match edges it gives way (0.06 m, about the error with no wrong match: 0.07)."""
    plain, robust = _with_a_wrong_match(None), _with_a_wrong_match(3.0)
    assert plain > 0.12
    assert robust < 0.08 and robust < 0.6 * plain


def test_an_edge_kernel_still_meets_every_edge_of_a_chain_without_closures():
    truth = _square_loops(laps=1)
    graph = PoseGraph(edge_kernel_width=3.0)
    graph.add_node(truth[0])
    for k in range(1, len(truth)):
        graph.add_node(truth[k])
        graph.add_edge(k - 1, k, np.array(relative_pose(truth[k - 1], truth[k])) + (0.0, 0.0, 0.2), INFO)
    before = graph.poses
    result = graph.optimize()
    assert result.converged and not np.allclose(graph.poses, before)  # it moved: the edges disagreed with the poses
    assert np.allclose(graph.chi2(), 0.0, atol=1e-6)  # and now meets every edge exactly: a chain has one solution


def test_a_diverging_optimization_raises_and_keeps_the_poses(monkeypatch):
    truth = _square_loops(laps=1)
    graph, _ = _graph(truth, seed=3)
    before = graph.poses

    class Broken:
        def solve(self, rhs):
            return np.full_like(rhs, np.nan)

    monkeypatch.setattr(pose_graph_module, "splu", lambda *args, **kwargs: Broken())
    with pytest.raises(MappingError, match="diverged"):
        graph.optimize()
    assert np.array_equal(graph.poses, before)


def test_an_optimized_graph_optimizes_again_without_moving():
    graph, _ = _graph(_square_loops(laps=1), seed=4)
    graph.optimize()
    again = graph.optimize()
    assert again.converged and again.max_change < 1e-3


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda g: g.add_edge(0, 0, (1, 0, 0), INFO), "two different nodes"),
        (lambda g: g.add_edge(0, 5, (1, 0, 0), INFO), "two different nodes"),
        (lambda g: g.add_edge(0, 1, (np.nan, 0, 0), INFO), "finite"),
        (lambda g: g.add_edge(0, 1, (1, 0, 0), -INFO), "positive definite"),
        (lambda g: g.add_edge(0, 1, (1, 0, 0), INFO + np.triu(np.ones((3, 3)), 1)), "symmetric"),
        (lambda g: g.add_node((0, np.inf, 0)), "finite"),
        (lambda g: PoseGraph(loop_kernel="tukey"), "loop_kernel"),
        (lambda g: PoseGraph(edge_kernel_width=0.0), "edge_kernel_width"),
        (lambda g: PoseGraph(edge_kernel_width=float("nan")), "edge_kernel_width"),
    ],
)
def test_bad_input_is_refused(call, message):
    graph = PoseGraph()
    graph.add_node((0, 0, 0))
    graph.add_node((1, 0, 0))
    with pytest.raises(MappingError, match=message):
        call(graph)


def test_an_optimization_taken_an_iteration_at_a_time_ends_where_one_call_does():
    """Optimization.step(1) repeated is optimize(): the kernel's width and the damping carry over between steps, and
    every step leaves the graph at a lower cost (a consistent graph between updates)."""
    truth = _square_loops()
    whole, _ = _graph(truth, seed=1)
    stepped, _ = _graph(truth, seed=1)
    result = whole.optimize(max_iterations=30)
    run = stepped.optimization(max_iterations=30)
    costs = [stepped.cost()]
    while not run.step(1):
        costs.append(stepped.cost())
    assert run.iterations == result.iterations > 2
    assert run.result().converged and np.allclose(stepped.poses, whole.poses)
    assert costs[-1] < costs[0] and _position_error(stepped, truth) < 0.1


def test_nodes_added_between_steps_join_the_optimization():
    truth = _square_loops()
    graph, guess = _graph(truth[:-3], seed=1)
    run = graph.optimization(max_iterations=30)
    run.step(1)
    for k in range(len(truth) - 3, len(truth)):  # three more nodes, exact steps, the last closing on node 0's place
        graph.add_node(compose(graph.pose(k - 1), relative_pose(truth[k - 1], truth[k])))
        graph.add_edge(k - 1, k, relative_pose(truth[k - 1], truth[k]), INFO)
    last = len(truth) - 1
    graph.add_edge(0, last, relative_pose(truth[0], truth[last]), INFO, loop=True)
    while not run.step(1):
        pass
    assert graph.node_count == len(truth) and run.result().converged
    assert _position_error(graph, truth) < 0.1
