"""The node's lifecycle: invalid transitions, inactive refusal, all-or-nothing configure, request queue."""

from __future__ import annotations

import pytest
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from support.ik_service import call, config_overrides, connect, pose, reached, solve_request
from support.ros import spin_until

from amr_interfaces.srv import ComputeFK, SolveIK

GOOD = solve_request("rr2", pose(1.0, 1.0))


def lifecycle_clients(multi_executor, probe):
    change = probe.create_client(ChangeState, "/ik_service/change_state")
    state = probe.create_client(GetState, "/ik_service/get_state")
    reached(multi_executor, change, ChangeState.Request(transition=Transition(id=250)))  # refused: no such transition
    reached(multi_executor, state, GetState.Request())
    return change, state


def served_names(node) -> set[str]:
    """The node's own services (the graph would also list those of earlier tests' nodes for a while)."""
    return {service.srv_name for service in node.services}


def test_invalid_transitions_are_refused_and_the_node_lives_on(launch, multi_executor):
    node, probe = launch(activate=False)
    change, state = lifecycle_clients(multi_executor, probe)

    def transition(transition_id: int = 0, label: str = "") -> bool:
        request = ChangeState.Request(transition=Transition(id=transition_id, label=label))
        return call(multi_executor, change, request).success

    def label() -> str:
        return call(multi_executor, state, GetState.Request()).current_state.label

    assert not transition(Transition.TRANSITION_ACTIVATE), "activate from unconfigured"
    assert not transition(Transition.TRANSITION_CLEANUP), "cleanup from unconfigured"
    assert not transition(label="no_such_transition")
    assert not transition(250)
    assert label() == "unconfigured"
    assert transition(Transition.TRANSITION_CONFIGURE)
    assert not transition(Transition.TRANSITION_CONFIGURE), "configure twice"
    assert not transition(Transition.TRANSITION_DEACTIVATE), "deactivate from inactive"
    assert transition(label="activate")
    assert not transition(Transition.TRANSITION_CLEANUP), "cleanup from active"
    assert label() == "active"
    connect(multi_executor, probe)
    assert call(multi_executor, probe.solve, GOOD).success


def test_inactive_node_refuses_requests_with_a_message(launch, multi_executor):
    node, probe = launch(activate=False)
    assert "/solve_ik" not in served_names(node), "no services before configure"
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert {"/solve_ik", "/compute_fk"} <= served_names(node)
    connect(multi_executor, probe)

    def refused() -> None:
        reply = call(multi_executor, probe.solve, GOOD)
        assert not reply.success and "ik_service is inactive: activate it" in reply.message
        fk = call(multi_executor, probe.fk, ComputeFK.Request(chain="rr2", positions=[0.0, 0.0]))
        assert not fk.success and "inactive" in fk.message

    refused()
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    assert call(multi_executor, probe.solve, GOOD).success
    assert node.try_transition(Transition.TRANSITION_DEACTIVATE)
    refused()
    assert node.try_transition(Transition.TRANSITION_CLEANUP)
    assert not {"/solve_ik", "/compute_fk"} & served_names(node)


BAD_CHAINS = {
    "length mismatch": ({"ur5.lower": [-1.0] * 5}, "chain 'ur5', key 'ur5.lower'"),
    "lower above upper": ({"panda.lower": [3.0] * 7}, "chain 'panda', key 'panda.lower'"),
    "unknown joint type": ({"arm5.types": ["revolute"] * 4 + ["helical"]}, "chain 'arm5', key 'arm5.types'"),
    "strings where floats": ({"ur5.d": ["0"] * 6}, "chain 'ur5', key 'ur5.d'"),
    "negative tolerance": ({"rr2.tolerance": -1.0}, "chain 'rr2', key 'rr2.tolerance'"),
    "typo in a key": ({"ull3.tolerence": 0.1}, "chain 'ull3', key 'ull3.tolerence'"),
    "listed, never described": ({"chains": ["arm5", "ghost"]}, "chain 'ghost', key 'ghost.convention'"),
    "inapplicable default solver": ({"ur5.solver": "analytic"}, "chain 'ur5', key 'ur5.solver'"),
}


def test_integers_given_for_floats_are_taken_as_floats(launch):
    """YAML `[0, 0]` or `1` where floats are meant: rclpy reads integers; the node widens them."""
    node, _ = launch(config_overrides(**{"ur5.d": [0, 0, 0, 0, 0, 0], "rr2.tolerance": 1}), activate=False)
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.get_parameter("ur5.d").value == [0.0] * 6
    assert node.get_parameter("rr2.tolerance").value == 1.0


@pytest.mark.parametrize("changes, named", BAD_CHAINS.values(), ids=BAD_CHAINS.keys())
def test_a_bad_chain_fails_configure_and_loads_nothing(launch, multi_executor, changes, named):
    from amr_kinematics.config import load_chain_set

    with pytest.raises(ValueError, match=named):  # the message the node logs names chain and key
        load_chain_set({p.name: p.value for p in config_overrides(**changes)})
    node, probe = launch(config_overrides(**changes), activate=False)
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.state_label == "unconfigured"
    assert not {"/solve_ik", "/compute_fk"} & served_names(node), "nothing half-loaded"
    good = {p.name: p for p in config_overrides()}
    if set(changes) - set(good):  # a key no chain has: the file must be fixed, a set cannot declare it
        assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
        return
    # a bad value fixed at run time: the node configures
    assert all(r.successful for r in node.set_parameters([good[name] for name in changes]))
    assert node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.try_transition(Transition.TRANSITION_ACTIVATE)
    connect(multi_executor, probe)
    assert call(multi_executor, probe.solve, GOOD).success


def test_bad_node_limits_fail_configure(launch, multi_executor):
    node, _ = launch(config_overrides() + [Parameter("max_timeout", value=-1.0)], activate=False)
    assert not node.try_transition(Transition.TRANSITION_CONFIGURE)
    assert node.state_label == "unconfigured"


def test_a_burst_of_slow_requests_is_queued_not_dropped(launch, multi_executor):
    # 30 requests of 50 ms each at once: the default service queue (10) would drop a third of them
    node, probe = launch()
    client = probe.create_client(SolveIK, "/solve_ik", qos_profile=QoSProfile(depth=100))
    reached(multi_executor, client, SolveIK.Request())
    burst = [
        client.call_async(solve_request(chain, pose(2.0, 2.0, 2.0), timeout=0.05, max_iterations=100_000))
        for chain in ("ur5", "panda", "arm5")
        for _ in range(10)
    ]
    assert spin_until(multi_executor, lambda: all(f.done() for f in burst), timeout=10.0), (
        f"{sum(not f.done() for f in burst)} of {len(burst)} requests never answered"
    )
    assert all(f.result().message for f in burst)
