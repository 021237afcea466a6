"""Shared helpers for the simulator library tests."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from amr_simulation.config import EncoderConfig, LidarConfig, SimulationConfig

WORLDS = Path(__file__).resolve().parents[2] / "config" / "worlds"


def make_config(
    lidar: dict[str, Any] | None = None, encoders: dict[str, Any] | None = None, **top: Any
) -> SimulationConfig:
    """Defaults with some fields replaced; lidar and encoder noise off unless given."""
    lidar_config = dataclasses.replace(LidarConfig(), **{"noise_std": 0.0, **(lidar or {})})
    encoder_config = dataclasses.replace(EncoderConfig(), **(encoders or {}))
    return dataclasses.replace(SimulationConfig(), lidar=lidar_config, encoders=encoder_config, **top)
