"""The 3D scene in viser: each robot's layers and the arms, redrawn only where their version changed.

Each robot has a colour of its own (ROBOT_COLORS, in the order the robots are first drawn): its disc, its trail and
the name label above it; the other layers keep one colour per kind (scan red, path blue, ...).

Everything lies on the floor (z = 0, the map) a few millimetres apart so nothing flickers: map, world goal, SLAM
graph, trail, path, particles, scan, estimate, goal, frontiers, robot. Point clouds and line sets keep one colour
each, so a new set of any size replaces the old in one message; the trail's full chunks are drawn once and never
sent again. Without a GPU (a headless browser's software WebGL) rendering dominates: dots and short line sets keep
it cheap. The SLAM graph's sequential edges and its loop closures are two line sets, so each keeps its colour.
"""

from __future__ import annotations

import math

import numpy as np
import viser

from amr_util.geometry import Pose2D
from amr_util.robot_description import default_robot
from amr_viewer.arms import ArmSet
from amr_viewer.geometry import wxyz_of
from amr_viewer.state import RobotState

COLORS = {
    "heading": (250, 250, 250),
    "truth": (20, 20, 20),
    "scan": (230, 40, 40),
    "particles": (255, 140, 0),
    "estimate": (0, 160, 80),
    "searching": (230, 120, 0),
    "path": (30, 110, 255),
    "goal": (200, 0, 200),
    "world_goal": (0, 170, 60),
    "beacons": (250, 200, 0),
    "arm": (60, 60, 60),
    "joint": (236, 180, 0),
    "graph_edges": (0, 150, 160),
    "graph_nodes": (0, 95, 110),
    "loop_closures": (235, 30, 140),
    "frontiers": (250, 170, 0),
    "chosen_frontier": (215, 60, 0),
}
ROBOT_COLORS = (
    (40, 60, 160),
    (120, 20, 70),
    (70, 130, 40),
    (150, 80, 200),
    (130, 85, 40),
    (0, 190, 255),
    (120, 120, 120),
    (150, 150, 0),
)
"""A robot's disc, trail and label, in the order the robots are first drawn (then again from the first): each at
least MIN_COLOR_DISTANCE from the others and from every layer's colour in COLORS (a robot's trail is never read as a
path, its disc never as an estimate)."""
ROBOT_COLOR_NAMES = ("blue", "maroon", "green", "violet", "brown", "cyan", "grey", "olive")
MIN_COLOR_DISTANCE = 70.0
"""RGB distance at least between a robot's colour and any other colour drawn."""
HEIGHTS = {
    "world_goal": 0.002,
    "graph": 0.003,
    "trail": 0.004,
    "path": 0.006,
    "particles": 0.008,
    "scan": 0.01,
    "estimate": 0.012,
    "goal": 0.014,
    "beacons": 0.02,
    "frontiers": 0.016,
    "robot": 0.0,
}
CIRCLE = np.column_stack([np.cos(np.linspace(0, 2 * math.pi, 41)), np.sin(np.linspace(0, 2 * math.pi, 41))])
LINE = 0.012
"""m, the thickness of drawn lines."""
TOGGLED = ("map", "graph", "frontiers", "particles", "scan", "trail", "truth", "path", "labels")
"""Layers a user can hide."""
MAP_PIXELS, MAP_UPSCALE = 1024, 8
"""A map image is repeated (nearest cell) up to about MAP_PIXELS on its long side, at most MAP_UPSCALE times."""


