"""The viewer in a real browser: Playwright drives Debian's chromium (headless, offline) against running stacks.

`amr-bringup maze_navigation --composed --view` (one stack for the module), `amr-bringup fleet_navigation
--composed --view` (four robots), `amr-bringup maze_mapping --composed --view` (SLAM) and `amr-bringup ik_service
--view`; a probe node in this process watches /clock,
the ground truths, /goal_pose and the nodes' parameters. Every wait polls for what it waits for (a drawing waits
until two screenshots agree). Without /usr/bin/chromium (AMR_CHROMIUM names another) or playwright the whole module
is skipped with one line saying how to install it.
AMR_VIEWER_SCREENSHOT=docs/viewer.png, AMR_VIEWER_FLEET_SCREENSHOT=docs/viewer_fleet.png and
AMR_VIEWER_MAPPING_SCREENSHOT=docs/viewer_mapping.png keep the screenshots of the one-robot, the fleet and the
mapping views there (the mapping one after the first loop closure).
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import itertools
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
import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.msg import Path as PathMessage
from rclpy.node import Node
from rclpy.parameter_client import AsyncParameterClient
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger
from support.ros import fresh_domain
from support.waiting import poll_until

from amr_interfaces.msg import Frontiers, PoseGraph
from amr_interfaces.srv import SolveIK
from amr_util.environment import child_environment
from amr_util.lean_executor import LeanExecutor
from amr_util.qos import LATCHED, reliable
from amr_viewer.geometry import free_share, top_down_camera
from amr_viewer.messages import occupancy_grid
from amr_viewer.parameters import value_of
from amr_viewer.scene import COLORS, ROBOT_COLORS

CHROMIUM = Path(os.environ.get("AMR_CHROMIUM", "/usr/bin/chromium"))
if not CHROMIUM.exists():
    pytest.skip(f"browser tests: no {CHROMIUM} (install it: apt-get install chromium)", allow_module_level=True)
playwright_api = pytest.importorskip(
    "playwright.sync_api", reason="browser tests: no playwright (pip install -e '.[test]')"
)

ARGS = [
    "--enable-unsafe-swiftshader",
    "--no-sandbox",
    "--disable-background-networking",
    "--disable-dev-shm-usage",
    "--disable-gpu-sandbox",
    "--mute-audio",
    "--no-first-run",
    "--disable-gpu-watchdog",  # a GPU process slow under load is not killed (its page would lose WebGL)
]
VIEWPORT = {"width": 1024, "height": 640}
FLEET_VIEWPORT = {"width": 1400, "height": 900}
FLEET = ("r1", "r2", "r3", "r4")
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
    if not poll_until(condition, timeout, period=0.05):
        raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def quiet(values: list, period: float, timeout: float = WAIT, what: str = "quiet") -> None:
    """Wait until `values` (a list a subscription appends to) has not grown for `period` s."""
    deadline = time.monotonic() + timeout
    count, since = len(values), time.monotonic()
    while time.monotonic() < deadline:
        if len(values) != count:
            count, since = len(values), time.monotonic()
        elif time.monotonic() - since >= period:
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}: {len(values)} messages")


class Probe(Node):
    def __init__(self, context, robots: tuple[str, ...] = (), mapping: bool = False) -> None:
        super().__init__("viewer_test_probe", context=context)
        self.graphs: list[PoseGraph] = []
        self.frontiers: list[Frontiers] = []
        if mapping:  # amr_mapping's slam and explorer
            self.create_subscription(PoseGraph, "/slam/graph", self.graphs.append, reliable(10))
            self.create_subscription(Frontiers, "/explorer/frontiers", self.frontiers.append, reliable(10))
        self.fleet: dict[str, list[tuple[float, float]]] = {robot: [] for robot in robots}
        for robot in robots:
            poses = self.fleet[robot]
            self.create_subscription(
                Odometry,
                f"/{robot}/ground_truth",
                lambda m, poses=poses: poses.append((m.pose.pose.position.x, m.pose.pose.position.y)),
                reliable(100),
            )
        self.clocks: list[float] = []
        self.truth: list[tuple[float, float]] = []
        self.goals: list[PoseStamped] = []
        self.paths: list[PathMessage] = []
        self.map: OccupancyGrid | None = None
        self.create_subscription(
            Clock, "/clock", lambda m: self.clocks.append(m.clock.sec + m.clock.nanosec * 1e-9), reliable(1000)
        )
        if not robots:  # a fleet's root has no ground truth (a subscription would make it a robot for the viewer)
            self.create_subscription(
                Odometry,
                "/ground_truth",
                lambda m: self.truth.append((m.pose.pose.position.x, m.pose.pose.position.y)),
                reliable(100),
            )
        self.create_subscription(PoseStamped, "/goal_pose", self.goals.append, reliable(10))
        self.create_subscription(PathMessage, "/path", self.paths.append, LATCHED)
        self.create_subscription(OccupancyGrid, "/map", lambda m: setattr(self, "map", m), LATCHED)
        self._parameter_clients: dict[str, AsyncParameterClient] = {}

    def pause_simulator(self) -> None:
        """/simulator/pause called from here, as the page's Pause calls it (the page's own is tested below)."""
        client = self.create_client(Trigger, "/simulator/pause")
        wait_for(client.service_is_ready, what="/simulator/pause")
        future = client.call_async(Trigger.Request())
        wait_for(future.done, what="the answer of /simulator/pause")
        assert future.result().success, future.result().message
        self.destroy_client(client)

    def parameter(self, node: str, name: str):
        client = self._parameter_clients.setdefault(node, AsyncParameterClient(self, node))
        wait_for(client.services_are_ready, what=f"{node}'s parameter services")
        future = client.get_parameters([name])
        wait_for(future.done, what=f"{node}.{name}")
        return value_of(future.result().values[0])


class Stack:
    """amr-bringup <stack> --view in a domain of its own, and a probe spinning on a thread.

    Up means every node active and the stack's own viewer serving its port (its log says it bound it: a free port
    picked here can be taken by another process before the viewer binds it, and then the page would be another
    server's). A stack that does not come up is stopped, never left running (it would load the machine and share
    its domain with a later test).
    """

    ATTEMPTS = 3
    """startups tried when the viewer lost its port to another process"""

    def __init__(self, name: str, tmp: Path, *extra: str, robots: tuple[str, ...] = (), mapping: bool = False) -> None:
        self.domain = fresh_domain()
        self.log = tmp / f"{name}.log"
        self.process = None
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=self.domain)
        self.probe = Probe(self.context, robots, mapping)
        self.executor = LeanExecutor(context=self.context)
        self.executor.add_node(self.probe)
        self._spinner = threading.Thread(target=self._spin, daemon=True)
        self._spinner.start()
        try:
            for attempt in range(self.ATTEMPTS):
                self._start(name, extra)
                wait_for(
                    lambda: self.up() or self.process.poll() is not None or self.viewer_failed(),
                    STARTUP,
                    f"{name} and its viewer to come up",
                )
                if self.up() or not self.viewer_failed() or attempt == self.ATTEMPTS - 1:
                    break
                self._stop_process()  # the port was taken before the viewer bound it: another one
            assert self.up(), self.output()
        except BaseException:
            self.stop()
            raise

    def _start(self, name: str, extra: tuple[str, ...]) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        env = child_environment(ROS_DOMAIN_ID=str(self.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        self.process = subprocess.Popen(
            [sys.executable, "-m", "amr_bringup.bringup", name, "--view", "--view-port", str(self.port), *extra],
            env=env,
            stdout=self.log.open("w"),
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )

    def up(self) -> bool:
        output = self.output()
        return (
            self.process.poll() is None
            and "all nodes active" in output
            and f": viewer at {self.url} (no authentication" in output
            and serving(self.port)
        )

    def viewer_failed(self) -> bool:
        """The port was taken: before amr-bringup started (it refuses the port) or before the viewer bound it."""
        output = self.output()
        return "the viewer (pid" in output or "--view: cannot serve on" in output

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # the context shut down under it
            pass

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def _stop_process(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(20.0)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()

    def stop(self) -> None:
        self._stop_process()
        self.executor.shutdown()
        self.probe.destroy_node()
        self.context.try_shutdown()


WEBGL_WATCH = "window.__webglLost = 0; addEventListener('webglcontextlost', () => window.__webglLost++, true);"
"""Counts the page's WebGL contexts lost (the event does not bubble: caught on its way down)."""
FRAME_PERIOD_MS = 250
FRAME_CAP = (
    "(() => { const native = window.requestAnimationFrame.bind(window); let last = -Infinity, open = null;"
    " const due = (now) => { if (now === open) return true;"
    f" if (now - last >= {FRAME_PERIOD_MS}) {{ last = now; open = now; window.__frames = (window.__frames || 0) + 1;"
    " return true; } return false; };"
    " window.requestAnimationFrame = (callback) => native(function frame(now) {"
    " if (due(now)) callback(now); else native(frame); }); })();"
)
"""The page draws at most every FRAME_PERIOD_MS: its render loop runs on the native frames, every callback of one
frame together, and skips the frames between. Headless chromium renders WebGL on the CPU (SwiftShader), at every
frame it is offered: uncapped, the GPU process took more CPU than the stack it shows. A frame of the navigation
stack's page costs the GPU process about 75 ms of CPU at 1024 x 640 whatever is drawn (800 x 500 the same; the
particles and scan hidden or the shadows off: within 10 %): a page on a running simulator took 0.77 of a core at
100 ms, 0.31 at 250 ms (2026-11-30). What the page does per frame (apply the server's messages, draw) is unchanged;
it does it four times a second."""
WEBGL_AVAILABLE = (
    "(() => { const canvas = document.createElement('canvas');"
    " return !!(canvas.getContext('webgl2') || canvas.getContext('webgl')); })()"
)


