"""Wheel encoders and wheel slip.

The motors hold the commanded wheel speeds, so the encoders count the commanded
rotation (plus noise) whatever the body does: when the robot is held by a wall,
or loses ground to slip, the wheels still turn and the encoder odometry drifts
away from the truth, as on a real robot.
"""

from __future__ import annotations

import numpy as np

from amr_simulation.config import EncoderConfig


class Encoders:
    """Per-step wheel angle increments (rad) and the ground speed slip leaves."""

    def __init__(self, config: EncoderConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng

    def ground_speeds(self, left: float, right: float) -> tuple[float, float]:
        """Wheel speeds as the floor sees them: each loses a fraction |N(0, slip)| <= 1."""
        if self.config.slip == 0.0:
            return left, right
        lost = np.minimum(np.abs(self._rng.normal(0.0, self.config.slip, 2)), 1.0)
        return left * (1.0 - lost[0]), right * (1.0 - lost[1])

    def increments(self, left: float, right: float, dt: float) -> tuple[float, float]:
        """Measured rotation over dt of wheels turning at (left, right) rad/s."""
        d_left, d_right = left * dt, right * dt
        if self.config.noise == 0.0:
            return d_left, d_right
        relative = self._rng.normal(0.0, self.config.noise, 2)
        return d_left * (1.0 + relative[0]), d_right * (1.0 + relative[1])
