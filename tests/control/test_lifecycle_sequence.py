import pytest

from amr_control.lifecycle_sequence import LifecycleSequencer

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


def make(nodes, fake, reported=None):
    return LifecycleSequencer(fake, nodes, wait_timeout=1.0, report=(reported.append if reported is not None else lambda s: None))


def test_startup_in_order_and_shutdown_in_reverse():
    fake = FakeNodes({"sim": "unconfigured", "odom": "unconfigured", "follower": "unconfigured"})
    sequencer = make(["sim", "odom", "follower"], fake)
    steps = sequencer.startup()
    assert all(step.ok for step in steps)
    assert fake.requests == [("sim", "configure"), ("sim", "activate"), ("odom", "configure"),
                             ("odom", "activate"), ("follower", "configure"), ("follower", "activate")]
    fake.requests.clear()
    sequencer.shutdown()
    assert fake.requests == [("follower", "deactivate"), ("follower", "cleanup"), ("odom", "deactivate"),
                             ("odom", "cleanup"), ("sim", "deactivate"), ("sim", "cleanup")]
    assert set(fake.states.values()) == {"unconfigured"}


def test_nodes_already_up_are_not_asked_again():
    fake = FakeNodes({"a": "active", "b": "inactive"})
    assert all(step.ok for step in make(["a", "b"], fake).startup())
    assert fake.requests == [("b", "activate")]


def test_a_failing_configure_stops_the_sequence_and_names_the_node():
    reported = []
    fake = FakeNodes({"sim": "unconfigured", "follower": "unconfigured", "last": "unconfigured"},
                     failing={("follower", "configure")})
    steps = make(["sim", "follower", "last"], fake, reported).startup()
    assert not steps[-1].ok and steps[-1].node == "follower" and steps[-1].transition == "configure"
    assert "follower" in steps[-1].detail
    assert ("last", "configure") not in fake.requests and reported == steps


@pytest.mark.parametrize(("fake", "words"), [
    (FakeNodes({"x": "unconfigured"}, absent={"x"}), "not available"),
    (FakeNodes({"x": "unconfigured"}, silent={"x"}), "did not answer"),
    (FakeNodes({"x": "finalized"}), "offers"),
])
def test_unreachable_or_finalized_nodes_fail_clearly(fake, words):
    steps = make(["x"], fake).startup()
    assert not steps[-1].ok and words in steps[-1].detail


def test_shutdown_skips_what_the_state_does_not_allow():
    fake = FakeNodes({"a": "unconfigured", "b": "inactive", "c": "finalized"})
    make(["a", "b", "c"], fake).shutdown()
    assert fake.requests == [("b", "cleanup")]


@pytest.mark.parametrize("nodes", [[], ["a", "a"]])
def test_bad_node_lists_are_refused(nodes):
    with pytest.raises(ValueError, match="node_startup_order"):
        make(nodes, FakeNodes({}))
