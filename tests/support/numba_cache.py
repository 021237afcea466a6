"""The suite's numba kernels compiled once before a parallel run's workers start (tests/conftest.py).

Each kernel is `numba.njit(cache=True)`: the first process to call it compiles it (about 26 s of CPU for them all)
and writes the machine code beside its source (`__pycache__`), later processes load it in a fraction of a second.
On a clean clone every process that reaches a kernel before that file exists compiles it again: both pytest-xdist
workers and the node processes of the first stacks, side by side. `python -m support.numba_cache [part ...]` (from
tests/) calls every kernel of the parts named (all without one) once, as the suite's code calls them (the same
argument types). Warming compiles them in two processes that share no kernel (PROCESSES), side by side on two cores,
while the workers start and run the tests that call no kernel:

- `loop`: the particle filter in its closed loop (the likelihood field, the place search's scan matcher, the
  LiDAR's ray casting, the wall follower's scan kernels), a fleet's scan (the other robots' discs), a log-odds
  map's update and its thresholds, a costmap's segment check;
- `chains`: every IK chain's warm-up;
- `mapping`: SLAM's (the front end's lines, the submaps' cell means) and a fleet route's thinning.

With the cache in place it costs the imports and the loads, about 2 s of CPU.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def warm_loop() -> None:
    import numpy as np

    from amr_control.wall_follower_config import read_parameter_file
    from amr_evaluation.closed_loop import run
    from amr_localization.particle_filter import ParticleFilter
    from amr_localization.particle_filter_config import ParticleFilterConfig
    from amr_maps.rasterize import rasterize_world
    from amr_maps.scan_mapping import LogOddsGrid
    from amr_maps.world import load_world
    from amr_planning.costmap import Costmap
    from amr_simulation.config import SimulationConfig
    from amr_simulation.fleet import Fleet
    from amr_simulation.simulator import Simulator
    from amr_util.scan import scan_of

    follower = read_parameter_file(ROOT / "config" / "wall_follower_sim.yaml")
    world = load_world(ROOT / "config" / "worlds" / "inner_maze.yaml")
    sim = Simulator(world, SimulationConfig(dt=follower.dt, seed=0))
    pf = ParticleFilter(rasterize_world(world, 0.05), ParticleFilterConfig(seed=0), range_max=sim.lidar.range_max)
    run(sim, pf, follower, 0.3)
    grid = LogOddsGrid(0.05)
    grid.insert_scan((0.0, 0.0, 0.0), scan_of(sim))
    grid.probability_at_least(0.65), grid.probability_at_most(0.2)
    Costmap(rasterize_world(world, 0.05)).segments_free(np.zeros((1, 2)), np.ones((1, 2)))
    Fleet(load_world(ROOT / "config" / "worlds" / "fleets" / "crossing.yaml"), SimulationConfig(seed=0))


def warm_mapping() -> None:
    import numpy as np

    from amr_mapping.slam import GraphSlam, SlamConfig
    from amr_maps.world import load_world
    from amr_navigation.traffic_messages import thin_path
    from amr_simulation.config import SimulationConfig
    from amr_simulation.simulator import Simulator
    from amr_util.scan import scan_of

    sim = Simulator(load_world(ROOT / "config" / "worlds" / "inner_maze.yaml"), SimulationConfig(dt=0.1, seed=0))
    slam = GraphSlam(SlamConfig())
    for k in range(30):  # straight runs and turns in place: nodes, the front end's match and its lines
        sim.step(*((0.2, 0.0) if k % 10 < 6 else (0.0, 1.5)))
        slam.add(k * 100_000_000, sim.odom_pose, scan_of(sim))
    thin_path(np.array([[0.0, 0.0], [1.0, 0.01], [2.0, 0.0], [3.0, 1.0]]))


def warm_chains() -> None:
    import yaml

    from amr_kinematics.config import load_chain_set

    chains = yaml.safe_load((ROOT / "config" / "ik_chains.yaml").read_text(encoding="utf-8"))
    for chain in load_chain_set(chains).values():
        chain.warm_up()


PARTS = {"loop": warm_loop, "chains": warm_chains, "mapping": warm_mapping}
PROCESSES = (("loop", "mapping"), ("chains",))
"""What Warming runs side by side: processes that share no kernel (`mapping` calls the scan matcher `loop` has
compiled in the same process), about 27 and 13 s of CPU on a cold cache."""


def warm(*parts: str) -> None:
    """Every kernel of the parts named (all of them without one) called once."""
    unknown = [part for part in parts if part not in PARTS]
    if unknown:
        raise SystemExit(f"support.numba_cache: unknown part(s) {unknown}, expected some of {list(PARTS)}")
    for part in parts or PARTS:
        PARTS[part]()


class Warming:
    """warm() in processes of their own, one per part, side by side (nothing of them stays in pytest's), started at
    once and not waited for: a parallel run's workers start and collect meanwhile, and the tests that call no kernel
    run (support.schedule.WITHOUT_KERNELS); the others wait for `done` (tests/conftest.py). When both have ended,
    `done` holds the line to print (also when a part failed or took longer than `timeout`: then the tests compile
    what they need themselves, as without the warm-up)."""

    def __init__(self, done: Path, timeout: float = 600.0) -> None:
        from amr_util.environment import child_environment

        self.done, self.started, self.timeout = done, time.monotonic(), timeout
        self.children = {}
        for parts in PROCESSES:
            part = " and ".join(parts)
            errors = tempfile.TemporaryFile(mode="w+")  # a file, not a pipe: a child never waits for its reader
            command = [sys.executable, "-m", "support.numba_cache", *parts]
            child = subprocess.Popen(
                command, cwd=ROOT / "tests", env=child_environment(), stdout=subprocess.DEVNULL, stderr=errors
            )
            self.children[part] = (child, errors)
        self._waiter = threading.Thread(target=self._wait, daemon=True)
        self._waiter.start()

    def _wait(self) -> None:
        failed = []
        for part, (child, errors) in self.children.items():
            try:
                child.wait(timeout=max(0.0, self.started + self.timeout - time.monotonic()))
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
                failed.append(f"{part}: not done in {self.timeout:g} s")
            else:
                if child.returncode != 0:
                    errors.seek(0)
                    failed.append(f"{part}: {errors.read().strip().splitlines()[-1:]}")
            errors.close()
        seconds = time.monotonic() - self.started
        if failed:
            line = f"numba kernels not compiled ahead: {'; '.join(failed)}"
        else:
            line = f"numba kernels compiled or loaded in {seconds:.1f} s ({' beside '.join(self.children)})"
        partial = self.done.with_name(self.done.name + ".part")
        partial.write_text(line + "\n", encoding="utf-8")
        partial.replace(self.done)  # whole or absent: a reader never sees half a line

    def stop(self) -> None:
        """The parts still running killed (a run interrupted before they ended)."""
        for child, _ in self.children.values():
            if child.poll() is None:
                child.kill()

    def line(self, timeout: float | None = None) -> str:
        """The line to print, once the parts have ended (waiting up to `timeout` s for them)."""
        self._waiter.join(timeout)
        return self.done.read_text(encoding="utf-8").strip() if self.done.is_file() else "numba warm-up still running"


def wait_for(done: Path, timeout: float = 600.0) -> float:
    """Until the warm-up whose marker is `done` has ended (or `timeout` s): the seconds waited."""
    began = time.monotonic()
    while not done.is_file() and time.monotonic() - began < timeout:
        time.sleep(0.1)
    return time.monotonic() - began


if __name__ == "__main__":
    warm(*sys.argv[1:])
