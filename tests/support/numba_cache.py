"""The suite's numba kernels compiled once before a parallel run's workers start (tests/conftest.py).

Each kernel is `numba.njit(cache=True)`: the first process to call it compiles it (about 30 s of CPU for them all)
and writes the machine code beside its source (`__pycache__`), later processes load it in a fraction of a second.
On a clean clone every process that reaches a kernel before that file exists compiles it again: both pytest-xdist
workers and the node processes of the first stacks, side by side. `python -m support.numba_cache` (from tests/)
calls every kernel once, as the suite's code calls them (the same argument types): the particle filter in its
closed loop (the likelihood field, the place search's scan matcher, the LiDAR's ray casting), a fleet's scan (the
other robots' discs), a log-odds map's update and every IK chain's warm-up. With the cache in place it costs the
imports and the loads, about 2 s of CPU.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def warm() -> None:
    import yaml

    from amr_control.wall_follower_config import read_parameter_file
    from amr_evaluation.closed_loop import run
    from amr_kinematics.config import load_chain_set
    from amr_localization.particle_filter import ParticleFilter
    from amr_localization.particle_filter_config import ParticleFilterConfig
    from amr_maps.rasterize import rasterize_world
    from amr_maps.scan_mapping import LogOddsGrid
    from amr_maps.world import load_world
    from amr_simulation.config import SimulationConfig
    from amr_simulation.fleet import Fleet
    from amr_simulation.simulator import Simulator
    from amr_util.scan import scan_of

    follower = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
    world = load_world(ROOT / "config" / "worlds" / "inner_maze.yaml")
    sim = Simulator(world, SimulationConfig(dt=follower.dt, seed=0))
    pf = ParticleFilter(rasterize_world(world, 0.05), ParticleFilterConfig(seed=0), range_max=sim.lidar.range_max)
    run(sim, pf, follower, 0.3)
    LogOddsGrid(0.05).insert_scan((0.0, 0.0, 0.0), scan_of(sim))
    Fleet(load_world(ROOT / "config" / "worlds" / "fleets" / "crossing.yaml"), SimulationConfig(seed=0))
    chains = yaml.safe_load((ROOT / "config" / "ik_chains.yaml").read_text(encoding="utf-8"))
    for chain in load_chain_set(chains).values():
        chain.warm_up()


def warm_in_a_child(timeout: float = 600.0) -> str:
    """warm() in a process of its own (nothing of it stays in pytest's); the line to print."""
    from amr_util.environment import child_environment

    started = time.monotonic()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "support.numba_cache"],
            cwd=ROOT / "tests",
            env=child_environment(),
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:  # the tests compile what they need themselves, as without this
        return f"numba kernels not compiled ahead: not done in {timeout:g} s"
    if done.returncode != 0:
        return f"numba kernels not compiled ahead: {done.stderr.strip().splitlines()[-1:]}"
    return f"numba kernels compiled or loaded in {time.monotonic() - started:.1f} s"


if __name__ == "__main__":
    warm()
