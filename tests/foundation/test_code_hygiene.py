"""The code states behaviour and invariants, not where they came from: no module cites this project's tracker by
issue number (an upstream project's issue, named with the project, is a reference and stays)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PLACES = sorted(p.parent for p in ROOT.glob("amr_*/__init__.py")) + [ROOT / "scripts", ROOT / "bench", ROOT / "tests"]
TRACKER = re.compile(r"(?<![\w-])issues? #?\d+", re.IGNORECASE)
UPSTREAM = re.compile(r"\b(?:rclpy|rclcpp|numba|numpy|scipy|viser|colcon|launch_ros|gtsam|pymunk)\s*$", re.IGNORECASE)


def tracker_citations(text: str) -> list[str]:
    """The lines of `text` citing an issue by number that no upstream project's name precedes (on the line or the
    one before: a citation may wrap)."""
    lines = text.splitlines()
    found = []
    for number, line in enumerate(lines):
        for match in TRACKER.finditer(line):
            before = line[: match.start()] or (lines[number - 1] if number else "")
            if not UPSTREAM.search(before.rstrip(" (")):
                found.append(f"{number + 1}: {line.strip()}")
    return found


def test_the_check_finds_a_tracker_citation_and_passes_an_upstream_one():
    assert tracker_citations("a rule (issue 36: the fleet) here") == ["1: a rule (issue 36: the fleet) here"]
    assert tracker_citations("see issues 13, 19") == ["1: see issues 13, 19"]
    assert tracker_citations("raises inside (rclpy issue 1209), which") == []
    assert tracker_citations("the state does not have (rclpy\nissue 1209), which") == []
    assert tracker_citations("no-issue 3 here, tissue 4") == []


@pytest.mark.parametrize("place", PLACES, ids=lambda p: p.name)
def test_no_module_cites_the_tracker(place):
    cited = {
        str(path.relative_to(ROOT)): lines
        for path in sorted(place.rglob("*.py"))
        if path.name != Path(__file__).name and (lines := tracker_citations(path.read_text()))
    }
    assert not cited, f"tracker issue numbers (say what the code does instead): {cited}"