class Browser:
    """One headless chromium page on the viewer, with every failed request and console error kept.

    The page is ready when it shows its controls (the Pause button). viser's page applies what the server sends, its
    controls too, in its WebGL render loop: a page without WebGL connects and receives them but never draws them. So
    a page without WebGL fails at once, and a page that does not draw its controls in STARTUP s fails saying what it
    saw (WebGL, contexts lost, its websockets, its last console messages)."""

    RELOAD_AFTER = 10.0
    """s a page that has received nothing while its websockets keep closing is given before it is loaded again"""

    def __init__(self, playwright, url: str, viewport: dict = VIEWPORT, extra_args: tuple[str, ...] = ()) -> None:
        self.browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=[*ARGS, *extra_args]
        )
        self.page = self.browser.new_page(viewport=viewport)
        self.page.set_default_timeout(WAIT * 1000)
        self.failed: list[str] = []
        self.errors: list[str] = []
        self.console: list[str] = []
        self.sockets: list[str] = []
        self.page.on("requestfailed", lambda request: self.failed.append(f"{request.url}: {request.failure}"))
        self.page.on("console", lambda message: message.type == "error" and self.errors.append(message.text))
        self.page.on("console", lambda message: self.console.append(f"{message.type}: {message.text}"))
        self.page.on("pageerror", lambda error: self.errors.append(str(error)))
        self.page.on("websocket", self._watch)
        self.page.add_init_script(WEBGL_WATCH)
        self.page.add_init_script(FRAME_CAP)
        try:
            self.page.goto(url, timeout=STARTUP * 1000)
            self._wait_for_controls()
        except BaseException:
            self.browser.close()
            raise
        self.canvas = self.page.locator("canvas").first

    def _watch(self, socket) -> None:
        """Each websocket of the page: created, its first frame received, closed."""
        self.sockets.append("created")
        socket.on("framereceived", lambda _: self.sockets[-1:] != ["received"] and self.sockets.append("received"))
        socket.on("close", lambda _: self.sockets.append("closed"))

    def _wait_for_controls(self) -> None:
        """Until the page shows its Pause button. Without WebGL it never will (see the class): said at once. viser's
        page retries a failed first connection every second, each retry closing the one in flight: a server whose
        handshake takes more than 1 s (a loaded machine) is then never reached. A page that has received nothing
        while its websockets keep closing is loaded again (the first attempt of a new page waits 5 s)."""
        start = since = time.monotonic()
        webgl, reloads = self.page.evaluate(WEBGL_AVAILABLE), 0
        pause = self.button("Pause")
        while webgl and time.monotonic() - start < STARTUP:
            try:
                pause.wait_for(timeout=2000)
                return
            except playwright_api.TimeoutError:
                pass
            if (
                "received" not in self.sockets
                and self.sockets.count("closed") >= 3
                and time.monotonic() - since > self.RELOAD_AFTER
                and reloads < 2
            ):
                self.sockets.append("page loaded again")
                self.page.reload(timeout=STARTUP * 1000)
                since, reloads = time.monotonic(), reloads + 1
        raise AssertionError(
            f"the page drew no controls in {time.monotonic() - start:.0f} s: WebGL "
            f"{'available' if webgl else 'unavailable'}, {self.page.evaluate('window.__webglLost')} WebGL contexts "
            f"lost, websockets: {', '.join(self.sockets) or 'none'}; last console messages: {self.console[-8:]}"
        )

    def button(self, label: str):
        return self.page.get_by_role("button", name=label, exact=True)

    def reply(self, text: str | re.Pattern) -> None:
        """Until the page shows `text`; else fails saying what the page showed (its panels' text), its frames and
        WebGL contexts lost and its websockets: whether the viewer's answer never came or the page stopped applying
        what the viewer sent (a run on a slowing machine once waited for eight answers in vain, cause not found)."""
        try:
            self.page.get_by_text(text).first.wait_for()
        except playwright_api.TimeoutError:
            shown = " | ".join(self.page.inner_text("body", timeout=10000).split("\n"))
            raise AssertionError(
                f"the page did not show {text!r} in {WAIT:g} s; it showed: {shown[-1500:]}; frames drawn "
                f"{self.page.evaluate('window.__frames || 0')}, WebGL contexts lost "
                f"{self.page.evaluate('window.__webglLost')}, websockets: {', '.join(self.sockets[-6:]) or 'none'}"
            ) from None

    def choose(self, label: str, option: str) -> None:
        self.page.get_by_label(label, exact=True).click()
        self.page.get_by_role("option", name=option, exact=True).click()

    def toggle_folder(self, title: str) -> None:
        self.page.get_by_text(title, exact=True).first.click()

    def set_checked(self, label: str, value: bool) -> None:
        """The panel's checkbox `label` to `value`: clicked, then looked at until the page shows it. A viewer
        checkbox shows the viewer's state, so the click's answer comes back from the viewer (late on a loaded
        machine: Playwright's own check() gives up at once); a click the page lost while redrawing the panel is
        made again."""
        box = self.page.get_by_label(label)
        for _ in range(3):
            if box.is_checked() == value:
                return
            box.click()
            if poll_until(lambda: box.is_checked() == value, 15.0):
                return
        raise AssertionError(f"the checkbox {label!r} did not become {value}")

    def screenshot(self) -> np.ndarray:
        """The canvas as an (H, W, 3) array (the panels over it included)."""
        from PIL import Image

        return np.asarray(Image.open(io.BytesIO(self.canvas.screenshot(timeout=120000))).convert("RGB"))

    def settled(self, timeout: float = WAIT, region=None, still: float = 1.0) -> np.ndarray:
        """The canvas once the screenshots have agreed for `still` s (in `region`, by default the scene left of the
        panel, but for a few pixels): what is drawn has reached the page. Two shots 0.2 s apart were not enough on
        a loaded machine: the viewer's updates came further apart than that, and a frame behind was taken."""
        last = self.screenshot()
        if region is None:
            region = (slice(None), slice(0, int(free_share(last.shape[1]) * last.shape[1])))
        deadline = time.monotonic() + timeout
        since = time.monotonic()
        while time.monotonic() < deadline:
            time.sleep(0.2)
            shot = self.screenshot()
            if (np.abs(shot[region].astype(int) - last[region].astype(int)).sum(axis=2) > 60).sum() >= 5:
                last, since = shot, time.monotonic()
            elif time.monotonic() - since >= still:
                return shot
        raise AssertionError(f"the drawing did not settle in {timeout} s")

    def hide_notifications(self) -> None:
        """The "software WebGL" notice off the scene."""
        self.page.add_style_tag(content=".mantine-Notification-root { display: none; }")

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
    """The camera the viewer sets (amr_viewer.geometry.top_down_camera over the map, the canvas's aspect, the share
    of the canvas left of the control panel)."""
    wait_for(lambda: stack.probe.map is not None, what="/map")
    box = page.canvas.bounding_box()
    return top_down_camera(
        occupancy_grid(stack.probe.map).bounds, box["width"] / box["height"], free=free_share(box["width"])
    )


