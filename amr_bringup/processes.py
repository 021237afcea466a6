"""Node processes for amr-bringup: started as `ros2 run` would, output prefixed, stopped for sure.

Each child gets a session of its own, so a Ctrl-C at the terminal reaches amr-bringup
only, which then stops the children in order (a second SIGINT in the middle of a node's
clean deactivation would cut it short); the session is also what SIGKILL sweeps.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from amr_util.environment import child_environment
from amr_util.share import package_prefix
from amr_util.stop_signals import Flag


def executable_path(package: str, executable: str) -> Path:
    """lib/<package>/<executable> under the package's install prefix."""
    return package_prefix(package) / "lib" / package / executable


class NodeProcess:
    """One node executable; every line it prints goes to `write` as `[label] line`."""

    def __init__(self, label: str, command: Sequence[str], write: Callable[[str], None]) -> None:
        self.label = label
        # Python children print at once; ROS log colours only when we write to a terminal.
        extra = {"PYTHONUNBUFFERED": "1"}
        if sys.stdout.isatty():
            extra["RCUTILS_COLORIZED_OUTPUT"] = "1"
        self.process = subprocess.Popen(
            list(command),
            env=child_environment(**extra),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
            start_new_session=True,
        )
        self._reader = threading.Thread(target=self._forward, args=(write,), daemon=True)
        self._reader.start()

    @property
    def pid(self) -> int:
        return self.process.pid

    def _forward(self, write: Callable[[str], None]) -> None:
        for line in self.process.stdout:
            write(f"[{self.label}] {line.rstrip()}")

    def exit_code(self) -> int | None:
        return self.process.poll()

    def interrupt(self) -> None:
        """SIGINT, as Ctrl-C would: the node deactivates (zero velocity) and exits."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)

    def kill(self) -> None:
        """SIGKILL to the child's whole session."""
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self.process.wait()

    def close(self) -> None:
        """Wait for the last output lines (the reader ends when the pipe closes)."""
        self._reader.join(timeout=1.0)
        self.process.stdout.close()


def stop_processes(processes: Sequence[NodeProcess], grace: float, hurry: Flag) -> list[str]:
    """SIGINT every process, SIGKILL those still running after `grace` s (or when `hurry` is set).

    Returns the labels of the processes that had to be killed. The SIGKILL goes to each
    child's session, which also takes anything the child started.
    """
    for process in processes:
        process.interrupt()
    deadline = time.monotonic() + grace
    while any(p.exit_code() is None for p in processes) and time.monotonic() < deadline and not hurry.is_set():
        time.sleep(0.05)
    killed = [p.label for p in processes if p.exit_code() is None]
    for process in processes:
        process.kill()
        process.close()
    return killed
