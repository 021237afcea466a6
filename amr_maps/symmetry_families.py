"""Generated square rooms whose four-fold symmetry one feature breaks, and truly symmetric controls.

``symmetry_case(kind, seed, **options)`` returns a :class:`SymmetryCase`: a world dict that
:func:`amr_maps.world.world_from_dict` accepts, and its symmetric counterpart (the same
world without what breaks the symmetry), from which a benchmark tells when the breaking feature
is in the LiDAR's view (:func:`feature_in_view`: beams whose ranges differ between the two). The
same kind, seed and options always give the same case; every value an option does not fix is
drawn from ``numpy.random.default_rng``.

Broken kinds (``BROKEN``), each a square room of side ``size`` (3.5-6.5 m) around the origin:

* ``doorway``: a square enclosure (walls) in the middle with one doorway of ``feature``
  (0.2-0.6 m) in one of its sides, anywhere along it;
* ``notch``: a square island in the middle and one notch ``feature`` wide and ``depth`` deep
  (0.2-0.6 m each) in one outer wall;
* ``missing_pillar``: a k x k grid of square pillars (k = 2 or 3, side 0.2-0.6 m) with one missing
  (never the centre one of a 3 x 3 grid: that keeps the symmetry);
* ``extra_pillar``: a square island in the middle plus one box of ``feature`` (0.2-0.6 m) against
  an outer wall or against the island.

Symmetric kinds (``SYMMETRIC``), unchanged by a quarter turn about the origin (their counterpart is
themselves): ``ring`` (a square corridor loop 0.6-1.0 m wide), ``island`` (a square room with a
centred square island), ``pillar_grid`` (the full k x k grid).

Every coordinate lies on a 2 cm lattice (wall thicknesses on 4 cm) so that a map rasterized at 2 cm
(amr_maps.rasterize aligns its grid on the lower-left corner) is exactly as symmetric as the world:
a symmetric world's map turned by a quarter turn is the same map. ``lattice=False`` draws them off
it: the world stays as symmetric, its map at 2 cm not quite (walls a cell apart in places). The
start is by the outer wall, heading along it with the wall on the right (a right-hand wall follower
goes round the room).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from amr_maps.world import World, world_from_dict

BROKEN = ("doorway", "notch", "missing_pillar", "extra_pillar")
SYMMETRIC = ("ring", "island", "pillar_grid")
KINDS = BROKEN + SYMMETRIC
LATTICE = 0.02
"""m: every coordinate is a multiple of this (thicknesses of twice this)."""
_OPTIONS = {
    "doorway": ("size", "feature", "thickness"),
    "notch": ("size", "feature", "depth", "thickness"),
    "missing_pillar": ("size", "feature", "thickness"),
    "extra_pillar": ("size", "feature", "thickness"),
    "ring": ("size", "width", "thickness"),
    "island": ("size", "thickness"),
    "pillar_grid": ("size", "feature", "thickness"),
}
START_CLEARANCE = 0.2
"""m from the start to every solid at least (about twice the robot description's radius)."""


class SymmetryFamilyError(ValueError):
    """A bad kind or option."""


@dataclass(frozen=True)
class SymmetryCase:
    kind: str
    world: dict
    """the world dict (world_from_dict)."""
    symmetric: dict
    """the same room without the feature that breaks the symmetry (the world itself for a symmetric kind)."""

    @property
    def breaks_symmetry(self) -> bool:
        return self.kind in BROKEN


def symmetry_case(kind: str, seed: int, **options: Any) -> SymmetryCase:
    """A case of ``kind`` drawn from ``seed``; options: see _OPTIONS and the module docstring."""
    if kind not in KINDS:
        raise SymmetryFamilyError(f"unknown symmetry family {kind!r} (known: {', '.join(KINDS)})")
    unknown = sorted(set(options) - set(_OPTIONS[kind]) - {"lattice"})
    if unknown:
        raise SymmetryFamilyError(f"{kind}: unknown option {unknown[0]!r} (known: {', '.join(_OPTIONS[kind])})")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise SymmetryFamilyError(f"seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng([int(seed), 20, KINDS.index(kind)])
    draw = _Draw(kind, rng, options)
    size = draw.even(draw.length("size", 3.5, 6.5, 2.0, 20.0))
    thickness = draw.thickness()
    world, symmetric = _BUILDERS[kind](draw, size, thickness)
    name = f"{kind}_{seed}"
    world = dict(world, name=name, wall_thickness=thickness)
    start = _start(rng, world, size, thickness)
    world = dict(world, start=start)
    if kind in SYMMETRIC:
        return SymmetryCase(kind, world, world)
    return SymmetryCase(kind, world, dict(symmetric, name=f"{name}_symmetric", wall_thickness=thickness, start=start))


def feature_in_view(world: World, symmetric: World) -> FeatureView:
    """A FeatureView for the pair (built worlds of a SymmetryCase)."""
    return FeatureView(world, symmetric)


class FeatureView:
    """Which beams of a scan see what breaks the symmetry: their noise-free ranges differ by more than
    `tolerance` between the world and its symmetric counterpart at the same sensor pose (differing_beams);
    and which beams tell the pose from its quarter turns about the origin, in the world itself
    (told_apart: the feature seen, or a wall seen where a turned copy would see the feature)."""

    def __init__(self, world: World, symmetric: World, tolerance: float = 0.05) -> None:
        from amr_maps.raycast import NumpyRayCaster  # here: only the benchmarks and tests need it

        self._casters = NumpyRayCaster(world.faces), NumpyRayCaster(symmetric.faces)
        self.tolerance = tolerance

    def differing_beams(self, x: float, y: float, phi0: float, increment: float, count: int, range_max: float) -> int:
        """Beams from sensor pose (x, y), first beam at phi0, whose ranges (clipped at range_max) differ."""
        ranges = [
            np.minimum(caster.cast(x, y, phi0, increment, count, range_max), range_max) for caster in self._casters
        ]
        return int(np.count_nonzero(np.abs(ranges[0] - ranges[1]) > self.tolerance))

    def told_apart(self, x: float, y: float, phi0: float, increment: float, count: int, range_max: float) -> list[int]:
        """For each quarter turn k = 1, 2, 3: beams whose ranges in the world differ between sensor pose
        (x, y, phi0) and that pose turned by k x 90 deg about the origin."""
        caster = self._casters[0]
        here = np.minimum(caster.cast(x, y, phi0, increment, count, range_max), range_max)
        out = []
        for k in (1, 2, 3):
            c, s = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
            turned = np.minimum(
                caster.cast(c * x - s * y, s * x + c * y, phi0 + k * math.pi / 2, increment, count, range_max),
                range_max,
            )
            out.append(int(np.count_nonzero(np.abs(turned - here) > self.tolerance)))
        return out


# -- drawing ---------------------------------------------------------------------------------


class _Draw:
    def __init__(self, kind: str, rng: np.random.Generator, options: dict) -> None:
        self.kind, self.rng, self.options = kind, rng, options
        self.lattice = options.get("lattice", True)
        if not isinstance(self.lattice, bool):
            raise SymmetryFamilyError(f"{kind}: lattice must be true or false, got {self.lattice!r}")

    def length(self, name: str, low: float, high: float, lowest: float, highest: float) -> float:
        """The option `name` (checked within [lowest, highest]) or a draw in [low, high]; on the lattice."""
        value = self.options.get(name)
        if value is None:
            value = float(self.rng.uniform(low, high))
        elif not (isinstance(value, (int, float)) and not isinstance(value, bool) and lowest <= value <= highest):
            raise SymmetryFamilyError(f"{self.kind}: {name} must be a number in [{lowest}, {highest}] m, got {value!r}")
        return self.lat(value)

    def thickness(self) -> float:
        return max(2 * LATTICE, self.even(self.length("thickness", 0.02, 0.08, 0.02, 0.3)))

    def lat(self, value: float) -> float:
        """On the lattice (unless the case was asked off it)."""
        return round(round(float(value) / LATTICE) * LATTICE, 5) if self.lattice else float(value)

    def even(self, value: float) -> float:
        """On twice the lattice: its half is on the lattice (sizes centred on the origin)."""
        return round(round(float(value) / (2 * LATTICE)) * 2 * LATTICE, 5) if self.lattice else float(value)


def _square(half: float) -> list[list[float]]:
    corners = [(-half, -half), (half, -half), (half, half), (-half, half)]
    return [[*a, *b] for a, b in zip(corners, corners[1:] + corners[:1], strict=True)]


def _doorway(draw: _Draw, size: float, thickness: float):
    half = draw.lat(draw.rng.uniform(0.15, 0.25) * size)  # enclosure side 0.3-0.5 of the room's
    door = min(draw.length("feature", 0.2, 0.6, 0.1, 1.0), 2 * half - 4 * thickness - 0.1)
    low = draw.lat(draw.rng.uniform(-half + thickness + 0.02, half - thickness - 0.02 - door))
    enclosure = _square(half)
    side = int(draw.rng.integers(4))
    a, b = np.array(enclosure[side][:2]), np.array(enclosure[side][2:])
    along = (b - a) / np.linalg.norm(b - a)
    gap0, gap1 = a + along * (half + low), a + along * (half + low + door)  # the door's ends, measured from a
    broken = [w for k, w in enumerate(enclosure) if k != side]
    broken += [[*a, *gap0], [*gap1, *b]]
    outer = _square(size / 2)
    return ({"walls": _rounded(outer + broken)}, {"walls": _rounded(outer + enclosure)})


def _notch(draw: _Draw, size: float, thickness: float):
    half = draw.lat(draw.rng.uniform(0.15, 0.25) * size)
    width = draw.length("feature", 0.2, 0.6, 0.1, 1.0)
    depth = draw.length("depth", 0.2, 0.6, 0.1, 1.0)
    s = size / 2
    x0 = draw.lat(draw.rng.uniform(-s + 0.3, s - 0.3 - width - thickness))  # the notch's left wall's centre line
    x1 = draw.lat(x0 + width + thickness)
    bottom = [
        [-s, -s, x0, -s],
        [x0, -s, x0, -s - depth],
        [x0, -s - depth, x1, -s - depth],
        [x1, -s - depth, x1, -s],
        [x1, -s, s, -s],
    ]
    outer = _square(s)
    island = [[-half, -half, half, half]]
    broken = _turned({"walls": _rounded(bottom + outer[1:]), "boxes": island}, int(draw.rng.integers(4)))
    return broken, {"walls": _rounded(outer), "boxes": island}


def _pillar_grid(draw: _Draw, size: float):
    count = int(draw.rng.integers(2, 4))
    spacing = size / (count + 1)
    side = max(2 * LATTICE, draw.even(draw.length("feature", 0.2, max(0.2, min(0.6, spacing - 0.6)), 0.1, 1.0)))
    centres = [(i - (count - 1) / 2) * spacing for i in range(count)]
    pillars = [
        [draw.lat(x) - side / 2, draw.lat(y) - side / 2, draw.lat(x) + side / 2, draw.lat(y) + side / 2]
        for y in centres
        for x in centres
    ]
    return count, _rounded(pillars)


def _missing_pillar(draw: _Draw, size: float, thickness: float):
    count, pillars = _pillar_grid(draw, size)
    candidates = [k for k in range(len(pillars)) if not (count == 3 and k == 4)]
    missing = candidates[int(draw.rng.integers(len(candidates)))]
    outer = _rounded(_square(size / 2))
    return (
        {"walls": outer, "boxes": [p for k, p in enumerate(pillars) if k != missing]},
        {"walls": outer, "boxes": pillars},
    )


def _extra_pillar(draw: _Draw, size: float, thickness: float):
    half = draw.lat(draw.rng.uniform(0.15, 0.25) * size)
    side = draw.length("feature", 0.2, 0.6, 0.1, 1.0)
    s = size / 2
    if draw.rng.random() < 0.5:  # against the outer wall (the bottom one, then turned)
        x = draw.lat(draw.rng.uniform(-s + 0.4, s - 0.4 - side))
        box = [x, -s, x + side, -s + thickness / 2 + side]
    else:  # against the island
        x = draw.lat(draw.rng.uniform(-half, half - side))
        box = [x, -half - side, x + side, -half]
    island = [[-half, -half, half, half]]
    outer = _rounded(_square(s))
    broken = _turned({"walls": outer, "boxes": _rounded(island + [box])}, int(draw.rng.integers(4)))
    return broken, {"walls": outer, "boxes": island}


def _ring(draw: _Draw, size: float, thickness: float):
    width = draw.length("width", 0.6, 1.0, 0.4, size / 2 - 0.2)
    half = draw.lat(size / 2 - width)
    world = {"walls": _rounded(_square(size / 2)), "boxes": [[-half, -half, half, half]]}
    return world, world


def _island(draw: _Draw, size: float, thickness: float):
    half = draw.lat(draw.rng.uniform(0.1, 0.25) * size)
    world = {"walls": _rounded(_square(size / 2)), "boxes": [[-half, -half, half, half]]}
    return world, world


def _full_grid(draw: _Draw, size: float, thickness: float):
    _, pillars = _pillar_grid(draw, size)
    world = {"walls": _rounded(_square(size / 2)), "boxes": pillars}
    return world, world


_BUILDERS = {
    "doorway": _doorway,
    "notch": _notch,
    "missing_pillar": _missing_pillar,
    "extra_pillar": _extra_pillar,
    "ring": _ring,
    "island": _island,
    "pillar_grid": _full_grid,
}


def _turned(world: dict, quarter_turns: int) -> dict:
    """The world turned by quarter_turns x 90 deg about the origin (exact on the lattice)."""

    def turn(x: float, y: float) -> tuple[float, float]:
        for _ in range(quarter_turns % 4):
            x, y = -y, x
        return x, y

    out = dict(world)
    out["walls"] = [[*turn(*w[:2]), *turn(*w[2:])] for w in world.get("walls", [])]
    boxes = []
    for x0, y0, x1, y1 in world.get("boxes", []):
        (ax, ay), (bx, by) = turn(x0, y0), turn(x1, y1)
        boxes.append([min(ax, bx), min(ay, by), max(ax, bx), max(ay, by)])
    out["boxes"] = boxes
    return out


def _rounded(items: list[list[float]]) -> list[list[float]]:
    return [[round(float(v), 5) for v in item] for item in items]


def _start(rng: np.random.Generator, world: dict, size: float, thickness: float) -> list[float]:
    """By an outer wall (0.3-0.45 m from its inner face), heading along it with the wall on the right."""
    solids = world_from_dict(dict(world, start=[0.0, 0.0, 0.0]))
    for _ in range(200):
        along = float(rng.uniform(-0.3, 0.3)) * size
        offset = size / 2 - thickness / 2 - float(rng.uniform(0.3, 0.45))
        quarter = int(rng.integers(4))
        x, y, theta = along, -offset, 0.0  # by the bottom wall heading +x: the wall on the right
        for _ in range(quarter):
            x, y, theta = -y, x, theta + math.pi / 2
        theta = math.atan2(math.sin(theta), math.cos(theta)) + float(rng.uniform(-0.3, 0.3))
        if float(solids.clearance(np.array([[x, y]]))[0]) >= START_CLEARANCE:
            return [round(x, 5), round(y, 5), round(theta, 5)]
    raise SymmetryFamilyError("no free start by the outer wall in 200 draws")