@pytest.fixture
def panels_only():
    """The viewer's page without ROS: a viser server with the viewer's panels only."""
    import viser

    from amr_viewer.panels import Panels

    with contextlib.redirect_stdout(io.StringIO()):  # viser's banner
        server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    Panels(server, actions=None)
    yield f"http://127.0.0.1:{server.get_port()}"
    server.stop()


def test_a_page_without_webgl_says_so_at_once_instead_of_waiting_for_its_controls(playwright, panels_only):
    """viser's page draws the controls it is sent in its WebGL render loop: without WebGL it connects, receives them
    and never draws them (the "page never drew its controls" of a loaded run). The wait says so at once."""
    Browser(playwright, panels_only).close()  # with WebGL: the controls
    start = time.monotonic()
    with pytest.raises(AssertionError, match=r"drew no controls in \d+ s: WebGL unavailable"):
        Browser(playwright, panels_only, extra_args=("--disable-webgl",))
    assert time.monotonic() - start < STARTUP / 3, "said at once, not after STARTUP"


class SlowHandshakes:
    """A TCP proxy to `port` that holds each websocket request: the first `first` s, the others `later` s."""

    def __init__(self, port: int, first: float, later: float) -> None:
        self.target, self.delays, self.requests = port, (first, later), 0
        self._ready = threading.Event()
        threading.Thread(target=asyncio.run, args=(self._serve(),), daemon=True).start()
        self._ready.wait(10.0)

    async def _serve(self) -> None:
        self._server = await asyncio.start_server(self._handle, "127.0.0.1", 0)
        self._loop = asyncio.get_running_loop()
        self.port = self._server.sockets[0].getsockname()[1]
        self._ready.set()
        with contextlib.suppress(asyncio.CancelledError):
            await self._server.serve_forever()

    def close(self) -> None:
        self._loop.call_soon_threadsafe(self._server.close)

    async def _handle(self, reader, writer) -> None:
        head = await reader.read(65536)
        if b"upgrade: websocket" in head.lower():
            self.requests += 1
            await asyncio.sleep(self.delays[self.requests > 1])
        upstream_reader, upstream_writer = await asyncio.open_connection("127.0.0.1", self.target)
        upstream_writer.write(head)
        await asyncio.gather(self._pipe(reader, upstream_writer), self._pipe(upstream_reader, writer))

    @staticmethod
    async def _pipe(reader, writer) -> None:
        with contextlib.suppress(OSError):
            while data := await reader.read(65536):
                writer.write(data)
                await writer.drain()
        writer.close()


