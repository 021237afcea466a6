"""What the navigator core (amr_navigation.navigator_core, which the navigator node and the library loop both run) does
with the traffic rules around the Navigator's decisions, without ROS: the observations the path follower does not
drive (`idle_advice`), the end of a detour (`detour_done`), and the node's board of the others' posts, which
forgets a robot that has gone quiet (`FleetBoard`).
"""

from __future__ import annotations

from amr_navigation.navigator import Controller, Decision, Mode, Navigator
from amr_navigation.traffic import Advice, Traffic
from amr_navigation.traffic_board import TrafficBoard, TrafficPost
from amr_planning.costmap import Costmap


def idle_advice(
    traffic: Traffic, decision: Decision, pose: tuple[float, float, float], costmap: Costmap, stamp: float
) -> Advice | None:
    """For an observation the path follower does not drive: post it (exploring: no pose; at the goal: passive),
    and at the goal the advice to make way for a robot this one blocks (an Advice with a detour), else None."""
    if decision.controller is Controller.WALL_FOLLOWER:
        traffic.post_idle(None, False)
        return None
    if decision.mode is Mode.REACHED:
        advice = traffic.wants_to_move(pose, costmap, stamp)
    else:
        traffic.post_idle(pose, False)
        advice = None
    return advice if advice is not None and advice.detour is not None else None


def detour_done(traffic: Traffic | None, navigator: Navigator, reached: bool, stamp: float) -> bool:
    """The path follower reached the end of a detour: the rules wait there, and the Navigator is not told (its
    goal stands; the rules say when to plan to it again). True when that was the case."""
    if traffic is None or not reached or not navigator.on_detour:
        return False
    traffic.arrived(stamp)
    return True


class FleetBoard(TrafficBoard):
    """A board fed from the others' posts as they come (the /traffic topic), each kept with the time it was
    stamped: a post older than `timeout` s at the last `prune` is forgotten (a robot gone quiet blocks no one)."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self.timeout = float(timeout)
        self._stamps: dict[str, float] = {}

    def receive(self, post: TrafficPost, stamp: float) -> None:
        """Another robot's post, stamped `stamp` s (a newer one of the same robot replaces it)."""
        last = self._stamps.get(post.name)
        if last is not None and stamp < last:
            return  # out of order: keep the newer one
        self.post(post)
        self._stamps[post.name] = stamp

    def prune(self, now: float) -> list[str]:
        """Forget the posts older than timeout at `now` (s); the names forgotten."""
        gone = [name for name, stamp in self._stamps.items() if now - stamp > self.timeout]
        for name in gone:
            del self._stamps[name]
            self._posts.pop(name, None)
        return gone
