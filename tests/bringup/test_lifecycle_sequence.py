import threading
import time

import pytest

from amr_bringup.lifecycle_sequence import WAIT_SLICE, LifecycleSequencer

GRAPH = {  # state -> {transition: next state}
    "unconfigured": {"configure": "inactive", "shutdown": "finalized"},
    "inactive": {"activate": "active", "cleanup": "unconfigured", "shutdown": "finalized"},
    "active": {"deactivate": "inactive", "shutdown": "finalized"},
    "finalized": {},
}


class FakeNodes:
    """Lifecycle state machines that record every request and refuse what their state does not offer."""

    def __init__(self, states, failing=(), silent=(), absent=()):
        self.states = dict(states)
        self.failing, self.silent, self.absent = set(failing), set(silent), set(absent)
        self.requests: list[tuple[str, str]] = []

    def wait_until_available(self, node, timeout):
        return node not in self.absent

    def state(self, node):
        return None if node in self.silent else self.states[node]

    def available_transitions(self, node):
        return None if node in self.silent else list(GRAPH[self.states[node]])

    def change_state(self, node, transition):
        self.requests.append((node, transition))
        assert transition in GRAPH[self.states[node]], "the sequencer asked for an invalid transition"
        if (node, transition) in self.failing:
            return False
        self.states[node] = GRAPH[self.states[node]][transition]
        return True


def make(nodes, fake, reported=None, wait_timeout=0.6):
    return LifecycleSequencer(
        fake, nodes, wait_timeout=wait_timeout, report=(reported.append if reported is not None else lambda s: None)
    )


def test_startup_in_order_and_shutdown_in_reverse():
    fake = FakeNodes({"sim": "unconfigured", "odom": "unconfigured", "follower": "unconfigured"})
    sequencer = make(["sim", "odom", "follower"], fake)
    steps = sequencer.startup()
    assert all(step.ok for step in steps)
    assert fake.requests == [
        ("sim", "configure"),
        ("sim", "activate"),
        ("odom", "configure"),
        ("odom", "activate"),
        ("follower", "configure"),
        ("follower", "activate"),
    ]
    fake.requests.clear()
    sequencer.shutdown()
    assert fake.requests == [
        ("follower", "deactivate"),
        ("follower", "cleanup"),
        ("odom", "deactivate"),
        ("odom", "cleanup"),
        ("sim", "deactivate"),
        ("sim", "cleanup"),
    ]
    assert set(fake.states.values()) == {"unconfigured"}


def test_nodes_already_up_are_not_asked_again():
    fake = FakeNodes({"a": "active", "b": "inactive"})
    assert all(step.ok for step in make(["a", "b"], fake).startup())
    assert fake.requests == [("b", "activate")]


def test_a_failing_configure_stops_the_sequence_and_names_the_node():
    reported = []
    fake = FakeNodes(
        {"sim": "unconfigured", "follower": "unconfigured", "last": "unconfigured"}, failing={("follower", "configure")}
    )
    steps = make(["sim", "follower", "last"], fake, reported).startup()
    assert not steps[-1].ok and steps[-1].node == "follower" and steps[-1].transition == "configure"
    assert "follower" in steps[-1].detail
    assert ("last", "configure") not in fake.requests and reported == steps


@pytest.mark.parametrize(
    ("fake", "words"),
    [
        (FakeNodes({"x": "unconfigured"}, absent={"x"}), "not available"),
        (FakeNodes({"x": "unconfigured"}, silent={"x"}), "did not answer"),
        (FakeNodes({"x": "finalized"}), "offers"),
    ],
)
def test_unreachable_or_finalized_nodes_fail_clearly(fake, words):
    steps = make(["x"], fake).startup()
    assert not steps[-1].ok and words in steps[-1].detail


def test_a_stop_mid_startup_cancels_the_rest_and_shutdown_takes_down_what_is_up():
    fake = FakeNodes({"sim": "unconfigured", "odom": "unconfigured", "follower": "unconfigured"})
    sequencer = make(["sim", "odom", "follower"], fake)
    answer = fake.change_state

    def stop_arrives_during_odom_activate(node, transition):  # the signal lands while a transition is under way
        if (node, transition) == ("odom", "activate"):
            sequencer.cancel_startup()
        return answer(node, transition)

    fake.change_state = stop_arrives_during_odom_activate
    steps = sequencer.startup()
    assert not steps[-1].ok and steps[-1].node == "follower" and "cancelled" in steps[-1].detail
    assert ("follower", "configure") not in fake.requests
    fake.requests.clear()
    sequencer.shutdown()
    assert fake.requests == [("odom", "deactivate"), ("odom", "cleanup"), ("sim", "deactivate"), ("sim", "cleanup")]
    fake.change_state = answer
    assert all(step.ok for step in sequencer.startup())  # a new startup is not cancelled by the old request


def test_a_cancel_ends_a_long_wait_for_a_node_within_a_slice():
    fake = FakeNodes({"x": "unconfigured"}, absent={"x"})
    sequencer = make(["x"], fake, wait_timeout=30.0)
    threading.Timer(0.3, sequencer.cancel_startup).start()
    started = time.monotonic()
    steps = sequencer.startup()
    assert time.monotonic() - started < 0.3 + 4 * WAIT_SLICE  # not the 30 s wait_timeout
    assert steps[-1].transition == "wait" and steps[-1].detail == "startup cancelled"


def test_shutdown_skips_what_the_state_does_not_allow():
    fake = FakeNodes({"a": "unconfigured", "b": "inactive", "c": "finalized"})
    make(["a", "b", "c"], fake).shutdown()
    assert fake.requests == [("b", "cleanup")]


@pytest.mark.parametrize("nodes", [[], ["a", "a"]])
def test_bad_node_lists_are_refused(nodes):
    with pytest.raises(ValueError, match="node_startup_order"):
        make(nodes, FakeNodes({}))