def test_a_page_whose_first_connection_failed_reaches_a_server_with_slow_handshakes(
    playwright, panels_only, monkeypatch
):
    """viser's page retries a failed first websocket every second, each retry closing the one in flight: with every
    handshake taking 1.5 s it never connects. The wait loads such a page again (its first attempt waits 5 s)."""
    monkeypatch.setattr(Browser, "RELOAD_AFTER", 3.0)
    port = int(panels_only.rpartition(":")[2])
    proxy = SlowHandshakes(port, first=6.0, later=1.5)  # the first attempt times out (5 s), every later one is slow
    try:
        browser = Browser(playwright, f"http://127.0.0.1:{proxy.port}")
        browser.close()
    finally:
        proxy.close()
    assert "page loaded again" in browser.sockets, browser.sockets
    assert browser.failed == [] and browser.errors == []


# The stacks of their own first: the maze_navigation stack of the module's page runs from its first test to the end.


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
        width = browser.screenshot().shape[1]
        scene = (slice(None), slice(0, int(0.6 * width)))  # left of the panel, whose status text changes too
        before = browser.settled(region=scene)  # the arms view drawn, still before a solution

        def changed_pixels() -> int:
            image = browser.screenshot()
            return int((np.abs(before[scene].astype(int) - image[scene].astype(int)).sum(axis=2) > 60).sum())

        for x, y in ((0.05, 0.35), (3.0, 1.0), (-1.0, 3.0)):  # again if a solution went out before the match
            request = SolveIK.Request(chain="rr2")
            request.target.position.x, request.target.position.y = x, y
            future = client.call_async(request)
            wait_for(future.done, what="the IK answer")
            assert future.result().success, future.result().message
            try:
                wait_for(lambda: changed_pixels() > 30, 10.0, "the arm drawing to move")
                break
            except AssertionError:
                continue
        assert changed_pixels() > 30, "the arm drawing did not move"
        assert browser.failed == [] and browser.errors == []
    finally:
        if browser is not None:
            browser.close()
        stack.stop()


