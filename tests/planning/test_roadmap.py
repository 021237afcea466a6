"""The course's PRM: deterministic per seed, edges clear of the inflated map, shortest route over the graph."""

import numpy as np
import pytest
from support.planning import grid, walled

from amr_planning.costmap import Costmap
from amr_planning.errors import PlanningError, Reason
from amr_planning.roadmap import Roadmap, RoadmapConfig
from amr_util.parameter_spec import ConfigError


def two_rooms():
    data = walled(40, 80)  # 2 x 4 m
    data[:, 40] = 100
    data[16:24, 40] = 0  # a 0.4 m door
    return Costmap(grid(data))


def test_the_same_seed_gives_the_same_roadmap_and_path_another_seed_another():
    costmap = two_rooms()
    first = Roadmap(costmap, RoadmapConfig(node_count=300, seed=7))
    again = Roadmap(costmap, RoadmapConfig(node_count=300, seed=7))
    other = Roadmap(costmap, RoadmapConfig(node_count=300, seed=8))
    assert np.array_equal(first.nodes, again.nodes) and np.array_equal(first.edges, again.edges)
    assert not np.array_equal(first.nodes, other.nodes)
    path = first.plan((0.5, 1.0), (3.5, 1.0)).points
    assert np.array_equal(path, again.plan((0.5, 1.0), (3.5, 1.0)).points)


def test_nodes_and_edges_stay_out_of_inflated_cells_and_the_path_goes_through_the_door():
    costmap = two_rooms()
    roadmap = Roadmap(costmap, RoadmapConfig(node_count=300, seed=1))
    assert not costmap.lethal_at(roadmap.nodes, costmap.inflated).any()
    a, b = roadmap.edges.T
    assert costmap.segments_free(roadmap.nodes[a], roadmap.nodes[b], costmap.inflated).all()
    assert (np.hypot(*(roadmap.nodes[a] - roadmap.nodes[b]).T) <= roadmap.config.connection_distance).all()
    path = roadmap.plan((0.5, 1.0), (3.5, 1.0))
    assert np.allclose(path.points[0], (0.5, 1.0)) and np.allclose(path.points[-1], (3.5, 1.0))
    assert costmap.segments_free(path.points[:-1], path.points[1:]).all()
    crossing = path.points[np.argmin(np.abs(path.points[:, 0] - 2.025))]
    assert 0.8 <= crossing[1] <= 1.2  # through the door
    assert path.cost == pytest.approx(path.length)


def test_the_roadmap_route_is_the_shortest_over_its_graph():
    costmap = two_rooms()
    roadmap = Roadmap(costmap, RoadmapConfig(node_count=150, seed=3))
    path = roadmap.plan(roadmap.nodes[0], roadmap.nodes[1])
    # Bellman-Ford relaxation over the graph's edges as the reference
    n = len(roadmap.nodes)
    a, b = roadmap.edges.T
    length = np.hypot(*(roadmap.nodes[a] - roadmap.nodes[b]).T)
    best = np.full(n, np.inf)
    best[0] = 0.0
    for _ in range(n):
        new = best.copy()
        np.minimum.at(new, b, best[a] + length)
        np.minimum.at(new, a, best[b] + length)
        if np.array_equal(new, best):
            break
        best = new
    direct = (
        np.hypot(*(roadmap.nodes[0] - roadmap.nodes[1]))
        if costmap.segments_free(roadmap.nodes[:1], roadmap.nodes[1:2])[0]
        else np.inf
    )
    assert path.cost == pytest.approx(min(best[1], direct))


def test_a_closed_wall_makes_the_goal_unreachable_with_a_message():
    data = walled(40, 80)
    data[:, 40] = 100
    roadmap = Roadmap(Costmap(grid(data)), RoadmapConfig(node_count=200))
    with pytest.raises(PlanningError, match="roadmap .* joins no route") as error:
        roadmap.plan((0.5, 1.0), (3.5, 1.0))
    assert error.value.reason is Reason.UNREACHABLE


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"node_count": 0}, "node_count"),
        ({"connection_distance": -1.0}, "connection_distance"),
        ({"seed": -1}, "seed"),
    ],
)
def test_bad_configs_are_refused_by_name(kwargs, name):
    with pytest.raises(ConfigError, match=name):
        RoadmapConfig(**kwargs)
