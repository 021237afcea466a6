"""The fleet file: a fleet world's roster and priorities, as the fleet planner reads them (no ROS).

A fleet world (config/worlds/fleets/*.yaml, docs/fleet.md) lists its robots under `robots`; each entry may carry a
`priority` (an integer, 0 first): who keeps its route and who is planned again first when the fleet is planned
again in part (amr_navigation.fleet_coordinator). Without the key a robot's priority is its place in the list.
The world's own keys are checked by amr_maps.world.load_world; the priorities here, each problem reported as
`<file>: <key>: <problem>` naming the value (`FleetFileError`, a ValueError):

| key | rule |
|---|---|
| `robots[i].priority` | an integer (not a bool, not a float), 0 or more |
| priorities | one robot each: `robots[2].priority: 1 is already the priority of robots[0] (r1)` |
| `robots` | the world must list its robots (a one-robot world is no fleet) |
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import yaml

from amr_maps.world import load_world


class FleetFileError(ValueError):
    """A fleet file that cannot be used: the message names the file, the key and the value."""


@dataclass(frozen=True)
class FleetFile:
    names: list[str]
    """the robots in file order (their namespaces)."""
    priorities: list[int]
    """per robot in file order: its priority (0 first)."""

    def in_priority_order(self) -> list[str]:
        return [name for _, _, name in sorted(zip(self.priorities, range(len(self.names)), self.names, strict=True))]


def load_fleet(path: str | Path) -> FleetFile:
    """The roster and priorities of the fleet world at `path` (WorldError or FleetFileError naming file, key and
    value)."""
    path = Path(path)
    world = load_world(path)  # the world's own rules (names, starts, goals, solids)
    names = [robot.name for robot in world.robots]
    if not names:
        raise FleetFileError(f"{path}: robots: the world has no robots list: there is no fleet to plan")
    entries = yaml.safe_load(path.read_text(encoding="utf-8"))["robots"]
    priorities: list[int] = []
    holder: dict[int, int] = {}
    for index, entry in enumerate(entries):
        key = f"robots[{index}].priority"
        value = entry.get("priority", index)
        if isinstance(value, bool) or not isinstance(value, int):
            raise FleetFileError(f"{path}: {key}: must be an integer, 0 or more, got {value!r}")
        if value < 0:
            raise FleetFileError(f"{path}: {key}: must be 0 or more, got {value!r}")
        if value in holder:
            other = holder[value]
            raise FleetFileError(
                f"{path}: {key}: {value!r} is already the priority of robots[{other}] ({names[other]})"
            )
        holder[value] = index
        priorities.append(value)
    return FleetFile(names, priorities)
