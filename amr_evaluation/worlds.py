"""The world of an episode, as data: a shipped or user world file, or a maze family and seed.

A world spec is a small JSON-able dict:

- ``{"file": "hard_maze.yaml"}``: a shipped world (share/amr_simulation/config/worlds), by name;
- ``{"data": {...}, "name": "lab"}``: a world's YAML content itself (a user's file is read into this when
  the sweep is built, so a worker on another machine needs no copy of it);
- ``{"family": "perfect", "seed": 3, "options": {"width": 0.45, "hand": "right"}}``: a generated maze
  (amr_maps.maze_families.generate: the same family, seed and options give the same world).

A goal spec replaces the world's goal: None keeps it, ``[x, y, radius]`` sets one, ``"far"`` the free cell
farthest from the start and ``"random"`` a random free cell over 1 m from it (drawn from the episode's
seed), both in the start's connected free space on the planner's costmap, with a 0.1 m radius.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from amr_evaluation.cases import far_free_point
from amr_maps.maze_families import generate
from amr_maps.rasterize import rasterize_world
from amr_maps.world import Goal, World, load_world, resolve_world_path, world_from_dict
from amr_planning.costmap import Costmap

GOAL_RADIUS = 0.1
"""m, the radius of a "far" or "random" goal."""
GOAL_RESOLUTION = 0.025
"""m/cell of the costmap far and random goals are drawn on (the planner's resolution)."""


class WorldSpecError(ValueError):
    """A world or goal spec that names nothing usable (the message says which key)."""


def world_spec_of_file(path_or_name: str) -> dict[str, Any]:
    """The spec of a world file: a shipped name stays a name; another file is read into the spec.

    A file naming a map_server map (``map: lab.yaml``) stays a path (the map is read where the episode runs).
    """
    path = Path(path_or_name)
    if not path.is_file() and not path.suffix:
        path_or_name += ".yaml"  # a shipped world by its name: hard_maze
        path = Path(path_or_name)
    if not path.is_file():
        try:
            resolve_world_path(path_or_name)
        except Exception as error:
            raise WorldSpecError(f"world {path_or_name!r}: {error}") from error
        return {"file": path_or_name}
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as error:
        raise WorldSpecError(f"{path}: cannot read world file ({error})") from error
    if not isinstance(data, dict):
        raise WorldSpecError(f"{path}: a world file is a mapping (walls, boxes or grid; start; goal)")
    if "map" in data:
        return {"file": str(path.resolve())}
    try:  # refuse a bad file now, naming it, rather than in every episode
        world_from_dict(data, source=str(path), default_name=path.stem)
    except ValueError as error:
        raise WorldSpecError(str(error)) from error
    return {"data": data, "name": path.stem}


def world_label(spec: dict[str, Any]) -> str:
    if "family" in spec:
        return f"{spec['family']}_{spec['seed']}"
    if "file" in spec:
        return Path(spec["file"]).stem
    return str(spec.get("name") or spec["data"].get("name", "world"))


def world_family(spec: dict[str, Any]) -> str:
    """The family of a generated world, else the world's own name (a family of one)."""
    return spec["family"] if "family" in spec else world_label(spec)


def world_dict(spec: dict[str, Any]) -> dict[str, Any] | None:
    """The world as a dict (generated or inline), or None for a file."""
    if "family" in spec:
        options = json.dumps(spec.get("options") or {}, sort_keys=True)
        return copy.deepcopy(_generated(spec["family"], int(spec["seed"]), options))
    if "data" in spec:
        return dict(spec["data"])
    return None


def forget_generated_worlds() -> None:
    """Empty this process's cache of generated mazes (benchmarks timing a sweep from cold)."""
    _generated.cache_clear()


@functools.lru_cache(maxsize=32)
def _generated(family: str, seed: int, options: str) -> dict[str, Any]:
    """A generated maze, once per process: a sweep runs each world under several configurations and noise
    levels, and drawing one (goal placement included) costs 0.1-0.3 s."""
    return generate(family, seed, **json.loads(options))


def build_world(spec: dict[str, Any]) -> World:
    if not isinstance(spec, dict) or not ({"family", "data", "file"} & set(spec)):
        raise WorldSpecError(f"world spec {spec!r}: needs 'file', 'data' or 'family'")
    data = world_dict(spec)
    if data is not None:
        return world_from_dict(data, default_name=world_label(spec))
    return load_world(resolve_world_path(spec["file"]))


def world_hand(spec: dict[str, Any]) -> str | None:
    """The wall-following hand a generated world's goal was placed for (None: not a generated world)."""
    return (spec.get("options") or {}).get("hand", "right") if "family" in spec else None


def with_goal(world: World, goal: Any, seed: int, costmap: Costmap | None = None) -> World:
    """``world`` with the goal of a goal spec (see the module docstring)."""
    if goal is None:
        return world
    if isinstance(goal, str):
        if goal not in ("far", "random"):
            raise WorldSpecError(f"goal {goal!r}: expected 'far', 'random', [x, y, radius] or null")
        costmap = costmap or Costmap(rasterize_world(world, GOAL_RESOLUTION))
        rng = np.random.default_rng(seed) if goal == "random" else None
        x, y = (float(v) for v in far_free_point(costmap, (world.start.x, world.start.y), rng))
        return dataclasses.replace(world, goal=Goal(x, y, GOAL_RADIUS))
    try:
        x, y, radius = (float(v) for v in goal)
    except (TypeError, ValueError) as error:
        raise WorldSpecError(f"goal {goal!r}: expected [x, y, radius]") from error
    if not (math.isfinite(x) and math.isfinite(y) and radius > 0):
        raise WorldSpecError(f"goal {goal!r}: x, y must be finite and the radius positive")
    return dataclasses.replace(world, goal=Goal(x, y, radius))
