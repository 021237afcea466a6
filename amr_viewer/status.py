"""The status panel's text: node states grouped by namespace in one compact table, one line per robot. No rclpy.

A fleet of four robots has some 25 lifecycle nodes; a table row per namespace, naming its nodes once per state
(`active: navigator, planner, ...`), keeps them readable in the panel's width.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping

from amr_viewer.messages import format_status

ACTIVE = "active"


def split_node(node: str) -> tuple[str, str]:
    """'/r1/navigator' -> ('/r1', 'navigator'); '/simulator' -> ('/', 'simulator')."""
    namespace, _, name = node.rpartition("/")
    return namespace or "/", name


def node_state_table(states: Mapping[str, str]) -> str:
    """Markdown: a row per namespace (sorted, the root first) with its nodes grouped by state, active first; the
    other states in bold. Empty for no node."""
    if not states:
        return ""
    grouped: dict[str, dict[str, list[str]]] = defaultdict(lambda: defaultdict(list))
    for node, state in states.items():
        namespace, name = split_node(node)
        grouped[namespace][state].append(name)
    rows = ["| namespace | nodes |", "|---|---|"]
    for namespace in sorted(grouped, key=lambda ns: (ns != "/", ns)):
        by_state = grouped[namespace]
        order = sorted(by_state, key=lambda state: (state != ACTIVE, state))
        cells = [
            f"{state if state == ACTIVE else f'**{state}**'}: {', '.join(sorted(by_state[state]))}" for state in order
        ]
        rows.append(f"| {namespace} | {'; '.join(cells)} |")
    return "\n".join(rows)


def offset_text(offset: float | None) -> str | None:
    """The distance between the robot's disc (TF: the localizer's belief) and its true-pose ring at the same
    instant, as the status panel says it; None when there is nothing to compare."""
    if offset is None:
        return None
    return f"disc {100.0 * offset:.0f} cm from the true ring (localization error)"


def mapping_texts(graph, frontiers, skipped: Mapping[str, int]) -> list[str]:
    """A robot's SLAM graph (amr_viewer.state.PoseGraphView), its explorer's frontiers (FrontierView) and the
    messages not drawn, as the status panel says them; nothing for what there is not."""
    texts = []
    if graph is not None:
        texts.append(f"graph {len(graph.poses)} nodes, {len(graph.edges)} edges, {graph.loop_closures} loop closures")
    if frontiers is not None:
        texts.append(
            f"explorer {frontiers.state}: {len(frontiers.centroids)} frontiers"
            + (", one chosen" if frontiers.chosen_centroid is not None else "")
            + (f", {frontiers.blacklisted} given up" if frontiers.blacklisted else "")
        )
    texts.extend(
        f"{count} {layer} message{'s' if count > 1 else ''} not drawn (see the log)"
        for layer, count in sorted(skipped.items())
        if count
    )
    return texts


def robot_line(state, color_name: str) -> str:
    """A robot's line (amr_viewer.state.RobotState, drawn in `color_name`): its simulator status, localization,
    particles, the disc's offset from the truth, its SLAM graph and frontiers, the messages not drawn."""
    details = format_status(state.status)
    if state.localized is not None and not state.status.get("localization_enabled"):
        details.append("localized" if state.localized else "not localized")
    if state.particle_count:
        details.append(f"{state.particle_count} particles ({len(state.particles)} drawn)")
    offset = offset_text(state.drawn_offset())
    if offset is not None:
        details.append(offset)
    details.extend(mapping_texts(state.graph, state.frontiers, state.skipped))
    title = f"**robot {state.namespace or '/'}** ({color_name})"
    return title + (": " + "; ".join(details) if details else "")


def panel_text(
    node_states: Mapping[str, str], paused: bool | None, robot_lines: Iterable[str], arms: Mapping[str, Iterable[str]]
) -> str:
    """The status panel: the node state table, whether the simulator is paused (None: not known), a line per robot
    (robot_line), the arms of each IK service; 'nothing found yet' for nothing."""
    lines = []
    table = node_state_table(node_states)
    if table:
        lines.append(table)
    if paused is not None:
        lines.append("**simulator paused**" if paused else "simulator running")
    lines.extend(robot_lines)
    lines.extend(f"**arms of {node}**: {', '.join(names)}" for node, names in arms.items())
    return "\n\n".join(lines) or "nothing found yet"
