"""StopSignals' flags survive a signal landing while the main thread waits on them.

A handler runs between two bytecodes of the main thread: with threading.Event it could land
inside Event.wait() with the event's lock held, and its Event.set() then blocked for good
(amr-bringup ignored SIGTERM on CI). The storm below makes that landing near certain: with
threading.Event in place of Flag the child hangs or dies of a RecursionError.
"""

import subprocess
import sys
import textwrap

from amr_util.environment import child_environment
from amr_util.stop_signals import Flag

SIGNAL_STORM = textwrap.dedent("""
    import os, signal, threading, time
    from amr_util.stop_signals import Flag, StopSignals
    flag = Flag()  # set by every signal while the main thread waits on it: the worst case
    signal.signal(signal.SIGUSR1, lambda signum, frame: flag.set())
    def storm():
        for _ in range(3000):
            os.kill(os.getpid(), signal.SIGUSR1)
            time.sleep(0.0003)
    threading.Thread(target=storm, daemon=True).start()
    end = time.monotonic() + 1.5
    while time.monotonic() < end:
        flag.wait(0.001)
    signals = StopSignals()
    os.kill(os.getpid(), signal.SIGTERM)
    first = (signals.stop.wait(5.0), signals.hurry.is_set())
    os.kill(os.getpid(), signal.SIGINT)
    print(flag.is_set(), first, signals.hurry.wait(5.0), flush=True)
""")


def test_a_storm_of_signals_setting_the_flag_being_waited_on_never_blocks_the_main_thread():
    result = subprocess.run(
        [sys.executable, "-c", SIGNAL_STORM], env=child_environment(), capture_output=True, text=True, timeout=30
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip() == "True (True, False) True"  # SIGTERM: stop; then SIGINT: hurry


def test_flag_wait_returns_false_after_the_timeout_and_true_once_set():
    flag = Flag()
    assert flag.wait(0.05) is False
    flag.set()
    assert flag.is_set() and flag.wait(10.0) is True