def near(image: np.ndarray, center: tuple[float, float], radius: float, beyond: float = 0.0) -> np.ndarray:
    """The (N, 3) pixels of `image` within `radius` px of `center` (and further than `beyond`)."""
    height, width = image.shape[:2]
    rows, cols = np.ogrid[:height, :width]
    distance = (rows - center[1]) ** 2 + (cols - center[0]) ** 2
    return image[(distance <= radius**2) & (distance >= beyond**2)].astype(int)


def test_a_fleet_shows_each_robot_in_its_colour_with_its_name_left_of_the_panel(playwright, tmp_path):
    """fleet_navigation on fleets/crossing.yaml (four robots, each with its particle filter) at 1400 x 900. The page
    is opened once the robots have moved and the simulator is paused: the viewer keeps the trails and sends a new
    page the scene as it is (neither the four filters nor the page's drawing run while nothing is checked)."""
    stack = Stack("fleet_navigation", tmp_path, "--composed", "-p", "simulator.pace:=1.0", robots=FLEET)
    browser = None
    try:
        probe, truth = stack.probe, stack.probe.fleet
        wait_for(lambda: all(truth[robot] for robot in FLEET), what="every robot's ground truth")
        starts = {robot: truth[robot][0] for robot in FLEET}
        wait_for(  # a trail that leaves the disc (radius 0.105 m) inside the 0.4 m the check below looks within
            lambda: all(math.dist(truth[robot][-1], starts[robot]) > 0.35 for robot in FLEET),
            STARTUP,
            "every robot to move 0.35 m",
        )
        probe.pause_simulator()
        quiet(probe.clocks, 0.5, what="/clock to stop after the pause")
        for robot in FLEET:
            quiet(truth[robot], 0.3, what=f"{robot} to stop")
        browser = Browser(playwright, stack.url, FLEET_VIEWPORT)
        for robot in FLEET:  # the node table: a row per namespace
            browser.page.get_by_role("cell", name=f"/{robot}", exact=True).wait_for()
        browser.reply("from the true ring")  # the disc's distance from the ring, said
        browser.hide_notifications()
        browser.toggle_folder("View")
        for layer in ("particles", "scan"):  # not checked here: with them a frame took some 2 s of software WebGL
            browser.set_checked(f"Show {layer}", False)
        browser.toggle_folder("View")  # folded again: the status panel in the picture
        camera = camera_of(stack, browser)
        shown = browser.settled()
        shot = tmp_path / "viewer_fleet.png"
        browser.page.screenshot(path=str(shot), timeout=120000)
        wanted = os.environ.get("AMR_VIEWER_FLEET_SCREENSHOT")
        if wanted:
            shutil.copy(shot, wanted)

        box = browser.canvas.bounding_box()
        panel = browser.page.locator('[data-testid="floating-panel"]').bounding_box()
        xmin, ymin, xmax, ymax = occupancy_grid(probe.map).bounds
        right = browser.pixel(xmax, ymax, camera)[0]
        left = browser.pixel(xmin, ymin, camera)[0]
        assert box["x"] < left and right < panel["x"], (
            f"the map ({left:.0f}-{right:.0f} px) left of the panel ({panel['x']:.0f} px)"
        )
        scale = browser.pixel(1.0, 0.0, camera)[0] - browser.pixel(0.0, 0.0, camera)[0]  # px per m
        labels, discs = {}, {}
        for index, robot in enumerate(FLEET):
            u, v = browser.pixel(*truth[robot][-1], camera)
            center = (u - box["x"], v - box["y"])
            discs[robot] = np.median(near(shown, center, 0.06 * scale), axis=0)  # the lit disc, its heading aside
            around = near(shown, center, 0.4 * scale, beyond=0.15 * scale)  # the disc (0.105 m) is in its colour too
            trail = (np.abs(around - ROBOT_COLORS[index]).sum(axis=1) < 40).sum()
            assert trail > 20, f"{robot}'s trail in its colour {ROBOT_COLORS[index]} leads to it ({trail} pixels)"
            labels[robot] = (center[0], center[1] - 0.25 * scale)
        for first, second in itertools.combinations(FLEET, 2):
            difference = np.abs(discs[first] - discs[second]).sum()
            assert difference > 60, f"{first} {discs[first]} and {second} {discs[second]}: not told apart"
        browser.toggle_folder("View")
        browser.set_checked("Show labels", False)
        unlabelled = browser.settled()
        for robot, (u, v) in labels.items():  # the label above each robot went with the checkbox
            window = (
                slice(max(int(v - 0.2 * scale), 0), int(v + 0.2 * scale)),
                slice(max(int(u - 0.3 * scale), 0), int(u + 0.3 * scale)),
            )
            changed = (np.abs(shown[window].astype(int) - unlabelled[window].astype(int)).sum(axis=2) > 60).sum()
            assert changed > 20, f"{robot}'s name label above it ({changed} pixels changed when hidden)"
        assert browser.failed == [] and browser.errors == []
    finally:
        if browser is not None:
            browser.close()
        stack.stop()


