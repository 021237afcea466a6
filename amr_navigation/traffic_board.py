"""The traffic board: what each robot of a fleet tells the others (`TrafficPost`), and every robot's latest post
(`TrafficBoard`). What a robot's traffic rules (amr_navigation.traffic) know of the others is exactly their posts.
At library level the board is one object shared by the robots' navigators (amr_evaluation.fleet_navigation);
through ROS it is the fleet's topic `/traffic` (amr_interfaces/TrafficPost, amr_navigation.traffic_messages), every
robot's navigator node publishing its post there and subscribing to everyone's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TrafficPost:
    """What one robot tells the others, once per observation."""

    name: str
    priority: int
    """lower is first: its index in the world's robots list."""
    pose: tuple[float, float, float] | None = None
    """the estimate in the map frame; None while not localized."""
    path: np.ndarray | None = None
    """(M, 2) the rest of the path it follows (from its closest point on); None without one."""
    blocked_by: str = ""
    """the robot whose centre stands on that stretch of path, in front of it ('' none)."""
    yielding_to: tuple[str, ...] = ()
    passive: bool = False
    """at its goal or waiting aside: it makes way for anyone it blocks."""
    cannot_yield: bool = False
    """it should yield but found no place to wait: the other robot yields instead."""


class TrafficBoard:
    """Every robot's latest post (at library level one object shared by the fleet's navigators; through ROS
    a topic in a namespace the fleet shares)."""

    def __init__(self) -> None:
        self._posts: dict[str, TrafficPost] = {}

    def post(self, post: TrafficPost) -> None:
        self._posts[post.name] = post

    def others(self, name: str) -> list[TrafficPost]:
        return [post for other, post in self._posts.items() if other != name]

    def get(self, name: str) -> TrafficPost | None:
        return self._posts.get(name)
