"""amr-bringup run as a child process, its output collected line by line (the bringup and recording tests)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading

import pytest

from amr_util.environment import child_environment


class Bringup:
    """`python -m amr_bringup.bringup ...` with its output collected line by line."""

    def __init__(self, *arguments: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "amr_bringup.bringup", *arguments],
            env=child_environment(),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=lambda: self.lines.extend(self.process.stdout), daemon=True)
        self._reader.start()

    @property
    def output(self) -> str:
        return "".join(self.lines)

    def finish(self, timeout: float = 20.0) -> int:
        try:
            code = self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            pytest.fail(f"amr-bringup did not exit within {timeout} s:\n{self.output}")
        self._reader.join(5.0)
        return code

    def child_pids(self) -> dict[str, int]:
        return {m[1]: int(m[2]) for m in re.finditer(r"started (\w+) \(pid (\d+)\)", self.output)}