def colored(image: np.ndarray, color: tuple[int, int, int], tolerance: int = 60) -> int:
    """Pixels of `image` within `tolerance` (summed over R, G, B) of `color`."""
    return int((np.abs(image.astype(int) - color).sum(axis=2) < tolerance).sum())


def test_a_mapping_run_shows_the_growing_map_its_pose_graph_and_the_frontiers(playwright, tmp_path):
    """maze_mapping (slam, explorer) on inner_maze: the map slam has made so far, its graph and the frontiers; each
    layer goes with its checkbox. The page is opened once there is a graph and frontiers, the simulator paused (by
    its service): the viewer sends a new page the scene as it is, and nothing runs while nothing is checked."""
    stack = Stack("maze_mapping", tmp_path, "--composed", "-p", "simulator.pace:=2.0", mapping=True)
    browser = None
    wanted = os.environ.get("AMR_VIEWER_MAPPING_SCREENSHOT")
    try:
        probe = stack.probe
        wait_for(
            lambda: (
                len(probe.graphs) > 2
                and len(probe.graphs[-1].poses) >= 14
                and any(f.chosen >= 0 and len(f.centroids) > 1 for f in probe.frontiers)
            ),
            STARTUP,
            "a graph of 14 nodes and frontiers with one chosen",
        )
        if wanted:  # the docs' picture: after the first loop closure
            wait_for(lambda: any(probe.graphs[-1].loop_closure), 600.0, "a loop closure")
        probe.pause_simulator()
        quiet(probe.clocks, 0.5, what="/clock to stop after the pause")
        # slam sends a change no scan carried out after map_publish_period of wall time (1 s): the map is still then
        quiet(probe.graphs, 2.5, what="slam's last map and graph after the pause")
        browser = Browser(playwright, stack.url)
        browser.reply(re.compile(r"graph \d+ nodes, \d+ edges, \d+ loop closures"))  # the status panel says it
        browser.reply(re.compile(r"explorer \w+: \d+ frontiers"))
        browser.hide_notifications()
        for folder in ("Simulation", "Click on the floor"):  # folded: the status panel in the picture
            browser.toggle_folder(folder)
        browser.page.mouse.move(0, 0)
        shown = browser.settled()
        browser.toggle_folder("View")
        browser.button("Top view").click()  # the camera over the map as it is now: where the view followed it
        browser.toggle_folder("View")
        browser.page.mouse.move(0, 0)
        refitted = browser.settled()
        region = (slice(None), slice(0, int(free_share(shown.shape[1]) * shown.shape[1])))
        moved = (np.abs(shown[region].astype(int) - refitted[region].astype(int)).sum(axis=2) > 60).sum()
        assert moved < 0.002 * shown[region].shape[0] * shown[region].shape[1], (
            f"the top view follows the map as it grows ({moved} pixels changed by Top view)"
        )
        shot = tmp_path / "viewer_mapping.png"
        browser.page.screenshot(path=str(shot), timeout=120000)
        if wanted:
            shutil.copy(shot, wanted)
        for folder in ("Simulation", "Click on the floor"):
            browser.toggle_folder(folder)
        scene = shown[:, : int(free_share(shown.shape[1]) * shown.shape[1])]
        counts = {
            layer: colored(scene, COLORS[layer])
            for layer in ("graph_edges", "graph_nodes", "frontiers", "chosen_frontier")
        }
        nodes = len(probe.graphs[-1].poses)  # paused: the graph drawn
        assert counts["graph_edges"] + counts["graph_nodes"] > 3 * nodes, f"the pose graph's {nodes} nodes: {counts}"
        last = probe.frontiers[-1]  # paused: the one drawn
        assert counts["frontiers"] > 20 * min(len(last.centroids), 1), f"the frontiers are drawn: {counts}"
        assert counts["chosen_frontier"] > 5 * (last.chosen >= 0), f"the chosen one is ringed: {counts}"
        free, unknown = colored(scene, (250, 250, 250), 15), colored(scene, (200, 200, 200), 15)
        assert free > 1000 and unknown > 1000, f"the map: {free} free and {unknown} unknown pixels"
        browser.toggle_folder("View")
        for layer, colors in (("graph", ("graph_edges", "graph_nodes")), ("frontiers", ("frontiers",))):
            browser.set_checked(f"Show {layer}", False)
            hidden = browser.settled()[:, : scene.shape[1]]
            left = sum(colored(hidden, COLORS[color]) for color in colors)
            assert left <= 0.2 * sum(counts[color] for color in colors), f"{layer} hidden: {left} pixels left"
            browser.set_checked(f"Show {layer}", True)
        assert browser.failed == [] and browser.errors == []
    finally:
        if browser is not None:
            browser.close()
        stack.stop()


