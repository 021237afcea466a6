"""amr_util.lean_executor.LeanExecutor: every kind of entity a suite node has runs as on rclpy's executor."""

from __future__ import annotations

import threading
import time

import pytest
import rclpy
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.executors import ExternalShutdownException
from rclpy.lifecycle import LifecycleNode
from std_msgs.msg import Empty, String
from std_srvs.srv import Trigger
from support.ros import close, spin_for, spin_until

from amr_util.lean_executor import LeanExecutor


@pytest.fixture
def lean(ros_context):
    executor = LeanExecutor(context=ros_context)
    yield executor
    close(executor)


@pytest.fixture
def node(ros_context, lean):
    made = LifecycleNode("lean_probe", context=ros_context)
    lean.add_node(made)
    yield made
    made.destroy_node()


def test_subscriptions_in_creation_order_and_an_entity_made_later(node, lean):
    heard: list[str] = []
    node.create_subscription(String, "lean_a", lambda m: heard.append("a" + m.data), 10)
    node.create_subscription(String, "lean_b", lambda m: heard.append("b" + m.data), 10)
    to_a, to_b = node.create_publisher(String, "lean_a", 10), node.create_publisher(String, "lean_b", 10)
    assert spin_until(lean, lambda: to_a.get_subscription_count() and to_b.get_subscription_count(), 5.0)
    to_b.publish(String(data="1"))
    to_a.publish(String(data="1"))
    assert spin_until(lean, lambda: len(heard) == 2, 5.0)
    if heard[0] == "a1":  # both ready in one wake-up: the node's subscriptions in creation order
        assert heard == ["a1", "b1"]
    # a subscription made while the executor runs is waited on from then on
    node.create_subscription(String, "lean_c", lambda m: heard.append("c" + m.data), 10)
    to_c = node.create_publisher(String, "lean_c", 10)
    assert spin_until(lean, lambda: to_c.get_subscription_count() == 1, 5.0)
    to_c.publish(String(data="2"))
    assert spin_until(lean, lambda: "c2" in heard, 5.0)


def test_a_destroyed_subscription_is_no_longer_called(node, lean):
    heard: list[str] = []
    subscription = node.create_subscription(String, "lean_gone", lambda m: heard.append(m.data), 10)
    publisher = node.create_publisher(String, "lean_gone", 10)
    assert spin_until(lean, lambda: publisher.get_subscription_count() == 1, 5.0)
    publisher.publish(String(data="before"))
    assert spin_until(lean, lambda: heard == ["before"], 5.0)
    node.destroy_subscription(subscription)
    publisher.publish(String(data="after"))
    spin_for(lean, 0.3)
    assert heard == ["before"]


def test_an_entity_destroyed_by_a_callback_of_the_same_wake_up_is_not_called(node, lean):
    heard: list[str] = []
    second = None

    def first_heard(message):
        heard.append("first")
        node.destroy_subscription(second)
        node.destroy_guard_condition(guard)

    node.create_subscription(String, "lean_first", first_heard, 10)
    second = node.create_subscription(String, "lean_second", lambda m: heard.append("second"), 10)
    guard = node.create_guard_condition(lambda: heard.append("guard"))
    to_first, to_second = (
        node.create_publisher(String, "lean_first", 10),
        node.create_publisher(String, "lean_second", 10),
    )
    assert spin_until(lean, lambda: to_first.get_subscription_count() and to_second.get_subscription_count(), 5.0)
    to_first.publish(String())
    to_second.publish(String())
    guard.trigger()
    time.sleep(0.2)  # both delivered: one wake-up finds all three ready
    spin_for(lean, 0.3)
    assert heard == ["first"]


def test_timers_guard_conditions_and_an_async_callback(node, lean):
    ticks, guarded, resumed = [], [], []
    timer = node.create_timer(0.01, lambda: ticks.append(1))
    guard = node.create_guard_condition(lambda: guarded.append(1))
    guard.trigger()
    assert spin_until(lean, lambda: len(ticks) >= 3 and guarded == [1], 5.0)
    timer.cancel()
    spin_for(lean, 0.05)
    count = len(ticks)
    spin_for(lean, 0.1)
    assert len(ticks) == count  # a cancelled timer is not called

    later = node.create_publisher(Empty, "lean_async_done", 10)

    async def step_twice(_):
        resumed.append("first")
        await lean.create_task(lambda: None)  # suspended until that task has run
        resumed.append("second")
        later.publish(Empty())

    node.create_subscription(Empty, "lean_async", step_twice, 10)
    publisher = node.create_publisher(Empty, "lean_async", 10)
    assert spin_until(lean, lambda: publisher.get_subscription_count() == 1, 5.0)
    publisher.publish(Empty())
    assert spin_until(lean, lambda: resumed == ["first", "second"], 5.0)


def test_services_clients_and_their_done_callbacks(node, lean, ros_context):
    node.create_service(Trigger, "lean_trigger", lambda request, response: Trigger.Response(success=True))
    client = node.create_client(Trigger, "lean_trigger")
    assert client.wait_for_service(timeout_sec=5.0)
    answered = []
    future = client.call_async(Trigger.Request())
    future.add_done_callback(lambda done: answered.append(done.result().success))
    assert spin_until(lean, lambda: answered == [True], 5.0)
    # spin_until_future_complete, as a test or the lifecycle manager would use it
    future = client.call_async(Trigger.Request())
    lean.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.done() and future.result().success


def test_a_lifecycle_node_answers_its_transitions(node, lean, ros_context):
    """rclpy's EventsExecutor never answered a lifecycle node's services: this one does."""
    change = node.create_client(ChangeState, "lean_probe/change_state")
    get = node.create_client(GetState, "lean_probe/get_state")
    assert change.wait_for_service(timeout_sec=5.0) and get.wait_for_service(timeout_sec=5.0)
    future = change.call_async(ChangeState.Request(transition=Transition(id=Transition.TRANSITION_CONFIGURE)))
    lean.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.result().success
    future = get.call_async(GetState.Request())
    lean.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.result().current_state.label == "inactive"


def test_an_exception_leaves_spin_once(node, lean):
    def fail(_):
        raise RuntimeError("lean probe")

    node.create_subscription(Empty, "lean_fail", fail, 10)
    publisher = node.create_publisher(Empty, "lean_fail", 10)
    assert spin_until(lean, lambda: publisher.get_subscription_count() == 1, 5.0)
    publisher.publish(Empty())
    with pytest.raises(RuntimeError, match="lean probe"):
        spin_until(lean, lambda: False, 5.0)


def test_spin_ends_when_the_context_shuts_down(ros_domain):
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    executor = LeanExecutor(context=context)
    made = LifecycleNode("lean_context_probe", context=context)
    executor.add_node(made)
    ended = threading.Event()

    def spin():
        try:
            executor.spin()
        except ExternalShutdownException:
            pass
        ended.set()

    threading.Thread(target=spin, daemon=True).start()
    assert not ended.wait(0.3)  # spinning
    context.try_shutdown()
    assert ended.wait(5.0)
    made.destroy_node()
