"""Tiny episodes for the evaluation tests: seconds of simulated time, a fraction of a second each."""

from __future__ import annotations

from amr_evaluation import configs
from amr_evaluation.episode import EpisodeSpec


def tiny_specs(count: int = 4, duration: float = 3.0, controller: str = "wall_follower") -> list[EpisodeSpec]:
    """`count` short wall-follower episodes over generated mazes and seeds (every one a different key)."""
    label, parameters = configs.resolve(controller, "sim" if controller == "wall_follower" else "default")
    families = ("perfect", "bends", "pillars", "open_room")
    return [
        EpisodeSpec(
            controller,
            label,
            parameters,
            {"family": families[i % len(families)], "seed": i, "options": {"hand": "right", "size": 3.0}},
            None,
            seed=i,
            lidar_noise=0.01 * (1 + i % 2),
            encoder_noise=0.02,
            slip=0.05,
            duration=duration,
        )
        for i in range(count)
    ]
