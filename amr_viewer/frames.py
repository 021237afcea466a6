"""The latest planar transform of each frame, as a tree: what a viewer needs of tf2 (which is not installable here).

Each child frame has one parent (tf's rule); a lookup composes the chains from both frames to their common root.
Only the latest transform is kept: a view draws the present, not an interpolated past.
"""

from __future__ import annotations

from amr_util.geometry import Pose2D, compose, inverse
from amr_viewer.geometry import IDENTITY, finite

MAX_DEPTH = 64
"""Frames followed up a chain before it is taken for a loop."""


class TransformTree:
    def __init__(self) -> None:
        self._parents: dict[str, tuple[str, Pose2D]] = {}

    def set(self, parent: str, child: str, pose: Pose2D) -> bool:
        """Record parent -> child; False (and nothing kept) for a non-finite pose, an empty name or a self loop."""
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if not parent or not child or parent == child or not finite(*pose):
            return False
        self._parents[child] = (parent, pose)
        return True

    def clear(self) -> None:
        self._parents.clear()

    def has(self, frame: str) -> bool:
        """Whether `frame` is a child in the tree (has a parent)."""
        return frame.lstrip("/") in self._parents

    @property
    def frames(self) -> set[str]:
        return set(self._parents) | {parent for parent, _ in self._parents.values()}

    def _to_root(self, frame: str) -> tuple[str, Pose2D]:
        """(root, pose of `frame` in the root)."""
        pose, seen = IDENTITY, 0
        while frame in self._parents and seen < MAX_DEPTH:
            parent, step = self._parents[frame]
            pose, frame, seen = compose(step, pose), parent, seen + 1
        return frame, pose

    def lookup(self, target: str, source: str) -> Pose2D | None:
        """The pose of frame `source` in frame `target`, or None when they are not connected."""
        target, source = target.lstrip("/"), source.lstrip("/")
        if target == source:
            return IDENTITY
        source_root, source_pose = self._to_root(source)
        target_root, target_pose = self._to_root(target)
        if source_root != target_root:
            return None
        return compose(inverse(target_pose), source_pose)

    def lookup_or_assume(self, target: str, source: str, assumed: tuple[str, str]) -> Pose2D | None:
        """lookup(); when it fails and the frames connect once `assumed` (parent, child) is taken as identity (a map
        -> odom no localizer publishes: odometry is then drawn as if it were the map), with that."""
        found = self.lookup(target, source)
        if found is not None or assumed[1].lstrip("/") in self._parents:
            return found
        parent, child = assumed[0].lstrip("/"), assumed[1].lstrip("/")
        upper = self.lookup(target, parent)
        lower = self.lookup(child, source)
        if upper is None or lower is None:
            return None
        return compose(upper, lower)
