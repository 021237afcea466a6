"""How long a fleet plan takes (amr_planning.fleet_lacam.plan_lacam, library level, no ROS): prints, asserts nothing.

Six robots (--robots) from random distinct lattice vertices (--trials of them, numpy default_rng(--seed)) to the
bench's goals of a generated tree maze (`perfect` --maze, amr_evaluation.fleet_navigation.with_robots: each robot
sent to the next one's start), the lattice the maze's cells (grid_pitch). Random starts stand for what the fleet
planner meets when it plans again from where the robots stand (a robot stuck, a pose that jumped): not the
bench's own starts, which are spread apart. Each start is planned with restarts (plan_lacam's default: 250
configurations, then the next seed with twice the budget) and, with --single, by one search of up to
`max_nodes` configurations, as before the restarts (slow: one took 107 s on `perfect 15`).

--family picks another maze family of amr_maps.maze_families (the lattice then is what amr_planning.fleet_plan.lattice
makes of it at 0.4 m: the sampled lattice where the square grid does not follow the free space, as in `rotated`
mazes); --figure PATH draws the lattice, the robots' starts and goals.

    python bench/bench_fleet_plan.py [--maze 15] [--trials 60] [--single]
    python bench/bench_fleet_plan.py --family rotated --maze 0 --trials 0 --figure docs/fleet_lattice.png
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from amr_evaluation.fleet_navigation import lattice_spacing  # noqa: E402
from amr_maps.maze_families import generate  # noqa: E402
from amr_maps.rasterize import rasterize_world  # noqa: E402
from amr_maps.world import world_from_dict  # noqa: E402
from amr_planning.costmap import Costmap, CostmapConfig  # noqa: E402
from amr_planning.errors import PlanningError  # noqa: E402
from amr_planning.fleet_lacam import MAX_NODES, plan_lacam  # noqa: E402
from amr_planning.fleet_lattice import lattice  # noqa: E402
from amr_planning.fleet_starts import with_robots  # noqa: E402


def timed(graph, starts, goals, first_budget: int) -> tuple[float, str]:
    began = time.perf_counter()
    try:
        plan = plan_lacam(graph, starts, goals, max_nodes=MAX_NODES, first_budget=first_budget)
        outcome = f"{plan.nodes} configurations"
    except PlanningError as error:
        outcome = f"failed: {error}"
    return time.perf_counter() - began, outcome


def summary(name: str, times: list[float]) -> str:
    values = np.array(times)
    return (
        f"{name}: median {np.median(values):.3f} s, 90th percentile {np.percentile(values, 90):.3f} s, "
        f"slowest {values.max():.2f} s, total {values.sum():.1f} s"
    )


def draw(costmap, graph, data, path: Path, title: str) -> None:
    """The lattice over the map (free space white, the inflated band grey), each robot's start and goal."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 6))
    x0, y0, x1, y1 = costmap.grid.bounds
    ax.imshow(
        costmap.lethal.astype(int) + costmap.inflated.astype(int),
        origin="lower",
        extent=(x0, x1, y0, y1),
        cmap="Greys",
        vmin=0,
        vmax=3,
    )
    for vertex, neighbours in enumerate(graph.neighbours):
        for other in neighbours:
            if other > vertex:
                ax.plot(*zip(graph.points[vertex], graph.points[other], strict=True), "-", color="tab:blue", lw=1)
    ax.plot(graph.points[:, 0], graph.points[:, 1], "o", color="tab:blue", ms=3)
    for index, robot in enumerate(data["robots"]):
        colour = f"C{(index + 1) % 10}"
        ax.plot(*robot["start"][:2], "o", color=colour, ms=9, mfc="none", mew=2)
        ax.plot(*robot["goal"][:2], "x", color=colour, ms=9, mew=2)
        ax.annotate(robot["name"], robot["start"][:2], textcoords="offset points", xytext=(6, 6), color=colour)
    edges = sum(len(n) for n in graph.neighbours) // 2
    ax.set_title(f"{title}: lattice of {len(graph)} points, {edges} edges (o start, x goal)")
    ax.set_aspect("equal")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    print(f"wrote {path}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", default="perfect", help="maze family (amr_maps.maze_families)")
    parser.add_argument("--maze", type=int, default=15, help="seed of the maze (4 m)")
    parser.add_argument("--figure", type=Path, help="draw the lattice, starts and goals to this file")
    parser.add_argument("--robots", type=int, default=6)
    parser.add_argument("--trials", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0, help="seed of the random starts")
    parser.add_argument("--single", action="store_true", help="also one search of up to 200,000 configurations")
    args = parser.parse_args(argv)
    data = with_robots(generate(args.family, args.maze, size=4.0), args.robots, args.maze)
    costmap = Costmap(
        rasterize_world(world_from_dict(data), 0.025), CostmapConfig(robot_radius=0.105, safety_margin=0.02)
    )
    graph = lattice(costmap, lattice_spacing(data, args.family))
    if args.figure:
        draw(costmap, graph, data, args.figure, f"{args.family} {args.maze}")
    goals = [graph.nearest(*robot["goal"][:2]) for robot in data["robots"]]
    rng = np.random.default_rng(args.seed)
    print(
        f"{args.family} {args.maze}: lattice of {len(graph)} vertices, {args.robots} robots, {args.trials} random "
        f"starts (default_rng({args.seed})), load {os.getloadavg()[0]:.1f}"
    )
    restarts, single = [], []
    for trial in range(args.trials):
        starts = [int(v) for v in rng.choice(len(graph), args.robots, replace=False)]
        seconds, outcome = timed(graph, starts, goals, 250)
        restarts.append(seconds)
        line = f"{trial:3d} {starts}: restarts {seconds:7.3f} s ({outcome})"
        if args.single:
            seconds, outcome = timed(graph, starts, goals, MAX_NODES)
            single.append(seconds)
            line += f"; one search {seconds:7.3f} s ({outcome})"
        print(line, flush=True)
    if restarts:
        print(summary("restarts", restarts))
    if single:
        print(summary("one search", single))
    print(f"load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
