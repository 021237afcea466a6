"""Augmented MCL's recovery (Thrun et al., table 8.3; AMCL's recovery_alpha_slow / _fast).

Two running averages of the measurement likelihood,

    w_slow += alpha_slow (w_avg - w_slow),   w_fast += alpha_fast (w_avg - w_fast)   (alpha_slow << alpha_fast)

and at each resampling a share max(0, 1 - w_fast / w_slow) of the particles is
drawn uniformly over free space instead: when the short-term likelihood falls
below the long-term one (the robot was kidnapped, or the filter locked onto
the wrong place), random guesses come in and the right place can be found again.
"""

from __future__ import annotations

import math


class RecoveryRate:
    """Tracks w_slow, w_fast; injection_share() is the fraction of random particles to draw."""

    def __init__(self, alpha_slow: float, alpha_fast: float) -> None:
        if not (0.0 <= alpha_slow <= 1.0 and 0.0 <= alpha_fast <= 1.0):
            raise ValueError(f"recovery alphas must be in [0, 1], got slow={alpha_slow}, fast={alpha_fast}")
        self.alpha_slow = alpha_slow
        self.alpha_fast = alpha_fast
        self.reset()

    def reset(self) -> None:
        self.w_slow = self.w_fast = 0.0

    def update(self, w_avg: float) -> None:
        if not math.isfinite(w_avg) or w_avg < 0.0:
            return
        if self.w_slow == 0.0:  # first measurement: both averages start from it
            self.w_slow = self.w_fast = w_avg
            return
        self.w_slow += self.alpha_slow * (w_avg - self.w_slow)
        self.w_fast += self.alpha_fast * (w_avg - self.w_fast)

    def injection_share(self) -> float:
        if self.w_slow <= 0.0 or self.alpha_slow == 0.0 or self.alpha_fast == 0.0:
            return 0.0
        return max(0.0, 1.0 - self.w_fast / self.w_slow)
