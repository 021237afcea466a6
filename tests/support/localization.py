"""Shared by the localization tests: grids from worlds, simulated observations."""

from __future__ import annotations

from pathlib import Path

from amr_simulation.simulator import Simulator

ROOT = Path(__file__).resolve().parents[2]
WORLDS_DIR = ROOT / "config" / "worlds"


def odometry_of(sim: Simulator) -> tuple[float, float, float]:
    return tuple(sim.odom_pose)
