"""The viewer in a real browser: Playwright drives Debian's chromium (headless, offline) against running stacks.

`amr-bringup maze_navigation --composed --view` (one stack for the module) and `amr-bringup ik_service --view`;
a probe node in this process watches /clock, /ground_truth, /goal_pose and the nodes' parameters. Without
/usr/bin/chromium (AMR_CHROMIUM names another) or playwright the whole module is skipped with one line saying how to
install it.
AMR_VIEWER_SCREENSHOT=docs/viewer.png keeps the screenshot of the last test there.
"""

from __future__ import annotations

import io
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = Path(os.environ.get("AMR_CHROMIUM", "/usr/bin/chromium"))
if not CHROMIUM.exists():
    pytest.skip(f"browser tests: no {CHROMIUM} (install it: apt-get install chromium)", allow_module_level=True)
playwright_api = pytest.importorskip("playwright.sync_api",
                                     reason="browser tests: no playwright (pip install -e '.[test]')")

import rclpy  # noqa: E402
from conftest import fresh_domain  # noqa: E402
from amr_interfaces.srv import SolveIK  # noqa: E402
from geometry_msgs.msg import PoseStamped  # noqa: E402
from nav_msgs.msg import OccupancyGrid, Odometry, Path as PathMessage  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter_client import AsyncParameterClient  # noqa: E402
from rclpy.qos import qos_profile_sensor_data  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402

from amr_util.environment import child_environment  # noqa: E402
from amr_util.qos import LATCHED, reliable  # noqa: E402
from amr_viewer.geometry import top_down_camera  # noqa: E402
from amr_viewer.messages import occupancy_grid  # noqa: E402
from amr_viewer.parameters import value_of  # noqa: E402

ARGS = ["--enable-unsafe-swiftshader", "--no-sandbox", "--disable-background-networking", "--disable-dev-shm-usage",
        "--disable-gpu-sandbox", "--mute-audio", "--no-first-run"]
