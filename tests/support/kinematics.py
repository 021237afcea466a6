"""Helpers and fixtures shared by the kinematics tests (the fixtures reach them through conftest.pytest_plugins)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from amr_kinematics.chain import Chain, Coupling
from amr_kinematics.config import load_chain_set

CONFIG = Path(__file__).resolve().parents[2] / "config" / "ik_chains.yaml"
UNSEEN = Path(__file__).resolve().parents[2] / "bench" / "ik_unseen_chains.yaml"  # arms nothing was tuned on


@pytest.fixture(scope="session")
def raw_params() -> dict:
    return yaml.safe_load(CONFIG.read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def chain_set(raw_params):
    return load_chain_set(raw_params)


@pytest.fixture(scope="session")
def unseen_set():
    return load_chain_set(yaml.safe_load(UNSEEN.read_text(encoding="utf-8")))


def random_targets(chain: Chain, count: int, seed: int) -> list[np.ndarray]:
    """Tool poses of uniformly random in-limit configurations (reachable by construction)."""
    rng = np.random.default_rng(seed)
    return [chain.fk(rng.uniform(chain.lower, chain.upper)).tool for _ in range(count)]


def seed004_arm(scale: float = 0.01) -> Chain:
    """Seed 004's arm with 5 (cm) links times ``scale``: 0.01 gives metres, 1.0 centimetres."""
    link = 5.0 * scale
    return Chain(
        "arm5",
        "standard_dh",
        ["q1", "q2", "q3", "q4", "q5"],
        ["revolute"] * 5,
        d=[link, 0, 0, 0, 0],
        theta=[0] * 5,
        a=[0, link, link, link, link],
        alpha=[math.pi / 2, 0, 0, 0, 0],
        lower=[-math.pi] * 5,
        upper=[math.pi] * 5,
        couplings=[Coupling(4, -math.pi / 2, np.array([0.0, -1.0, -1.0, -1.0, 0.0]))],
    )


def prismatic_modified_chain() -> Chain:
    """A modified-DH chain mixing prismatic and revolute joints, with base and tool."""
    from amr_kinematics.transforms import xyz_rpy_matrix

    return Chain(
        "mixed_mdh",
        "modified_dh",
        ["j1", "j2", "j3", "j4"],
        ["revolute", "prismatic", "revolute", "prismatic"],
        d=[0.2, 0.1, 0.0, 0.05],
        theta=[0.0, 0.3, -0.2, 0.0],
        a=[0.0, 0.15, 0.1, 0.0],
        alpha=[0.0, -math.pi / 2, math.pi / 2, 0.4],
        lower=[-3.0, 0.0, -3.0, -0.1],
        upper=[3.0, 0.4, 3.0, 0.2],
        base=xyz_rpy_matrix([0.1, -0.2, 0.3, 0.2, -0.1, 0.5]),
        tool=xyz_rpy_matrix([0.0, 0.02, 0.05, 0.3, 0.0, -0.2]),
    )
