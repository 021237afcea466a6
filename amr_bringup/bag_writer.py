"""rosbag2 bags in MCAP storage, written by the `rosbags` library from serialized (CDR) messages.

A bag is a directory holding metadata.yaml (what `ros2 bag info` reads) and one .mcap file that
carries every topic's schema (ros2msg definition) so Foxglove decodes it. `out/run.mcap` names the bag
directory `out/run` (rosbag2's layout: `ros2 bag record -s mcap -o out/run`).
Types come from rosbags' ROS 2 Jazzy store; others (amr_interfaces) are read from the installed
.msg files of their package. Messages arrive already serialized (an rclpy subscription with raw=True),
so recording costs no (de)serialization. No rclpy here.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

BAG_VERSION = 9
"""rosbag2 metadata version (Jazzy's rosbag2 reads 1..9)."""
NO_TIME = QosTime(0, 0)
UNSET_TIME = QosTime(2147483647, 4294967295)
"""rmw's 'infinite' durations, as rosbag2 writes them for default deadline/lifespan/lease."""


class BagError(ValueError):
    """A bag that cannot be written or read, naming what is wrong."""


ROS_DISTRO = "jazzy"
"""What metadata.yaml names as the recording's distribution (rosbags writes its own name there)."""


@dataclass(frozen=True)
class TopicQos:
    """The QoS a recorded topic was offered with (plain data; the ROS recorder fills it).

    depth None: history unknown, depth 0, which is what DDS discovery reports for every publisher
    (history is not part of the discovery data) and what rosbag2 records then.
    """

    reliable: bool = True
    transient_local: bool = False
    depth: int | None = 10

    def rosbags_qos(self) -> Qos:
        return Qos(
            history=QosHistory.UNKNOWN if self.depth is None else QosHistory.KEEP_LAST,
            depth=self.depth or 0,
            reliability=QosReliability.RELIABLE if self.reliable else QosReliability.BEST_EFFORT,
            durability=QosDurability.TRANSIENT_LOCAL if self.transient_local else QosDurability.VOLATILE,
            deadline=UNSET_TIME,
            lifespan=UNSET_TIME,
            liveliness=QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=UNSET_TIME,
            avoid_ros_namespace_conventions=False,
        )


def bag_directory(path: str | Path) -> Path:
    """The bag directory for a user's path: `out/run.mcap` -> `out/run`."""
    path = Path(path)
    return path.with_suffix("") if path.suffix == ".mcap" else path


def suite_typestore(search_prefixes: tuple[Path, ...] = ()) -> Typestore:
    """Jazzy's standard types plus the installed interface packages rosbags does not know."""
    store = get_typestore(Stores.ROS2_JAZZY)
    store.search_prefixes = search_prefixes or _prefixes()  # type: ignore[attr-defined]
    return store


def ensure_type(store: Typestore, msgtype: str) -> None:
    """Register `msgtype` (pkg/msg/Name) and what it nests from the installed .msg files if unknown."""
    if msgtype in store.types:
        return
    package, kind, name = _split(msgtype)
    for prefix in getattr(store, "search_prefixes", _prefixes()):
        definition = Path(prefix) / "share" / package / kind / f"{name}.msg"
        if definition.is_file():
            types = get_types_from_msg(definition.read_text(encoding="utf-8"), msgtype)
            for _, fields in types.values():
                for _, (_, nested) in fields:
                    _ensure_nested(store, nested)
            store.register(types)
            return
    raise BagError(f"message type {msgtype}: no {package}/{kind}/{name}.msg installed and not a Jazzy standard type")


class BagWriter:
    """Write serialized messages of named topics into a new rosbag2 MCAP bag."""

    def __init__(self, path: str | Path, typestore: Typestore | None = None) -> None:
        self.path = bag_directory(path)
        if self.path.exists():
            raise BagError(f"{self.path}: exists already; a recording never overwrites a bag")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._store = typestore or suite_typestore()
        self._writer = Writer(self.path, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._connections: dict[str, object] = {}
        self.messages = 0

    def add_topic(self, topic: str, msgtype: str, qos: TopicQos = TopicQos()) -> None:
        """Declare a topic before writing to it (its type, definition, hash and offered QoS)."""
        if topic in self._connections:
            raise BagError(f"{self.path}: topic {topic} added twice")
        ensure_type(self._store, msgtype)
        self._connections[topic] = self._writer.add_connection(
            topic, msgtype, typestore=self._store, offered_qos_profiles=[qos.rosbags_qos()]
        )

    def write(self, topic: str, stamp_ns: int, data: bytes | memoryview) -> None:
        """One serialized (CDR) message received at `stamp_ns` (ns since the epoch of the recorder clock)."""
        connection = self._connections.get(topic)
        if connection is None:
            raise BagError(f"{self.path}: topic {topic} was not added")
        self._writer.write(connection, int(stamp_ns), data)
        self.messages += 1

    def close(self) -> None:
        """Finish the MCAP file and write metadata.yaml (a bag is only readable after this)."""
        self._writer.close()
        metadata = self.path / "metadata.yaml"
        text = metadata.read_text(encoding="utf-8")
        metadata.write_text(
            text.replace("\n  ros_distro: rosbags\n", f"\n  ros_distro: {ROS_DISTRO}\n"), encoding="utf-8"
        )

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _prefixes() -> tuple[Path, ...]:
    ament = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return tuple(dict.fromkeys([*ament, Path(sys.prefix)]))


def _split(msgtype: str) -> tuple[str, str, str]:
    parts = msgtype.split("/")
    if len(parts) != 3 or not all(parts):
        raise BagError(f"message type {msgtype!r}: expected package/msg/Name")
    return parts[0], parts[1], parts[2]


def _ensure_nested(store: Typestore, nested: object) -> None:
    """Nested field types appear as (kind, detail) tuples; message names are 'pkg/msg/Name' strings."""
    if isinstance(nested, str) and nested.count("/") == 2:
        ensure_type(store, nested)
    elif isinstance(nested, tuple):
        for item in nested:
            _ensure_nested(store, item)