VIEWPORT = {"width": 1024, "height": 640}
STARTUP = 90.0
"""s for a stack and its viewer to come up (a loaded 2-core machine)."""
WAIT = 60.0
DT = 0.05


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def serving(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


def wait_for(condition, timeout: float = WAIT, what: str = "condition") -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


class Probe(Node):
    def __init__(self, context) -> None:
        super().__init__("viewer_test_probe", context=context)
        self.clocks: list[float] = []
        self.truth: list[tuple[float, float]] = []
        self.goals: list[PoseStamped] = []
        self.paths: list[PathMessage] = []
        self.map: OccupancyGrid | None = None
        self.create_subscription(Clock, "/clock", lambda m: self.clocks.append(m.clock.sec + m.clock.nanosec * 1e-9),
                                 reliable(1000))
        self.create_subscription(Odometry, "/ground_truth", lambda m: self.truth.append(
            (m.pose.pose.position.x, m.pose.pose.position.y)), reliable(100))
        self.create_subscription(PoseStamped, "/goal_pose", self.goals.append, reliable(10))
        self.create_subscription(PathMessage, "/path", self.paths.append, LATCHED)
        self.create_subscription(OccupancyGrid, "/map", lambda m: setattr(self, "map", m), LATCHED)
        self._parameter_clients: dict[str, AsyncParameterClient] = {}

    def parameter(self, node: str, name: str):
        client = self._parameter_clients.setdefault(node, AsyncParameterClient(self, node))
        wait_for(client.services_are_ready, what=f"{node}'s parameter services")
        future = client.get_parameters([name])
        wait_for(future.done, what=f"{node}.{name}")
        return value_of(future.result().values[0])


class Stack:
    """amr-bringup <stack> --composed --view in a domain of its own, and a probe spinning on a thread."""

    def __init__(self, name: str, tmp: Path, *extra: str) -> None:
        self.domain, self.port = fresh_domain(), free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = tmp / f"{name}.log"
        env = child_environment(ROS_DOMAIN_ID=str(self.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        self.process = subprocess.Popen(
            [sys.executable, "-m", "amr_bringup.bringup", name, "--view", "--view-port", str(self.port), *extra],
            env=env, stdout=self.log.open("w"), stderr=subprocess.STDOUT, start_new_session=True)
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=self.domain)
        self.probe = Probe(self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.probe)
        self._spinner = threading.Thread(target=self._spin, daemon=True)
        self._spinner.start()
        wait_for(lambda: ("all nodes active" in self.output() and serving(self.port)) or
                 self.process.poll() is not None, STARTUP, f"{name} and its viewer to come up")
        assert self.process.poll() is None, self.output()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # the context shut down under it
            pass

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(20.0)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
        self.executor.shutdown()
        self.probe.destroy_node()
        self.context.try_shutdown()


class Browser:
    """One headless chromium page on the viewer, with every failed request and console error kept."""

    def __init__(self, playwright, url: str) -> None:
        self.browser = playwright.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=ARGS)
        self.page = self.browser.new_page(viewport=VIEWPORT)
        self.page.set_default_timeout(WAIT * 1000)
        self.failed: list[str] = []
        self.errors: list[str] = []
        self.page.on("requestfailed", lambda request: self.failed.append(f"{request.url}: {request.failure}"))
        self.page.on("console", lambda message: message.type == "error" and self.errors.append(message.text))
        self.page.on("pageerror", lambda error: self.errors.append(str(error)))
        self.page.goto(url, timeout=STARTUP * 1000)
        self.button("Pause").wait_for(timeout=STARTUP * 1000)
        self.canvas = self.page.locator("canvas").first

    def button(self, label: str):
        return self.page.get_by_role("button", name=label, exact=True)

    def reply(self, text: str) -> None:
        self.page.get_by_text(text).first.wait_for()

    def choose(self, label: str, option: str) -> None:
        self.page.get_by_label(label, exact=True).click()
        self.page.get_by_role("option", name=option, exact=True).click()

    def toggle_folder(self, title: str) -> None:
        self.page.get_by_text(title, exact=True).first.click()

    def screenshot(self) -> np.ndarray:
        """The canvas as an (H, W, 3) array (the panels over it included)."""
        from PIL import Image

        return np.asarray(Image.open(io.BytesIO(self.canvas.screenshot(timeout=120000))).convert("RGB"))

    def pixel(self, x: float, y: float, camera) -> tuple[float, float]:
        """Where the floor point (x, y) appears on the page, for a camera looking straight down (+y up)."""
        box = self.canvas.bounding_box()
        aspect = box["width"] / box["height"]
        half_height = camera.position[2] * math.tan(camera.fov / 2)
        u = 0.5 + (x - camera.look_at[0]) / (2 * half_height * aspect)
        v = 0.5 - (y - camera.look_at[1]) / (2 * half_height)
        return box["x"] + u * box["width"], box["y"] + v * box["height"]

    def close(self) -> None:
        self.browser.close()


@pytest.fixture(scope="module")
def playwright():
    with playwright_api.sync_playwright() as driver:
        yield driver


@pytest.fixture(scope="module")
def navigation(tmp_path_factory):
    # 2x real time: a lockstep run at full speed leaves a software-rendered page little of two cores
    stack = Stack("maze_navigation", tmp_path_factory.mktemp("navigation"), "--composed", "-p", "simulator.pace:=2.0")
    yield stack
    stack.stop()


@pytest.fixture(scope="module")
def page(playwright, navigation):
    browser = Browser(playwright, navigation.url)
    yield browser
    browser.close()


def camera_of(stack: Stack, page: Browser):
    """The camera the viewer sets (amr_viewer.geometry.top_down_camera over the map, the canvas's aspect)."""
    wait_for(lambda: stack.probe.map is not None, what="/map")
    box = page.canvas.bounding_box()
    return top_down_camera(occupancy_grid(stack.probe.map).bounds, box["width"] / box["height"])


def test_the_page_loads_offline_with_no_failed_request_and_no_console_error(page, navigation):
    assert page.failed == [] and page.errors == []
    page.reply("simulator active")  # the status panel


def test_the_pace_control_sets_the_simulators_pace(page, navigation):
    page.choose("Pace", "1x real time")
    page.reply("/simulator: pace = 1.0")
    assert navigation.probe.parameter("/simulator", "pace") == 1.0


def test_the_scene_is_drawn_and_follows_the_robot(page, navigation):
    probe = navigation.probe
    page.button("Reset").click()
    page.reply("/simulator: reset")
    camera = camera_of(navigation, page)
    wait_for(lambda: len(probe.truth) > 2, what="/ground_truth")
    time.sleep(1.5)  # the reset drawn: the viewer redraws at 10 Hz, a software-rendered page a few times a second
    before = page.screenshot()
    start = probe.truth[-1]  # 1x real time: within a few cm of where it was drawn
    assert len(np.unique(before.reshape(-1, 3), axis=0)) > 20, "not a blank canvas"
    wait_for(lambda: math.dist(probe.truth[-1], start) > 0.3, what="the robot to move 0.3 m")
    time.sleep(0.5)
    after = page.screenshot()
    box = page.canvas.bounding_box()
    for x, y in (start, probe.truth[-1]):
        u, v = page.pixel(x, y, camera)
        u, v = int(u - box["x"]), int(v - box["y"])
        window = (slice(max(v - 25, 0), v + 25), slice(max(u - 25, 0), u + 25))
        changed = np.abs(before[window].astype(int) - after[window].astype(int)).sum(axis=2) > 60
        assert changed.sum() > 50, f"the drawing around ({x:.2f}, {y:.2f}) did not change as the robot moved"


def test_pause_stops_the_clock_and_resume_restarts_it(page, navigation):
    clocks = navigation.probe.clocks
    page.button("Pause").click()
    page.reply("/simulator: paused at")
    time.sleep(0.5)  # what was in flight
    count = len(clocks)
    time.sleep(1.5)
    assert len(clocks) == count, "no /clock while paused"
    page.button("Resume").click()
    page.reply("/simulator: running from")
    wait_for(lambda: len(clocks) > count + 5, what="/clock to run again")


def test_step_advances_exactly_one_step(page, navigation):
    clocks = navigation.probe.clocks
    page.button("Pause").click()
    page.reply("/simulator: paused at")
    time.sleep(0.5)
    for expected in (1, 2):
        count, last = len(clocks), clocks[-1]
        page.button("Step").click()
        wait_for(lambda: len(clocks) > count, what="one /clock after Step")
        time.sleep(1.0)
        assert len(clocks) == count + 1, f"step {expected}: exactly one /clock, got {clocks[count:]}"
        assert clocks[-1] == pytest.approx(last + DT, abs=1e-9)
    page.button("Resume").click()
    page.reply("/simulator: running from")


def test_a_click_on_the_floor_sends_that_point_as_the_goal(page, navigation):
    probe = navigation.probe
    page.toggle_folder("View")
    page.button("Top view").click()
    time.sleep(0.5)
    camera = camera_of(navigation, page)
    grid = probe.map
    info = grid.info
    cells = np.array(grid.data).reshape(info.height, info.width)
    free = np.argwhere(cells == 0)
    box = page.canvas.bounding_box()
    # a free cell left of the panel and below the notification corner: the click must reach the canvas
    for row, col in free[np.random.default_rng(0).permutation(len(free))]:
        x = info.origin.position.x + (col + 0.5) * info.resolution
        y = info.origin.position.y + (row + 0.5) * info.resolution
        u, v = page.pixel(x, y, camera)
        if box["x"] + 0.15 * box["width"] < u < box["x"] + 0.6 * box["width"] and v > box["y"] + 0.3 * box["height"]:
            break
    count = len(probe.goals)
    page.page.mouse.click(u, v)
    wait_for(lambda: len(probe.goals) > count, what="/goal_pose")
    goal = probe.goals[-1]
    assert goal.header.frame_id == "map"
    error = math.hypot(goal.pose.position.x - x, goal.pose.position.y - y)
    assert error < 0.05, f"goal ({goal.pose.position.x:.3f}, {goal.pose.position.y:.3f}) is {error:.3f} m from the " \
                         f"clicked ({x:.3f}, {y:.3f})"


def test_a_slider_sets_a_live_parameter(page, navigation):
    page.toggle_folder("Parameters")
    page.choose("Node", "/wall_follower")
    label = page.page.locator("label").filter(has_text=re.compile(r"^kp$"))
    label.wait_for()
    slider = page.page.locator(f'[id="{label.get_attribute("for")}"]')  # a div: not found by get_by_label
    slider.scroll_into_view_if_needed()
    thumb = slider.get_by_role("slider")
    maximum = float(thumb.get_attribute("aria-valuemax"))
    minimum = float(thumb.get_attribute("aria-valuemin"))
    box = slider.bounding_box()
    page.page.mouse.click(box["x"] + 0.12 * box["width"], box["y"] + box["height"] / 2)
    wait_for(lambda: abs(float(thumb.get_attribute("aria-valuenow")) - 4.0) > 1.0, what="the slider to move")
    shown = float(thumb.get_attribute("aria-valuenow"))
    assert minimum < shown < maximum
    page.reply(f"/wall_follower: kp = {shown!r}")
    assert navigation.probe.parameter("/wall_follower", "kp") == pytest.approx(shown)


def test_the_view_after_the_robot_localized_shows_the_path(page, navigation, tmp_path):
    probe = navigation.probe
    wait_for(lambda: probe.paths, 60.0, "a /path (the robot localized)")
    page.toggle_folder("View")  # folded again, and the parameters: the scene free of the panel
    page.toggle_folder("Parameters")
    page.page.add_style_tag(content=".mantine-Notification-root { display: none; }")  # "software WebGL" notice
    time.sleep(1.0)
    shot = tmp_path / "viewer.png"
    page.page.screenshot(path=str(shot), timeout=120000)
    wanted = os.environ.get("AMR_VIEWER_SCREENSHOT")
    if wanted:
        shutil.copy(shot, wanted)
    image = page.screenshot()
    blue = (np.abs(image.astype(int) - (30, 110, 255)).sum(axis=2) < 60).sum()
    assert blue > 30, "the path is drawn"
    assert page.failed == [] and page.errors == [], "no failed request and no console error all along"


def test_the_arm_view_moves_after_an_ik_request(playwright, tmp_path):
    stack = Stack("ik_service", tmp_path)
    browser = None
    try:
        browser = Browser(playwright, stack.url)
        browser.reply("arms of /ik_service")
        browser.toggle_folder("View")
        browser.button("Arms view").click()  # whatever else the domain holds, the camera on the arms
        client = stack.probe.create_client(SolveIK, "/solve_ik")
        wait_for(client.service_is_ready, what="/solve_ik")
        wait_for(lambda: stack.probe.count_subscribers("/ik_service/joint_states") > 0, what="the viewer's arms")
        time.sleep(1.5)  # the subscription matched, the arms view drawn
        before = browser.screenshot()
        width = before.shape[1]
        scene = (slice(None), slice(0, int(0.6 * width)))  # left of the panel, whose status text changes too

        def changed_pixels(image) -> int:
            return int((np.abs(before[scene].astype(int) - image[scene].astype(int)).sum(axis=2) > 60).sum())

        time.sleep(1.0)
        assert changed_pixels(browser.screenshot()) < 5, "the scene is still before a solution"
        changed = 0
        for x, y in ((0.05, 0.35), (3.0, 1.0), (-1.0, 3.0)):  # again if a solution went out before the match
            request = SolveIK.Request(chain="rr2")
            request.target.position.x, request.target.position.y = x, y
            future = client.call_async(request)
            wait_for(future.done, what="the IK answer")
            assert future.result().success, future.result().message
            time.sleep(1.5)
            changed = changed_pixels(browser.screenshot())
            if changed > 30:
                break
        assert changed > 30, "the arm drawing did not move"
        assert browser.failed == [] and browser.errors == []
    finally:
        if browser is not None:
            browser.close()
        stack.stop()
