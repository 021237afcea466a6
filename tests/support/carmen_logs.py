"""Small CARMEN logs written by the tests, and where the shipped real-robot logs are."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
SHARED_CANDIDATES = (Path("/work/shared/data/carmen"), ROOT.parent / "shared" / "data" / "carmen")
SHARED = next((path for path in SHARED_CANDIDATES if path.is_dir()), None)
"""The real logs (intel, aces, fhw, orebro), or None where this machine has no copy."""
MAX_RANGE = 81.83


def square_path(count: int, step: float = 0.5) -> np.ndarray:
    """(count, 3) poses around a 4 m square, `step` apart, heading along the path, turning at the corners."""
    poses, x, y, theta = [], 0.0, 0.0, 0.0
    for i in range(count):
        poses.append((x, y, theta))
        x, y = x + step * math.cos(theta), y + step * math.sin(theta)
        if (i + 1) % 8 == 0:
            theta = (theta + math.pi / 2 + math.pi) % (2 * math.pi) - math.pi
    return np.array(poses)


def ranges_of(i: int, beams: int) -> list[float]:
    """Readings of scan i: varied, with a run of max-range (no return) readings."""
    values = [round(1.0 + 0.01 * ((i * 7 + k * 3) % 300), 2) for k in range(beams)]
    for k in range(i % 5, beams, 9):
        values[k] = MAX_RANGE
    return values


def flaser_line(ranges, pose, stamp: float | None, odom=None) -> str:
    x, y, theta = pose
    odom = pose if odom is None else odom
    tail = "" if stamp is None else f" {stamp:.6f} testhost {stamp:.6f}"
    return (
        f"FLASER {len(ranges)} "
        + " ".join(f"{r:g}" for r in ranges)
        + f" {x:.6f} {y:.6f} {theta:.6f} {odom[0]:.6f} {odom[1]:.6f} {odom[2]:.6f}"
        + tail
    )


def write_log(
    path: Path,
    count: int = 20,
    beams: int = 181,
    stamps: bool = True,
    period: float = 0.2,
    extra: tuple[str, ...] = (),
    gzipped: bool = False,
) -> np.ndarray:
    """A log of `count` FLASER scans on square_path with ODOM/NEFF/PARAM lines, comments and blank lines between;
    returns the poses."""
    poses = square_path(count)
    lines = [
        "# message formats defined: PARAM SYNC ODOM FLASER RLASER TRUEPOS",
        "# a comment",
        "PARAM robot_frontlaser_offset 0.0 nohost 0",
        "",
    ]
    for i, pose in enumerate(poses):
        stamp = 10.0 + period * i if stamps else None
        lines.append(f"ODOM {pose[0]:.6f} {pose[1]:.6f} {pose[2]:.6f} 0 0 0 {10.0 + period * i:.6f} pippo 0")
        lines.append(flaser_line(ranges_of(i, beams), pose, stamp))
        lines.append("NEFF 30")
        if i % 4 == 0:
            lines.append("")
    lines += list(extra)
    text = "\n".join(lines) + "\n"
    if gzipped:
        with gzip.open(path, "wt", encoding="utf-8") as out:
            out.write(text)
    else:
        path.write_text(text, encoding="utf-8")
    return poses