def test_the_page_loads_offline_with_no_failed_request_and_no_console_error(page, navigation):
    assert page.failed == [] and page.errors == []
    page.page.get_by_role("cell", name=re.compile(r"^active: .*\bsimulator\b")).wait_for()  # the node table


def test_the_pace_control_sets_the_simulators_pace(page, navigation):
    page.choose("Pace", "1x real time")
    page.reply("/simulator: pace = 1.0")
    assert navigation.probe.parameter("/simulator", "pace") == 1.0


def pause(page: Browser, probe: Probe) -> None:
    """Pause the simulator and wait until its last messages are in: nothing moves until resume()."""
    page.button("Pause").click()
    page.reply("/simulator: paused at")
    quiet(probe.clocks, 0.5, what="/clock to stop after Pause")


def resume(page: Browser) -> None:
    page.button("Resume").click()
    page.reply("/simulator: running from")


def test_the_scene_is_drawn_and_follows_the_robot(page, navigation):
    """The robot is reset while the simulator is paused, so its whole route is ahead of it when the page is first
    looked at (reset while running, the pause's answer came some 8 simulated seconds later on a loaded machine, the
    robot at its goal already, 1.6 m on, and it never moved 0.3 m again)."""
    probe = navigation.probe
    camera = camera_of(navigation, page)
    wait_for(lambda: len(probe.truth) > 2, what="/ground_truth")
    pause(page, probe)
    seen = len(probe.truth)
    page.button("Reset").click()
    page.reply("/simulator: reset")
    wait_for(lambda: len(probe.truth) > seen, what="/ground_truth after the reset")
    before, start = page.settled(), probe.truth[-1]
    assert len(np.unique(before.reshape(-1, 3), axis=0)) > 20, "not a blank canvas"
    resume(page)
    wait_for(lambda: math.dist(probe.truth[-1], start) > 0.3, what="the robot to move 0.3 m")
    pause(page, probe)
    after, end = page.settled(), probe.truth[-1]
    resume(page)
    box = page.canvas.bounding_box()
    for x, y in (start, end):
        u, v = page.pixel(x, y, camera)
        u, v = int(u - box["x"]), int(v - box["y"])
        window = (slice(max(v - 25, 0), v + 25), slice(max(u - 25, 0), u + 25))
        changed = np.abs(before[window].astype(int) - after[window].astype(int)).sum(axis=2) > 60
        assert changed.sum() > 50, f"the drawing around ({x:.2f}, {y:.2f}) did not change as the robot moved"


