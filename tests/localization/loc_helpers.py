"""Shared by the localization tests: grids from worlds, simulated observations."""

from __future__ import annotations

from pathlib import Path

from amr_util.scan import scan_of  # noqa: F401  (re-exported for the tests)
from amr_maps.rasterize import rasterize_world as grid_of  # noqa: F401  (the shared rasterizer)
from amr_simulation.simulator import Simulator

ROOT = Path(__file__).resolve().parents[2]
WORLDS_DIR = ROOT / "config" / "worlds"


def odometry_of(sim: Simulator) -> tuple[float, float, float]:
    return tuple(sim.odom_pose)
