"""The viewer's control panel in viser: simulation controls, clicks, view, status and any node's parameters.

Callbacks run on viser's threads; each hands the request to `actions` (the node, which runs it on its executor)
and never blocks. A value the server writes back (a refused parameter set reverted) reaches the same callbacks with
no client, and is not sent again.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import viser

from amr_viewer.clicks import GOAL, INITIAL_POSE, OFF
from amr_viewer.parameters import ParameterEntry, format_value
from amr_viewer.scene import TOGGLED

PACES = {
    "as fast as possible": 0.0,
    "0.5x real time": 0.5,
    "1x real time": 1.0,
    "2x real time": 2.0,
    "5x real time": 5.0,
    "10x real time": 10.0,
    "20x real time": 20.0,
}
CLICK_MODES = {"goal (/goal_pose)": GOAL, "pose estimate (/initialpose)": INITIAL_POSE, "nothing": OFF}
NO_NODE = "(choose a node)"
NO_ROBOT = "(none yet)"


class Actions(Protocol):
    def control(self, service: str) -> None: ...
    def set_pace(self, pace: float) -> None: ...
    def set_click_mode(self, mode: str, two_clicks: bool, robot: str) -> None: ...
    def frame(self, client, view: str) -> None: ...
    def select_node(self, node: str) -> None: ...
    def set_parameter(self, node: str, entry: ParameterEntry, value: object) -> None: ...
    def hide_layer(self, layer: str, hidden: bool) -> None: ...


class Panels:
    def __init__(self, server: viser.ViserServer, actions: Actions) -> None:
        self.gui = gui = server.gui
        self.actions = actions
        gui.configure_theme(control_width="medium", dark_mode=False, show_share_button=False)
        with gui.add_folder("Simulation"):
            for label, service in (("Pause", "pause"), ("Resume", "resume"), ("Step", "step"), ("Reset", "reset")):
                gui.add_button(label, hint=f"the simulator's ~/{service}").on_click(
                    lambda event, service=service: self.actions.control(service)
                )
            self.pace = gui.add_dropdown(
                "Pace", tuple(PACES), initial_value="as fast as possible", hint="the simulator's pace parameter"
            )
            self.pace.on_update(
                lambda event: event.client is not None and self.actions.set_pace(PACES[self.pace.value])
            )
            self.simulation_reply = gui.add_markdown("")
        with gui.add_folder("Click on the floor"):
            self.click_mode = gui.add_dropdown("Sends", tuple(CLICK_MODES), initial_value="goal (/goal_pose)")
            self.two_clicks = gui.add_checkbox(
                "Heading by 2nd click",
                False,
                hint="off: a goal faces away from the robot, an estimate keeps its heading",
            )
            self.robot = gui.add_dropdown("Robot", (NO_ROBOT,))
            for handle in (self.click_mode, self.two_clicks, self.robot):
                handle.on_update(lambda event: self._click_mode_changed())
            self.click_reply = gui.add_markdown("")
        with gui.add_folder("View", expand_by_default=False):
            gui.add_button("Top view").on_click(lambda event: self.actions.frame(event.client, "top"))
            gui.add_button("Arms view").on_click(lambda event: self.actions.frame(event.client, "arms"))
            for layer in TOGGLED:
                box = gui.add_checkbox(f"Show {layer}", True)
                box.on_update(lambda event, layer=layer, box=box: self.actions.hide_layer(layer, not box.value))
        with gui.add_folder("Status"):
            self.status = gui.add_markdown("looking at the graph ...")
        self._parameters_folder = gui.add_folder("Parameters", expand_by_default=False)
        with self._parameters_folder:
            self.node = gui.add_dropdown("Node", (NO_NODE,))
            self.node.on_update(
                lambda event: (
                    event.client is not None
                    and self.node.value != NO_NODE
                    and self.actions.select_node(self.node.value)
                )
            )
            gui.add_button("Reload").on_click(
                lambda event: self.node.value != NO_NODE and self.actions.select_node(self.node.value)
            )
            self.parameter_reply = gui.add_markdown("")
        self._entries_folder = None
        self._widgets: dict[str, object] = {}
        self._shown_node = ""

    def _click_mode_changed(self) -> None:
        self.actions.set_click_mode(CLICK_MODES[self.click_mode.value], self.two_clicks.value, self.robot.value)

    # -- written by the node -----------------------------------------------------------------------------------

    def set_robots(self, labels: Sequence[str]) -> None:
        options = tuple(labels) or (NO_ROBOT,)
        if tuple(self.robot.options) != options:
            current = self.robot.value
            self.robot.options = options
            self.robot.value = current if current in options else options[0]

    def set_nodes(self, names: Sequence[str]) -> None:
        options = (NO_NODE, *names)
        if tuple(self.node.options) != options:
            current = self.node.value
            self.node.options = options
            self.node.value = current if current in options else NO_NODE

    def show_parameters(self, node: str, entries: Sequence[ParameterEntry]) -> None:
        """Rebuild the parameter widgets for `node`."""
        if self._entries_folder is not None:
            self._entries_folder.remove()
        self._widgets = {}
        self._shown_node = node
        with self._parameters_folder:
            self._entries_folder = self.gui.add_folder(node)
        with self._entries_folder:
            for entry in entries:
                self._widgets[entry.name] = self._widget(node, entry)

    def _widget(self, node: str, entry: ParameterEntry):
        gui, hint = self.gui, entry.description or None
        if entry.widget == "slider":
            cast = int if entry.is_integer else float
            handle = gui.add_slider(
                entry.name,
                min=cast(entry.minimum),
                max=cast(entry.maximum),
                step=cast(entry.step),
                initial_value=cast(entry.value),
                hint=hint,
            )
        elif entry.widget == "number":
            handle = gui.add_number(entry.name, initial_value=entry.value, hint=hint)
        elif entry.widget == "checkbox":
            handle = gui.add_checkbox(entry.name, bool(entry.value), hint=hint)
        elif entry.widget == "text":
            handle = gui.add_text(entry.name, entry.text(), hint=hint)
        else:
            return gui.add_text(entry.name, entry.text(), disabled=True, hint=hint)

        def changed(event) -> None:
            if event.client is None:  # written back by the server (a refusal reverted): not a user's set
                return
            self.actions.set_parameter(node, entry, handle.value)

        handle.on_update(changed)
        return handle

    def show_value(self, node: str, entry: ParameterEntry, value: object) -> None:
        """Write a parameter's value back into its widget (after a refusal, or a change made elsewhere)."""
        handle = self._widgets.get(entry.name)
        if handle is None or node != self._shown_node:
            return
        if entry.widget in ("text", "readonly"):
            handle.value = format_value(value)
        elif entry.widget in ("slider", "number"):
            handle.value = int(value) if entry.is_integer else float(value)
        elif entry.widget == "checkbox":
            handle.value = bool(value)