def test_pause_stops_the_clock_and_resume_restarts_it(page, navigation):
    clocks = navigation.probe.clocks
    page.button("Pause").click()
    page.reply("/simulator: paused at")
    quiet(clocks, 1.5, what="no /clock for 1.5 s after Pause")
    count = len(clocks)
    resume(page)
    wait_for(lambda: len(clocks) > count + 5, what="/clock to run again")


def test_step_advances_exactly_one_step(page, navigation):
    clocks = navigation.probe.clocks
    pause(page, navigation.probe)
    for expected in (1, 2):
        count, last = len(clocks), clocks[-1]
        page.button("Step").click()
        wait_for(lambda count=count: len(clocks) > count, what="one /clock after Step")
        quiet(clocks, 1.0, what="/clock to stop after one step")
        assert len(clocks) == count + 1, f"step {expected}: exactly one /clock, got {clocks[count:]}"
        assert clocks[-1] == pytest.approx(last + DT, abs=1e-9)
    resume(page)


def test_a_click_on_the_floor_sends_that_point_as_the_goal(page, navigation):
    probe = navigation.probe
    pause(page, probe)  # a still scene: the camera's move has settled when two screenshots agree
    page.toggle_folder("View")
    page.button("Top view").click()
    page.settled()
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
    resume(page)
    goal = probe.goals[-1]
    assert goal.header.frame_id == "map"
    error = math.hypot(goal.pose.position.x - x, goal.pose.position.y - y)
    assert error < 0.05, (
        f"goal ({goal.pose.position.x:.3f}, {goal.pose.position.y:.3f}) is {error:.3f} m from the "
        f"clicked ({x:.3f}, {y:.3f})"
    )


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
    page.hide_notifications()
    pause(page, probe)
    image = page.settled()
    shot = tmp_path / "viewer.png"
    page.page.screenshot(path=str(shot), timeout=120000)
    resume(page)
    wanted = os.environ.get("AMR_VIEWER_SCREENSHOT")
    if wanted:
        shutil.copy(shot, wanted)
    blue = (np.abs(image.astype(int) - (30, 110, 255)).sum(axis=2) < 60).sum()
    assert blue > 30, "the path is drawn"
    assert page.failed == [] and page.errors == [], "no failed request and no console error all along"
