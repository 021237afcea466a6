"""Write the parameter tables of docs/<package>.md from the specs (`--check`: only say which ones drifted).

    .venv/bin/python scripts/parameter_docs.py           # rewrite every generated table
    .venv/bin/python scripts/parameter_docs.py --check   # exit 1 naming the tables that differ

Every node of the suite is listed in NODES with where its parameters are stated (amr_util.parameter_spec)
and the parameter files the suite ships for it (one column each). A group of parameters another table already
lists (the navigator's `traffic_rules.*` are the traffic table's) is one row linking there (`Refer`), checked to be
the same specs. tests/foundation/test_docs.py fails when a committed table differs from this, or when an installed
executable has no entry.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import yaml

from amr_util.parameter_docs import blocks, drift, parameter_table, splice
from amr_util.parameter_file import dotted
from amr_util.parameter_spec import ParameterSpec

ROOT = Path(__file__).resolve().parents[1]

DOCS = ROOT / "docs"
CONFIG = ROOT / "config"


@dataclass(frozen=True)
class Refer:
    """The parameters `<prefix>*` of a node are those `<target_prefix>*` of the node `target` lists: one row."""

    prefix: str
    target: str
    target_prefix: str = ""


@dataclass(frozen=True)
class Node:
    package: str
    executable: str
    specs: Callable[[], Sequence[ParameterSpec]]
    files: tuple[str, ...] = ()
    """Shipped parameter files (config/), one table column each."""
    refers: tuple[Refer, ...] = ()
    """Groups of parameters written as one row linking to the table that lists them."""

    @property
    def key(self) -> str:
        return f"{self.package}/{self.executable}"

    @property
    def page(self) -> Path:
        return DOCS / f"{self.package}.md"


def _simulator():
    from amr_simulation.parameters import parameter_specs

    return parameter_specs()


def _wall_follower():
    from amr_control.wall_follower_config import WallFollowerConfig

    return WallFollowerConfig.parameter_specs()


def _path_follower():
    from amr_control.path_follower_config import PathFollowerConfig

    return PathFollowerConfig.parameter_specs()


def _particle_filter():
    from amr_localization.localizer_node import SHELL_SPECS
    from amr_localization.particle_filter_parameters import parameter_specs

    return parameter_specs() + SHELL_SPECS


def _beacon_localizer():
    from amr_localization.beacon_localizer_node import parameter_specs

    return parameter_specs()


def _planner():
    from amr_planning.planner import PlannerConfig

    return PlannerConfig.parameter_specs()


def _navigator():
    from amr_navigation.navigator_config import NavigatorConfig

    return NavigatorConfig.parameter_specs()


def _fleet_planner():
    from amr_navigation.fleet_planner_config import FleetPlannerConfig

    return FleetPlannerConfig.parameter_specs()


def _traffic():
    from amr_navigation.traffic import TrafficConfig

    return TrafficConfig.parameter_specs()


def _map_server():
    from amr_maps.map_source import parameter_specs

    return parameter_specs()


def _odometry_node():
    from amr_turtlebot3.odometry_node import PARAMETERS

    return PARAMETERS


def _lifecycle_manager():
    from amr_bringup.lifecycle_manager import PARAMETERS

    return PARAMETERS


def _recorder():
    from amr_bringup.recorder import PARAMETERS

    return PARAMETERS


def _ik_service():
    from amr_kinematics.parameters import CHAINS, SERVICE_PARAMETERS

    return (*SERVICE_PARAMETERS, CHAINS)


def _ik_chain_keys():
    """Every `<chain>.<key>` a chain may have (named here by the key alone)."""
    from dataclasses import replace

    from amr_kinematics.config import CHAIN_KEYS

    return tuple(replace(spec, name=f"<chain>.{key}") for key, spec in CHAIN_KEYS.items())


def _viewer():
    from amr_viewer.viewer_config import specs

    return specs()


def _log_player():
    from amr_datasets.player_node import PARAMETERS

    return PARAMETERS


def _slam():
    from amr_mapping.slam_node import parameter_specs

    return parameter_specs()


def _explorer():
    from amr_mapping.explorer_node import parameter_specs

    return parameter_specs()


NODES = (
    Node("amr_simulation", "simulator", _simulator, ("simulator.yaml",)),
    Node("amr_control", "wall_follower", _wall_follower, ("wall_follower_sim.yaml", "wall_follower_real.yaml")),
    Node("amr_control", "path_follower", _path_follower, ("path_follower_sim.yaml", "path_follower_real.yaml")),
    Node("amr_localization", "particle_filter", _particle_filter, ("particle_filter.yaml",)),
    Node("amr_localization", "beacon_localizer", _beacon_localizer, ("beacon_localizer.yaml",)),
    Node("amr_planning", "planner", _planner, ("planner.yaml",)),
    Node(
        "amr_navigation",
        "navigator",
        _navigator,
        ("navigator.yaml",),
        (Refer("traffic_rules.", "amr_navigation/traffic"),),
    ),
    Node("amr_navigation", "traffic", _traffic, ("traffic.yaml",)),
    Node(
        "amr_navigation",
        "fleet_planner",
        _fleet_planner,
        refers=(Refer("costmap.", "amr_navigation/navigator", "costmap."),),
    ),
    Node("amr_maps", "map_server", _map_server),
    Node("amr_turtlebot3", "odometry_node", _odometry_node, ("odometry_node.yaml",)),
    Node("amr_bringup", "lifecycle_manager", _lifecycle_manager),
    Node("amr_bringup", "recorder", _recorder),
    Node("amr_kinematics", "ik_service", _ik_service),
    Node("amr_kinematics", "ik_service.chain_keys", _ik_chain_keys),
    Node("amr_viewer", "viewer", _viewer),
    Node("amr_datasets", "log_player", _log_player),
    Node("amr_mapping", "slam", _slam, ("slam.yaml",)),
    Node("amr_mapping", "explorer", _explorer, ("explorer.yaml",)),
)


def file_values(node: Node, name: str) -> dict:
    """{parameter: value} a shipped file sets for the node (dotted names)."""
    data = yaml.safe_load((CONFIG / name).read_text(encoding="utf-8"))
    section = node.executable.split(".")[0]
    return dotted(data[section]["ros__parameters"])


def _target(refer: Refer) -> Node:
    return next(node for node in NODES if node.key == refer.target)


def _link(node: Node, target: Node) -> str:
    """A link from node's page to target's table: the anchor of the last heading above its block."""
    text = target.page.read_text(encoding="utf-8") if target.page.is_file() else ""
    above = re.sub(r"^```.*?^```", "", text.split(f"<!-- parameters: {target.key} -->")[0], flags=re.S | re.M)
    headings = re.findall(r"^#+ (.+)$", above, re.M)
    slug = re.sub(r"[^\w\- ]", "", headings[-1].strip().lower()).replace(" ", "-") if headings else ""
    return ("" if target.page == node.page else target.page.name) + f"#{slug}"


def referral_problems(node: Node) -> list[str]:
    """Why a group of the node's parameters cannot be one row: its specs differ from the target's, or a shipped
    file sets one of them (the row has no values)."""
    specs = node.specs()
    found = []
    for refer in node.refers:
        mine = [replace(s, name=s.name.removeprefix(refer.prefix)) for s in specs if s.name.startswith(refer.prefix)]
        theirs = [
            replace(s, name=s.name.removeprefix(refer.target_prefix))
            for s in _target(refer).specs()
            if s.name.startswith(refer.target_prefix)
        ]
        if not mine or mine != theirs:
            found.append(f"{node.key}: {refer.prefix}* are not the {refer.target_prefix}* parameters of {refer.target}")
        if any(name.startswith(refer.prefix) for file in node.files for name in file_values(node, file)):
            found.append(f"{node.key}: a shipped file sets {refer.prefix}*: the group needs its own rows")
    return found


def table(node: Node) -> str:
    """A node's table: a row per parameter, each group another table lists as one row linking there."""
    specs = [s for s in node.specs() if not any(s.name.startswith(refer.prefix) for refer in node.refers)]
    made = parameter_table(specs, {name: file_values(node, name) for name in node.files})
    for refer in node.refers:
        link = f"[{refer.target}]({_link(node, _target(refer))})"
        what = (
            f"the `{refer.target_prefix}*` rows of {link}"
            if refer.target_prefix
            else f"each row of {link}, so prefixed"
        )
        made += "| " + " | ".join([f"`{refer.prefix}*`", *[""] * (len(node.files) + 4), what]) + " |\n"
    return made


