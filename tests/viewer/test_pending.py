"""Pending: the viewer's service requests in flight, each answered or timed out (no rclpy: any future)."""

from __future__ import annotations

from amr_viewer.pending import ANSWER_TIMEOUT, Pending


class Future:
    def __init__(self) -> None:
        self.value = self.error = None
        self.finished = self.cancelled = False

    def done(self) -> bool:
        return self.finished

    def result(self):
        return self.value

    def exception(self):
        return self.error

    def cancel(self) -> None:
        self.cancelled = True


class Clock:
    def __init__(self) -> None:
        self.now = 10.0

    def __call__(self) -> float:
        return self.now


def test_an_answer_an_error_and_a_timeout_each_reach_their_callback_once():
    clock, told = Clock(), []
    pending = Pending(clock)
    answered, failed, silent = Future(), Future(), Future()
    pending.add(answered, lambda answer: told.append(("answer", answer)), lambda: told.append("late"))
    pending.add(failed, lambda answer: told.append(("error", str(answer))), lambda: told.append("late"))
    pending.add(silent, lambda answer: told.append(("silent", answer)), lambda: told.append("timed out"))
    pending.poll()
    assert told == [] and len(pending) == 3
    answered.finished, answered.value = True, 42
    failed.finished, failed.error = True, RuntimeError("refused")
    pending.poll()
    assert told == [("answer", 42), ("error", "refused")] and len(pending) == 1
    clock.now += ANSWER_TIMEOUT + 0.1
    pending.poll()
    assert told[-1] == "timed out" and silent.cancelled and len(pending) == 0
    pending.poll()
    assert len(told) == 3


def test_a_request_has_its_own_deadline():
    clock, told = Clock(), []
    pending = Pending(clock)
    pending.add(Future(), told.append, lambda: told.append("first"), timeout=1.0)
    pending.add(Future(), told.append, lambda: told.append("second"), timeout=3.0)
    clock.now += 2.0
    pending.poll()
    assert told == ["first"]
