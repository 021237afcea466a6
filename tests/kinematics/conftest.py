"""Fixtures: the shipped chain set, loaded once."""

from __future__ import annotations

import pytest
import yaml

from amr_kinematics.config import load_chain_set
from kin_helpers import CONFIG


@pytest.fixture(scope="session")
def raw_params() -> dict:
    return yaml.safe_load(CONFIG.read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def chain_set(raw_params):
    return load_chain_set(raw_params)
