"""replies: what the viewer says under its buttons and panels, and the reset that waits for the localizers."""

from __future__ import annotations

from types import SimpleNamespace

from amr_viewer.replies import (
    Countdown,
    control_reply,
    parameter_reply,
    restart_note,
    simulator_parameter_reply,
    taken,
)


def answer(success: bool, message: str = "") -> SimpleNamespace:
    return SimpleNamespace(success=success, message=message)


def set_answer(successful: bool | None, reason: str = "") -> SimpleNamespace:
    results = [] if successful is None else [SimpleNamespace(successful=successful, reason=reason)]
    return SimpleNamespace(results=results)


def test_a_control_answer_says_the_simulators_words_and_whether_it_is_paused():
    assert control_reply("/simulator", "pause", answer(True, "paused at t = 1.00 s")) == (
        "/simulator: paused at t = 1.00 s",
        True,
    )
    assert control_reply("/simulator", "resume", answer(True, "running"))[1] is False
    assert control_reply("/simulator", "step", answer(True, "stepped"))[1] is True
    assert control_reply("/simulator", "reset", answer(True, "reset: robot at"), "; note") == (
        "/simulator: reset: robot at; note",
        None,
    )
    assert control_reply("/simulator", "pause", answer(False, "not active")) == ("/simulator: not active", None)
    assert control_reply("/simulator", "step", TimeoutError("late")) == ("/simulator/step: late", None)


def test_the_reset_goes_once_every_localizer_is_done():
    called = []
    countdown = Countdown(["/particle_filter", "/r2/particle_filter"], lambda: called.append(True))
    countdown.done("/particle_filter")
    assert not called
    countdown.done("/r2/particle_filter")
    countdown.done("/r2/particle_filter")
    assert called == [True], "once"
    assert restart_note(["/a", "/b"]) == "; global localization restarted on /a, /b"


def test_a_parameter_answer_is_taken_or_refused_with_its_reason():
    assert taken(set_answer(True)) and not taken(set_answer(False)) and not taken(set_answer(None))
    assert not taken(RuntimeError("no service"))
    assert parameter_reply("/wall_follower", "kp", 3.0, "3.0", set_answer(True)) == "/wall_follower: kp = 3.0"
    assert parameter_reply("/wall_follower", "dt", 0.1, "0.1", set_answer(False, "not live")) == (
        "/wall_follower refused dt = 0.1: not live"
    )
    assert parameter_reply("/n", "a", "x", "x", set_answer(False)) == "/n refused a = 'x': (no reason given)"
    assert simulator_parameter_reply("/simulator", "pace", 2.0, set_answer(True)) == "/simulator: pace = 2.0"
    assert simulator_parameter_reply("/simulator", "pace", -1.0, set_answer(False, "below 0")) == (
        "/simulator refused pace = -1.0: below 0"
    )
