"""amr-bringup --view: the viewer (amr_viewer) as a process of its own beside any stack.

Its own process, so drawing never takes the GIL from a composed stack; it is not one of the stack's managed nodes
(it configures and activates itself: autostart), so the stack's lifecycle order and its failures stay its own.
The web server binds to localhost unless --view-host says otherwise; it has no authentication.
"""

from __future__ import annotations

import socket
from collections.abc import Callable

from amr_bringup.processes import NodeProcess, executable_path

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8080


def viewer_command(name: str, host: str, port: int, simulated: bool) -> list[str]:
    return [
        str(executable_path("amr_viewer", "viewer")),
        "--ros-args",
        "-r",
        f"__node:={name}",
        "-p",
        "autostart:=true",
        "-p",
        f"host:={host}",
        "-p",
        f"port:={port}",
        "-p",
        f"use_sim_time:={'true' if simulated else 'false'}",
    ]


def port_problem(host: str, port: int) -> str | None:
    """Why the viewer could not serve on host:port (in use, an address not of this machine), or None."""
    try:
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host, port))
    except OSError as error:
        return f"cannot serve on {host}:{port}: {error.strerror or error}"
    return None


def viewer_url(host: str, port: int) -> str:
    shown = "127.0.0.1" if host in ("0.0.0.0", "") else host
    return f"http://[{shown}]:{port}" if ":" in shown else f"http://{shown}:{port}"


class ViewerProcess:
    def __init__(self, name: str, host: str, port: int, simulated: bool, write: Callable[[str], None]) -> None:
        self.command = viewer_command(name, host, port, simulated)
        self.url = viewer_url(host, port)
        self.process = NodeProcess(name, self.command, write)
        self.reported = False
