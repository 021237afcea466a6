"""Arms drawn from their own forward kinematics: no URDF meshes, no rclpy, no viser.

The chains come from an IK service's parameters (amr_kinematics.config.load_chain_set, the service's own loader),
the joint values from its `joint_states` (names `<chain>/<joint>`). Each chain stands in a cell of its own along
+x, scaled to a common size (arms from 0.1 m to 1.2 m of reach side by side), its links a polyline through the
joint frame origins and its frames drawn as axes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from amr_kinematics.config import ChainConfig, load_chain_set

CELL = 1.0
"""m between the bases of two arms in the view."""
DRAWN_REACH = 0.4
"""m each arm's reach is scaled to."""
REACH_SAMPLES = 64


def reach_of(config: ChainConfig, seed: int = 0) -> float:
    """The farthest any joint origin or the tool gets from the base over the home pose and seeded random poses
    within the limits (infinite limits read as +-pi)."""
    chain = config.chain
    lower = np.where(np.isfinite(chain.lower), chain.lower, -math.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, math.pi)
    rng = np.random.default_rng(seed)
    samples = [np.asarray(config.home, dtype=float)] + [
        chain.apply_coupling(rng.uniform(lower, upper)) for _ in range(REACH_SAMPLES)
    ]
    base = chain.base[:3, 3]
    reach = max(float(np.linalg.norm(chain.fk(q).origins - base, axis=1).max()) for q in samples)
    return reach if reach > 1e-9 else 1.0


@dataclass
class ArmView:
    """One chain as drawn: where it stands, its scale, its joint values now."""

    name: str
    config: ChainConfig
    origin: np.ndarray
    """(3,) where its base stands in the view"""
    scale: float
    positions: np.ndarray
    version: int = 0

    def points(self) -> np.ndarray:
        """(n + 2, 3) base, joint frame origins and tool point, placed and scaled."""
        return self.origin + self.scale * self.config.chain.fk(self.positions).origins

    def frames(self) -> tuple[np.ndarray, np.ndarray]:
        """(n + 2, 4) wxyz and (n + 2, 3) positions of the base, every joint frame and the tool."""
        result = self.config.chain.fk(self.positions)
        matrices = np.concatenate([result.frames, result.tool[None]], axis=0)
        wxyz = np.array([rotation_wxyz(m[:3, :3]) for m in matrices])
        return wxyz, self.origin + self.scale * matrices[:, :3, 3]


def rotation_wxyz(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """A rotation matrix as a unit quaternion (w, x, y, z), w >= 0."""
    m = np.asarray(rotation, dtype=float)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    w, x, y, z = q
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    sign = 1.0 if w >= 0.0 else -1.0
    return sign * w / norm, sign * x / norm, sign * y / norm, sign * z / norm


class ArmSet:
    """Every chain of one IK service, laid out from `origin` along +x."""

    def __init__(
        self,
        configs: Mapping[str, ChainConfig],
        origin=(0.0, 0.0, 0.0),
        cell: float = CELL,
        drawn_reach: float = DRAWN_REACH,
    ) -> None:
        self.arms: dict[str, ArmView] = {}
        for index, (name, config) in enumerate(configs.items()):
            base = np.array(origin, dtype=float) + np.array([index * cell, 0.0, 0.0])
            self.arms[name] = ArmView(
                name, config, base, drawn_reach / reach_of(config), np.array(config.home, dtype=float)
            )
        self.cell = cell

    @classmethod
    def from_parameters(cls, parameters: Mapping, origin=(0.0, 0.0, 0.0)) -> ArmSet:
        """From an IK service's parameters ({"chains": [...], "arm5.types": [...], ...}); ChainConfigError names
        the chain and key of anything wrong."""
        return cls(load_chain_set(parameters), origin)

    def on_joint_state(self, names: Sequence[str], positions: Sequence[float]) -> set[str]:
        """Take `<chain>/<joint>` values (any subset, any order); returns the chains that changed. Unknown names and
        non-finite values are ignored, and so is a message without one position per name."""
        given: dict[str, dict[str, float]] = {}
        if len(names) != len(positions):
            return set()  # no positions (a JointState of efforts only), or a malformed message
        for name, value in zip(names, positions, strict=True):
            chain, _, joint = name.partition("/")
            if chain in self.arms and joint and math.isfinite(value):
                given.setdefault(chain, {})[joint] = float(value)
        changed = set()
        for chain, values in given.items():
            arm = self.arms[chain]
            new = arm.positions.copy()
            for index, joint in enumerate(arm.config.chain.joint_names):
                if joint in values:
                    new[index] = values[joint]
            if not np.array_equal(new, arm.positions):
                arm.positions = new
                arm.version += 1
                changed.add(chain)
        return changed

    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the cells on the floor."""
        origins = np.array([arm.origin for arm in self.arms.values()]) if self.arms else np.zeros((1, 3))
        half = 0.5 * self.cell
        return (
            float(origins[:, 0].min() - half),
            float(origins[:, 1].min() - half),
            float(origins[:, 0].max() + half),
            float(origins[:, 1].max() + half),
        )
