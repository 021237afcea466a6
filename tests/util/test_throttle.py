"""amr_util.throttle: one message per call site per period, the first one logged, decided before the logger is
asked (rclpy's throttled logger resolves its caller at every call); the path follower's repeated warnings go
through it."""

from __future__ import annotations

import pytest

from amr_util.throttle import Throttle, ThrottledLogger


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Logger:
    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []
        self.asked = 0

    def warning(self, text, **_):
        self.lines.append(("warning", text))

    def error(self, text, **_):
        self.lines.append(("error", text))


def test_a_key_passes_once_per_period_and_keys_are_apart():
    clock = Clock()
    throttle = Throttle(2.0, clock)
    assert throttle("a") and not throttle("a") and throttle("b")
    clock.now += 1.999
    assert not throttle("a")
    clock.now += 0.001
    assert throttle("a") and not throttle("a")
    with pytest.raises(ValueError, match="period"):
        Throttle(float("nan"))


def test_each_call_site_is_throttled_on_its_own_and_the_logger_is_asked_only_for_what_goes_out():
    clock, logger = Clock(), Logger()

    def get_logger():
        logger.asked += 1
        return logger

    throttled = ThrottledLogger(get_logger, 2.0, clock)

    def warn(text):  # one call site, as a node's _warn
        return throttled.warning(text)

    said = [warn(f"w{k}") for k in range(50)]
    assert said == [True] + [False] * 49
    assert throttled.error("e0")  # another call site: a throttle of its own
    clock.now += 2.0
    assert warn("late") and not warn("later")
    assert logger.lines == [("warning", "w0"), ("error", "e0"), ("warning", "late")]
    assert logger.asked == 3


def test_the_path_follower_throttles_its_warnings_before_asking_its_logger(ros_context):
    from amr_control.path_follower_node import PathFollowerNode

    node = PathFollowerNode(context=ros_context)
    try:
        logger = Logger()
        node.get_logger = lambda: logger  # records every call it gets, throttle_duration_sec or not
        for _ in range(20):
            node.warn_throttled("no localized /pose + /scan")
            node.warn_throttled("/path refused, stopping: empty")  # another warning: its own throttle
        assert logger.lines == [
            ("warning", "no localized /pose + /scan"),
            ("warning", "/path refused, stopping: empty"),
        ]
    finally:
        node.destroy_node()


def test_one_throttled_logger_logs_every_severity_through_rclpys_logger():
    """rclpy's logger keeps one severity per line that calls it; a ThrottledLogger that logs a warning and then an
    error (a node's two call sites) does not raise "Logger severity cannot be changed between calls"."""
    import rclpy.logging

    logger = rclpy.logging.get_logger("throttle_test")  # one object, as a node's get_logger() gives
    throttled = ThrottledLogger(lambda: logger, 0.0)
    for _ in range(2):
        assert throttled.debug("d") and throttled.info("i") and throttled.warning("w") and throttled.error("e")
