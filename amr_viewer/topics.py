"""Which robots, simulators, arms and nodes the graph holds, from its names and types: no rclpy.

A robot is a namespace with any of the standard robot topics (`<ns>/scan`, `<ns>/ground_truth`, `<ns>/pose`,
`<ns>/particle_cloud`, `<ns>/odom`); its topics are those names in that namespace, so a fleet (one namespace per
robot, nav2's convention: `/robot1/scan`, `/robot1/tf`) gives one RobotTopics each and the root namespace gives the
single robot of today's stacks.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass

ROBOT_MARKERS = {
    "scan": "sensor_msgs/msg/LaserScan",
    "ground_truth": "nav_msgs/msg/Odometry",
    "pose": "amr_interfaces/msg/LocalizedPose",
    "particle_cloud": "geometry_msgs/msg/PoseArray",
    "odom": "nav_msgs/msg/Odometry",
}
"""Topic leaf name -> type that makes its namespace a robot."""
SIMULATOR_STATUS = "amr_interfaces/msg/SimulatorStatus"
JOINT_STATES = "sensor_msgs/msg/JointState"
CONTROL_SERVICES = ("pause", "resume", "step", "reset")
TRIGGER = "std_srvs/srv/Trigger"
EMPTY = "std_srvs/srv/Empty"
GLOBAL_LOCALIZATION = "reinitialize_global_localization"
"""A localizer's service that spreads its estimate over the map again (nav2 AMCL's name; our particle filter's)."""
GET_STATE = "lifecycle_msgs/srv/GetState"
POSE_GRAPH = "amr_interfaces/msg/PoseGraph"
"""A SLAM node's graph for viewers (amr_mapping's slam: `<ns>/slam/graph`)."""
FRONTIERS = "amr_interfaces/msg/Frontiers"
"""Frontier exploration's state (amr_mapping's explorer: `<ns>/explorer/frontiers`)."""


def split(name: str) -> tuple[str, str]:
    """'/a/b/scan' -> ('/a/b', 'scan'); '/scan' -> ('', 'scan')."""
    namespace, _, leaf = name.rpartition("/")
    return namespace, leaf


def join(namespace: str, name: str) -> str:
    return f"{namespace}/{name}" if namespace else f"/{name}"


@dataclass(frozen=True)
class RobotTopics:
    """The names a robot's topics have in its namespace ('' = the root)."""

    namespace: str

    def __getattr__(self, leaf: str) -> str:
        if leaf.startswith("_"):
            raise AttributeError(leaf)
        return join(self.namespace, leaf)

    @property
    def label(self) -> str:
        return self.namespace or "/"


def robot_namespaces(topics: Iterable[tuple[str, Iterable[str]]]) -> list[str]:
    """Namespaces with a robot marker topic of the right type, sorted (the root first)."""
    found = set()
    for name, types in topics:
        namespace, leaf = split(name)
        if ROBOT_MARKERS.get(leaf) in set(types):
            found.add(namespace)
    return sorted(found)


def simulator_status_topics(topics: Iterable[tuple[str, Iterable[str]]]) -> list[str]:
    return sorted(name for name, types in topics if SIMULATOR_STATUS in set(types))


def joint_state_nodes(topics: Iterable[tuple[str, Iterable[str]]]) -> list[str]:
    """Nodes publishing `<node>/joint_states` (an IK service's private topic): their full names."""
    return sorted(
        split(name)[0]
        for name, types in topics
        if split(name)[1] == "joint_states" and split(name)[0] and JOINT_STATES in set(types)
    )


def simulators(services: Iterable[tuple[str, Iterable[str]]]) -> list[str]:
    """Nodes serving every simulator control (`<node>/pause`, `/resume`, `/step`, `/reset` as Trigger)."""
    offered: dict[str, set[str]] = {}
    for name, types in services:
        node, leaf = split(name)
        if leaf in CONTROL_SERVICES and TRIGGER in set(types):
            offered.setdefault(node, set()).add(leaf)
    return sorted(node for node, leaves in offered.items() if leaves == set(CONTROL_SERVICES))


def localizers(services: Iterable[tuple[str, Iterable[str]]]) -> list[str]:
    """Nodes serving `<node>/reinitialize_global_localization` (std_srvs/Empty): their full names."""
    return sorted(
        split(name)[0] for name, types in services if split(name)[1] == GLOBAL_LOCALIZATION and EMPTY in set(types)
    )


def lifecycle_nodes(services: Iterable[tuple[str, Iterable[str]]]) -> list[str]:
    """Nodes with a `get_state` lifecycle service."""
    return sorted(
        split(name)[0] for name, types in services if split(name)[1] == "get_state" and GET_STATE in set(types)
    )


def node_topic(topics: Mapping[str, Iterable[str]], namespace: str, leaf: str, kind: str) -> str | None:
    """A node's private topic `<namespace>/<node>/<leaf>` of type `kind` (the first by name; None if there is
    none): a SLAM node or an explorer by another name than the suite's."""
    for name in sorted(topics):
        node, found = split(name)
        if found == leaf and node and split(node)[0] == namespace and kind in set(topics[name]):
            return name
    return None


def full_name(name: str, namespace: str) -> str:
    return f"{namespace.rstrip('/')}/{name}"


FOUND_BY_TYPE = {"slam/graph": POSE_GRAPH, "explorer/frontiers": FRONTIERS}
"""Leaves of a robot found by type when the suite's node name is not in the graph (a SLAM node or explorer named
otherwise in the robot's namespace)."""


def leaf_topic(namespace: str, leaf: str, graph: Collection[str], current: str | None = None) -> str:
    """The topic of a robot's `leaf` (`current`: the one subscribed now, if any): in its namespace; a fleet robot's
    map and tree are the root's until its own appear (then kept), its simulator status is `<ns>/status` once that
    appears (docs/fleet.md); the SLAM graph and the frontiers are the suite's node names' (`slam/graph`,
    `explorer/frontiers`), else a topic of their type under another node of the namespace when `graph` maps names
    to types."""
    own = join(namespace, leaf)
    if leaf in FOUND_BY_TYPE:
        if own in graph or (current is not None and current in graph):
            return own if own in graph else current
        found = node_topic(graph, namespace, leaf.rpartition("/")[2], FOUND_BY_TYPE[leaf])
        return found or current or own
    if not namespace:
        return own
    if leaf in ("map", "tf", "tf_static"):
        return own if own in graph or current == own else "/" + leaf
    if leaf == "simulator/status":
        status = join(namespace, "status")
        return status if status in graph or current == status else own
    return own
