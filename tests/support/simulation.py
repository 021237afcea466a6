"""Shared helpers for the simulator library tests."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig

WORLDS = Path(__file__).resolve().parents[2] / "config" / "worlds"
TWO_IN_THE_PILLAR_ROOM = """\
name: two_in_the_pillar_room
wall_thickness: 0.05
walls:
  - [-2.0, -1.5, 2.0, -1.5]
  - [2.0, -1.5, 2.0, 1.5]
  - [2.0, 1.5, -1.0, 1.5]
  - [-1.0, 1.5, -1.0, 1.0]
  - [-1.0, 1.0, -2.0, 1.0]
  - [-2.0, 1.0, -2.0, -1.5]
boxes:
  - [-0.15, -0.15, 0.15, 0.15]
  - [0.8, 0.5, 1.4, 0.9]
robots:
  - name: r1
    start: [-1.5, -1.0, 0.0]
    goal: [0.0, -0.45, 0.15]
  - name: r2
    start: [1.6, -0.2, 3.14159265358979]
    goal: [-0.5, 0.45, 0.15]
"""
"""A fleet world file: two robots in a room with a pillar and a box, each with a goal (the fleet stacks' tests)."""


def make_config(
    lidar: dict[str, Any] | None = None, encoders: dict[str, Any] | None = None, **top: Any
) -> SimulationConfig:
    """Defaults with some fields replaced; lidar and encoder noise off unless given."""
    lidar_config = dataclasses.replace(LidarConfig(), **{"noise_std": 0.0, **(lidar or {})})
    encoder_config = dataclasses.replace(EncoderConfig(), **(encoders or {}))
    return dataclasses.replace(SimulationConfig(), lidar=lidar_config, encoders=encoder_config, **top)