def polyline(points: np.ndarray, z: float) -> np.ndarray:
    """(N, 2) points as (N - 1, 2, 3) segments at height z."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 2:
        return np.zeros((0, 2, 3), dtype=np.float32)
    return segments_at(np.stack([points[:-1], points[1:]], axis=1), z)


def segments_at(segments: np.ndarray, z: float) -> np.ndarray:
    """(M, 2, 2) segments at height z as (M, 2, 3) float32."""
    out = np.zeros((len(segments), 2, 3), dtype=np.float32)
    out[:, :, :2] = segments
    out[:, :, 2] = z
    return out


def arrow(pose: Pose2D, length: float) -> np.ndarray:
    """A heading arrow as (3, 2, 2) segments: shaft and two barbs."""
    tip = np.array([pose.x + length * math.cos(pose.theta), pose.y + length * math.sin(pose.theta)])
    base = np.array([pose.x, pose.y])
    barbs = [tip - 0.35 * length * np.array([math.cos(pose.theta + s), math.sin(pose.theta + s)]) for s in (0.5, -0.5)]
    return np.array([[base, tip], [tip, barbs[0]], [tip, barbs[1]]])


def cross(center, size: float) -> np.ndarray:
    """A cross at `center` as (2, 2, 2) segments."""
    x, y = float(center[0]), float(center[1])
    return np.array([[[x - size, y], [x + size, y]], [[x, y - size], [x, y + size]]])


def circle(x: float, y: float, radius: float) -> np.ndarray:
    return CIRCLE * radius + np.array([x, y])


def points3(points: np.ndarray, z: float) -> np.ndarray:
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return np.column_stack([points, np.full(len(points), z)]).astype(np.float32)


class Scene:
    """Draws RobotStates and an ArmSet into a viser server's scene."""

    def __init__(self, server: viser.ViserServer, robot_radius: float = default_robot().radius) -> None:
        self.scene = server.scene
        self.robot_radius = robot_radius
        self.hidden: set[str] = set()
        self._drawn: dict[tuple[str, str], int] = {}
        self._handles: dict[str, object] = {}
        self._trail_chunks: dict[str, set[int]] = {}
        self._arm_versions: dict[str, int] = {}
        self._colors: dict[str, tuple] = {}
        self._robot_colors: dict[str, tuple[int, int, int]] = {}
        self.scene.set_up_direction("+z")

    def color_of(self, namespace: str) -> tuple[int, int, int]:
        """The robot's own colour (ROBOT_COLORS in the order robots are first drawn; kept while it is drawn)."""
        if namespace not in self._robot_colors:
            self._robot_colors[namespace] = ROBOT_COLORS[len(self._robot_colors) % len(ROBOT_COLORS)]
        return self._robot_colors[namespace]

    def color_name_of(self, namespace: str) -> str:
        return ROBOT_COLOR_NAMES[ROBOT_COLORS.index(self.color_of(namespace))]

    @staticmethod
    def label_of(namespace: str) -> str:
        """The name drawn above a robot: its namespace without the slash ("robot" in the root namespace)."""
        return namespace.strip("/") or "robot"

    # -- robots ------------------------------------------------------------------------------------------------

    def draw(self, state: RobotState) -> int:
        """Redraw the layers of `state` whose version changed; returns how many were redrawn."""
        redrawn = 0
        for layer in (
            "map",
            "world",
            "beacons",
            "graph",
            "path",
            "goal",
            "trail",
            "frontiers",
            "particles",
            "scan",
            "estimate",
            "truth",
            "robot",
        ):
            key = (state.namespace, layer)
            version = state.versions[layer]
            if self._drawn.get(key) == version:
                continue
            getattr(self, f"_draw_{layer}")(state, self._root(state))
            self._drawn[key] = version
            redrawn += 1
        return redrawn

    def set_hidden(self, layer: str, hidden: bool) -> None:
        """Hide or show a layer of every robot (TOGGLED)."""
        if hidden:
            self.hidden.add(layer)
        else:
            self.hidden.discard(layer)
        for name, handle in self._handles.items():
            if name.rsplit("/", 1)[-1] == layer or f"/{layer}/" in name:
                handle.visible = not hidden

    def forget(self, namespace: str) -> None:
        """Remove everything drawn for a robot that is gone."""
        root, removed = self._root_of(namespace), []
        for name in sorted(n for n in self._handles if n.startswith(root + "/")):
            handle = self._handles.pop(name)
            if not any(name.startswith(parent + "/") for parent in removed):  # gone with its parent
                handle.remove()
                removed.append(name)
        self._drawn = {key: v for key, v in self._drawn.items() if key[0] != namespace}
        self._trail_chunks.pop(namespace, None)
        self._robot_colors.pop(namespace, None)

    @staticmethod
    def _root_of(namespace: str) -> str:
        return "/robots/" + (namespace.strip("/").replace("/", "_") or "root")

    def _root(self, state: RobotState) -> str:
        return self._root_of(state.namespace)

    def _put(self, name: str, handle) -> None:
        """Keep `handle`, added under `name` (viser has removed the node that had that name: removing it again
        warned "Attempted to remove already removed node" at the first redraw of a new map)."""
        self._handles[name] = handle
        layer = name.split("/")[3] if name.count("/") >= 3 else ""
        if layer in self.hidden:
            handle.visible = False

    def _drop(self, name: str) -> None:
        handle = self._handles.pop(name, None)
        if handle is not None:
            handle.remove()

    def _points(self, name: str, points: np.ndarray, add) -> None:
        """Points of a handle with a `points` property: updated in place, added with add(), dropped when empty."""
        if len(points) == 0:
            self._drop(name)
            return
        handle = self._handles.get(name)
        if handle is not None:
            handle.points = points
        else:
            self._put(name, add())

    def _segments(self, name: str, segments: np.ndarray, color, thickness: float = LINE) -> None:
        """Line segments (M, 2, 3); none drawn for M = 0."""
        self._points(name, segments, lambda: self.scene.add_line_segments(name, segments, color, thickness=thickness))

    def _cloud(self, name: str, points: np.ndarray, color, size: float, shape: str = "circle") -> None:
        self._points(
            name,
            points,
            lambda: self.scene.add_point_cloud(
                name, points, color, point_size=size, point_shape=shape, precision="float32", point_shading="flat"
            ),
        )

    def _draw_map(self, state: RobotState, root: str) -> None:
        image = state.map
        if image is None:
            self._drop(f"{root}/map")
            return
        factor = max(1, min(MAP_UPSCALE, MAP_PIXELS // max(image.rgb.shape[:2])))  # sharp cells: the browser
        rgb = np.repeat(np.repeat(image.rgb, factor, axis=0), factor, axis=1)  # interpolates the texture
        self._put(
            f"{root}/map",
            self.scene.add_image(
                f"{root}/map",
                rgb,
                image.width,
                image.height,
                format="png",
                cast_shadow=False,
                receive_shadow=False,
                position=(image.center.x, image.center.y, -0.001),
                wxyz=wxyz_of(image.center.theta),
            ),
        )

    def _draw_world(self, state: RobotState, root: str) -> None:
        goal = state.world_goal
        if goal is None:
            self._drop(f"{root}/world_goal")
            return
        outline = polyline(circle(goal.x, goal.y, goal.radius), HEIGHTS["world_goal"])
        self._segments(f"{root}/world_goal", outline, COLORS["world_goal"], 2 * LINE)

    def _draw_graph(self, state: RobotState, root: str) -> None:
        """The SLAM pose graph: its sequential edges, its loop closures (thicker, in their own colour) and its nodes
        as dots."""
        graph, z = state.graph, HEIGHTS["graph"]
        if graph is None:
            for part in ("edges", "loops", "nodes"):
                self._drop(f"{root}/graph/{part}")
            return
        self._segments(f"{root}/graph/edges", segments_at(graph.segments(False), z), COLORS["graph_edges"], LINE)
        self._segments(
            f"{root}/graph/loops", segments_at(graph.segments(True), z + 0.0005), COLORS["loop_closures"], 2 * LINE
        )
        self._cloud(f"{root}/graph/nodes", points3(graph.poses[:, :2], z + 0.001), COLORS["graph_nodes"], 0.035)

    def _draw_frontiers(self, state: RobotState, root: str) -> None:
        """The explorer's frontiers: a dot at each centroid, the chosen one ringed."""
        frontiers, z = state.frontiers, HEIGHTS["frontiers"]
        if frontiers is None:
            self._drop(f"{root}/frontiers/centroids")
            self._drop(f"{root}/frontiers/chosen")
            return
        self._cloud(f"{root}/frontiers/centroids", points3(frontiers.centroids, z), COLORS["frontiers"], 0.09)
        chosen = frontiers.chosen_centroid
        if chosen is None:
            self._drop(f"{root}/frontiers/chosen")
            return
        ring = circle(float(chosen[0]), float(chosen[1]), 0.12)
        rings = np.concatenate([np.stack([ring[:-1], ring[1:]], axis=1), cross(chosen, 0.12)])
        self._segments(f"{root}/frontiers/chosen", segments_at(rings, z), COLORS["chosen_frontier"], 2 * LINE)

    def _draw_beacons(self, state: RobotState, root: str) -> None:
        self._cloud(f"{root}/beacons", points3(state.beacons, HEIGHTS["beacons"]), COLORS["beacons"], 0.09)

    def _draw_path(self, state: RobotState, root: str) -> None:
        self._segments(f"{root}/path", polyline(state.path, HEIGHTS["path"]), COLORS["path"], 1.5 * LINE)

    def _draw_goal(self, state: RobotState, root: str) -> None:
        if state.goal is None:
            self._drop(f"{root}/goal")
            return
        goal = state.goal
        marks = np.concatenate(
            [arrow(goal, 0.3), np.stack([circle(goal.x, goal.y, 0.08)[:-1], circle(goal.x, goal.y, 0.08)[1:]], axis=1)]
        )
        self._segments(f"{root}/goal", segments_at(marks, HEIGHTS["goal"]), COLORS["goal"], 1.5 * LINE)

    def _draw_trail(self, state: RobotState, root: str) -> None:
        """The trail as dots (a line set of thousands of segments is slow to render without a GPU); full chunks are
        sent once, the last one again as it grows."""
        trail, namespace = state.trail, state.namespace
        drawn = self._trail_chunks.setdefault(namespace, set())
        first, last = trail.dropped, trail.dropped + len(trail.chunks) - 1
        for index in [i for i in drawn if not first <= i <= last]:  # dropped from the front, or the trail cleared
            self._drop(f"{root}/trail/chunk{index}")
            drawn.discard(index)
        for index in range(first, last + 1):
            if index in drawn and index != last:
                continue
            points = np.asarray(trail.chunks[index - first], dtype=float).reshape(-1, 2)
            points = points[np.isfinite(points).all(axis=1)]
            self._cloud(
                f"{root}/trail/chunk{index}", points3(points, HEIGHTS["trail"]), self.color_of(namespace), 0.015
            )
            drawn.add(index)

    def _draw_particles(self, state: RobotState, root: str) -> None:
        self._cloud(
            f"{root}/particles", points3(state.particles[:, :2], HEIGHTS["particles"]), COLORS["particles"], 0.025
        )

    def _draw_scan(self, state: RobotState, root: str) -> None:
        self._cloud(f"{root}/scan", points3(state.scan_in_map(), HEIGHTS["scan"]), COLORS["scan"], 0.02)

    def _draw_estimate(self, state: RobotState, root: str) -> None:
        estimate = state.estimate
        if estimate is None:
            self._drop(f"{root}/estimate")
            return
        marks = [arrow(estimate.pose, 0.25)]
        ellipse = state.estimate_ellipse()
        if ellipse is not None:
            marks.append(np.stack([ellipse[:-1], ellipse[1:]], axis=1))
        color = COLORS["estimate"] if estimate.localized else COLORS["searching"]
        name = f"{root}/estimate"
        if self._colors.get(name) != color:  # a line set keeps its colour: a new one for the other
            self._drop(name)
            self._colors[name] = color
        self._segments(name, segments_at(np.concatenate(marks), HEIGHTS["estimate"]), color)

    def _draw_truth(self, state: RobotState, root: str) -> None:
        """The true pose as a ring, at the instant of the robot's transform (RobotState.truth_at_robot_instant)."""
        truth = state.truth_at_robot_instant()
        if truth is None:
            self._drop(f"{root}/truth")
            return
        outline = np.concatenate(
            [
                np.stack(
                    [circle(truth.x, truth.y, self.robot_radius)[:-1], circle(truth.x, truth.y, self.robot_radius)[1:]],
                    axis=1,
                ),
                arrow(truth, self.robot_radius)[:1],
            ]
        )
        self._segments(f"{root}/truth", segments_at(outline, HEIGHTS["goal"] + 0.04), COLORS["truth"], 0.6 * LINE)

    def _draw_robot(self, state: RobotState, root: str) -> None:
        """The disc where TF puts the robot, in its colour, its name above it."""
        pose = state.robot_pose()
        name, label = f"{root}/robot", f"{root}/labels"
        if pose is None:
            for hidden in (name, label):
                if hidden in self._handles:
                    self._handles[hidden].visible = False
            return
        handle = self._handles.get(name)
        if handle is None:
            handle = self.scene.add_frame(name, show_axes=False)
            self._put(name, handle)
            body = self.scene.add_cylinder(
                f"{name}/body",
                radius=self.robot_radius,
                height=0.04,
                color=self.color_of(state.namespace),
                position=(0.0, 0.0, 0.02),
                cast_shadow=False,
            )
            self._handles[f"{name}/body"] = body
            nose = segments_at(np.array([[[0.0, 0.0], [self.robot_radius, 0.0]]]), 0.045)
            self._handles[f"{name}/heading"] = self.scene.add_line_segments(
                f"{name}/heading", nose, COLORS["heading"], thickness=2 * LINE
            )
        handle.position = (pose.x, pose.y, HEIGHTS["robot"])
        handle.wxyz = wxyz_of(pose.theta)
        handle.visible = True
        position = (pose.x, pose.y + 1.4 * self.robot_radius, 0.06)  # above the disc on the screen, not turning
        if label not in self._handles:
            self._put(
                label,
                self.scene.add_label(
                    label,
                    self.label_of(state.namespace),
                    position=position,
                    anchor="bottom-center",
                    font_screen_scale=1.2,
                ),
            )
        else:
            self._handles[label].position = position
            self._handles[label].visible = True

    # -- arms -------------------------------------------------------------------------------------------------

    def draw_arms(self, arms: ArmSet | None, key: str = "arms") -> int:
        """Redraw each arm whose joint values changed; returns how many were redrawn."""
        if arms is None:
            return 0
        redrawn = 0
        for name, arm in arms.arms.items():
            if self._arm_versions.get(f"{key}/{name}") == arm.version:
                continue
            base = f"/{key}/{name}"
            points = arm.points()
            links = np.stack([points[:-1], points[1:]], axis=1).astype(np.float32)
            self._segments(f"{base}/links", links, COLORS["arm"], 0.015)
            wxyz, positions = arm.frames()
            handle = self._handles.get(f"{base}/frames")
            if handle is None:
                self._put(
                    f"{base}/frames",
                    self.scene.add_batched_axes(f"{base}/frames", wxyz, positions, axes_length=0.06, axes_radius=0.004),
                )
                self._put(
                    f"{base}/label",
                    self.scene.add_label(
                        f"{base}/label", f"{name} (x{arm.scale:.2g})", position=tuple(arm.origin + (0.0, -0.3, 0.0))
                    ),
                )
            else:
                handle.batched_wxyzs, handle.batched_positions = wxyz, positions
            self._arm_versions[f"{key}/{name}"] = arm.version
            redrawn += 1
        return redrawn