def tables() -> dict[str, str]:
    """{block key: table} of every node, from the specs and the shipped files."""
    return {node.key: table(node) for node in NODES}


def pages() -> dict[Path, list[str]]:
    """{docs page: block keys it must hold}."""
    found: dict[Path, list[str]] = {}
    for node in NODES:
        found.setdefault(node.page, []).append(node.key)
    return found


def problems() -> list[str]:
    """What differs between the committed docs and the specs, one line each (empty: all in step)."""
    made = tables()
    lines = [problem for node in NODES for problem in referral_problems(node)]
    for page, keys in pages().items():
        if not page.is_file():
            lines.append(f"{page.relative_to(ROOT)}: missing (it must hold the tables of {', '.join(keys)})")
            continue
        text = page.read_text(encoding="utf-8")
        present = blocks(text)
        lines += [
            f"{page.relative_to(ROOT)}: no block `<!-- parameters: {key} -->`" for key in keys if key not in present
        ]
        lines += [
            f"{page.relative_to(ROOT)}: the table of {key} differs from its specs"
            for key in drift(text, made)
            if key in present
        ]
    return lines


def write() -> list[str]:
    """Rewrite every block; the pages changed."""
    made = tables()
    changed = []
    for page in pages():
        if not page.is_file():
            continue
        text = page.read_text(encoding="utf-8")
        new, unknown = splice(text, made)
        if unknown:
            raise SystemExit(f"{page}: blocks with no node: {', '.join(unknown)}")
        if new != text:
            page.write_text(new, encoding="utf-8")
            changed.append(str(page.relative_to(ROOT)))
    return changed


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only report tables that differ (exit 1)")
    args = parser.parse_args(argv)
    if args.check:
        found = problems()
        for line in found:
            print(line)
        return 1 if found else 0
    for page in write():
        print(f"wrote {page}")
    for line in problems():  # pages or blocks still missing: add them by hand, then run this again
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
