"""Ctrl-C for a command that must end with one line and exit status 130, whatever moment the signal lands.

Python turns SIGINT into a KeyboardInterrupt raised between two bytecodes of the main thread, and that is not
always where the program can see it: raised while a ``__del__``, a weakref callback, an at-fork hook (a pool
forking its workers) or a cffi callback runs, it is printed as "Exception ignored in ..." and swallowed. Seen:
amr-evaluate interrupted while forking its pool ran all its episodes and exited 0; under load, the full test
suite saw a one-process sweep exit 0 and a two-worker one, whose workers did end, die of the broken pool
(exit status 1), or print an InvalidStateError (a cancel racing the pool's breakage).

``Interrupt`` therefore keeps the interrupt as a flag as well as raising it:

- the first SIGINT sets ``interrupted`` and raises KeyboardInterrupt (the quick way out, through every
  ``finally``); code that waits (the sweep runner) also polls the flag, so a swallowed exception is only late;
- an exception of any kind that reaches the command while the flag is set is the interrupt (a pool broken by
  its workers' own Ctrl-C), and so is a command that returns normally after it;
- swallowed there, it is not printed either (sys.unraisablehook drops a KeyboardInterrupt after the flag);
- a watchdog thread ends the process (the one line, ``os._exit(130)``) when the command has not done so
  ``grace`` s after the interrupt (the exception swallowed in the middle of a long in-process episode);
- a second SIGINT ends the process at once (the same line);
- in a process forked from this one before it installed a handler of its own (a pool worker starting up), a
  SIGINT ends that process at once and quietly: the command reports it.

The line is written once, by whichever of the command and the watchdog claims it first. A SIGINT ignored when
the command starts (a background job of a non-interactive shell) stays ignored.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

from amr_util.stop_signals import Flag

INTERRUPTED = 128 + signal.SIGINT
"""The exit status of a command stopped by Ctrl-C (130, as a shell reports it)."""
GRACE = 5.0
"""s the command has, after the interrupt, to end by itself before the watchdog ends the process."""
WATCH_PERIOD = 0.05
"""s between the watchdog's looks at the flag."""


class Interrupt:
    """A context: SIGINT handled as above while it is entered (main thread only); the previous handler after.

    ``message`` is the one line (without its newline) written to ``stream`` (default stderr) on an interrupt;
    ``grace`` (default GRACE) the s the watchdog gives the command.
    """

    def __init__(self, message: str, grace: float | None = None, stream=None) -> None:
        self.message = message
        self.grace = GRACE if grace is None else grace
        self.stream = stream
        self.interrupted = Flag()
        self._at: float | None = None
        self._claim = threading.Lock()
        self._claimed = False
        self._done = threading.Event()
        self._pid = os.getpid()
        self._previous = None
        self._watchdog: threading.Thread | None = None
        self._unraisable_hook = None

    def __enter__(self) -> Interrupt:
        self._previous = signal.getsignal(signal.SIGINT)
        if self._previous is not signal.SIG_IGN:
            signal.signal(signal.SIGINT, self._on_signal)
            self._unraisable_hook, sys.unraisablehook = sys.unraisablehook, self._on_unraisable
            self._watchdog = threading.Thread(target=self._watch, name="interrupt-watchdog", daemon=True)
            self._watchdog.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        if self._previous is not signal.SIG_IGN:
            signal.signal(signal.SIGINT, self._previous if self._previous is not None else signal.SIG_DFL)
            sys.unraisablehook = self._unraisable_hook
        if self._watchdog is not None:
            self._watchdog.join()

    def is_set(self) -> bool:
        return self.interrupted.is_set()

    def report(self) -> int:
        """Write the line (unless the watchdog has: then this never returns) and give the exit status."""
        if self._take_claim():
            self._write()
        else:  # the watchdog is ending the process
            time.sleep(self.grace + 60.0)
        return INTERRUPTED

    def _on_signal(self, signum, frame) -> None:
        if os.getpid() != self._pid:  # a forked worker before its own handler: its parent reports
            os._exit(INTERRUPTED)
        if self.interrupted.is_set():  # the second Ctrl-C: now (unless the command is writing the line)
            self._exit_now()
            return
        self._at = time.monotonic()
        self.interrupted.set()
        raise KeyboardInterrupt

    def _on_unraisable(self, unraisable) -> None:
        """The interrupt swallowed where exceptions cannot propagate ("Exception ignored in ..."): the flag has it."""
        if isinstance(unraisable.exc_value, KeyboardInterrupt) and self.interrupted.is_set():
            return
        self._unraisable_hook(unraisable)

    def _watch(self) -> None:
        while not self._done.wait(WATCH_PERIOD):
            if self._at is not None and time.monotonic() - self._at >= self.grace:
                self._exit_now()

    def _exit_now(self) -> None:
        if self._take_claim():
            self._write()
            os._exit(INTERRUPTED)

    def _take_claim(self) -> bool:
        """True for the first caller only. Never blocks: the handler runs in the main thread, which may hold the
        lock at that moment (then the main thread is the one claiming)."""
        if not self._claim.acquire(blocking=False):
            return False
        try:
            claimed, self._claimed = self._claimed, True
        finally:
            self._claim.release()
        return not claimed

    def _write(self) -> None:
        stream = self.stream or sys.stderr
        try:
            stream.write(self.message + "\n")
            stream.flush()
        except (OSError, ValueError, RuntimeError):  # a closed stream, or one a handler interrupted mid-write
            os.write(2, (self.message + "\n").encode())
