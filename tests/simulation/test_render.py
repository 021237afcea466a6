"""Rendering: every shipped world renders to a PNG; the drawing functions compose on any Axes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from support.simulation import WORLDS, make_config

from amr_maps.world import load_world
from amr_simulation.render import draw_simulation
from amr_simulation.simulator import Simulator

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name", sorted(p.name for p in WORLDS.glob("*.yaml")))
def test_each_shipped_world_renders_to_png(name: str, tmp_path: Path) -> None:
    sim = Simulator(load_world(WORLDS / name), make_config(lidar={"noise_std": 0.01}))
    for _ in range(20):
        sim.step(0.1, 0.2)
    path = sim.render(tmp_path / f"{Path(name).stem}.png", dpi=40)
    assert path.read_bytes()[:8] == PNG_SIGNATURE


def test_draw_composes_on_a_given_axes() -> None:
    sim = Simulator(load_world(WORLDS / "open_room.yaml"), make_config())
    for _ in range(10):
        sim.step(0.2, 0.0)
    sim.set_pose(0.5, -1.0, 0.0)
    sim.step(0.2, 0.0)
    figure = Figure()
    FigureCanvasAgg(figure)
    left, right = figure.subplots(1, 2)
    lines = draw_simulation(right, sim)
    assert not left.patches  # only the given Axes is drawn on
    assert len(right.patches) >= len(sim.world.polygons) + 2  # solids, start arrow, goal, robot
    segments = lines.get_segments()
    assert len(segments) == len(sim.trajectory) - 1
    # steps are 1 cm long; no segment spans the 0.9 m set_pose jump
    assert max(np.ptp(s[:, 0]) for s in segments) < 0.02
    hits = right.collections[-1].get_offsets()
    assert len(hits) == np.isfinite(sim.ranges).sum()
