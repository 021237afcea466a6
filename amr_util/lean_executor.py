"""A single-threaded executor that keeps its wait set between wake-ups and runs ready callbacks directly.

rclpy 7.1.6's SingleThreadedExecutor, at every wake-up, gathers every entity of its nodes in Python (filtering each
through its callback group), enters each handle, builds a new rcl wait set, then wraps every ready callback in a
Task around a coroutine and triggers its own guard condition twice per callback, so each callback is followed by
a second, empty wake-up that rebuilds the whole wait set again. With a few dozen entities per node and 20 callbacks
per robot-step in the fleet stack, that machinery was most of the stack's CPU
(docs/decisions/2026-11-29-fleet-ros-layer.md).

`LeanExecutor` gathers its nodes' entities once, again only when an entity or node is added or removed (rclpy's
nodes call `executor.wake()` then), reuses one rcl wait set, and runs each ready callback in place: a subscription's
message taken and handed over, a timer called, a service answered, a guard condition's callback, a client's
response set on its future. What is not a plain function (an `async def` callback, a waitable's `execute`, a
future's done callback scheduled with `create_task`) runs as rclpy's own `Task`, resumed at each wake-up until it
finishes, as the stock executor does. Within one wake-up the order is the stock executor's: waitables, then node by
node its timers, subscriptions (in creation order: a node's own /clock first), guard conditions, clients, services.
A callback's exception propagates out of `spin_once`, as with the stock executor.

Callback groups are not consulted: on one thread every callback runs to its end before the next starts, which is
what a mutually exclusive group asks; a node whose callbacks must overlap (a reentrant group) runs on rclpy's
MultiThreadedExecutor instead (amr_util.executors, `multithreaded_executor = True`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable

from rclpy.exceptions import InvalidHandle
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.subscription import Subscription
from rclpy.task import Task
from rclpy.utilities import timeout_sec_to_nsec
from rclpy.waitable import NumberOfEntities


class _Entities:
    """One gathering of the executor's nodes' entities, and the rcl wait set sized for them."""

    def __init__(self, executor: LeanExecutor) -> None:
        nodes = executor.get_nodes()
        self.per_node = [
            (
                list(node.timers),
                list(node.subscriptions),
                list(node.guards),
                list(node.clients),
                list(node.services),
            )
            for node in nodes
        ]
        self.waitables = [waitable for node in nodes for waitable in node.waitables]
        self.executor_guards = [executor._guard, executor._sigint_gc]
        timers = [t for per in self.per_node for t in per[0]]
        subscriptions = [s for per in self.per_node for s in per[1]]
        guards = [g for per in self.per_node for g in per[2]] + self.executor_guards
        clients = [c for per in self.per_node for c in per[3]]
        services = [s for per in self.per_node for s in per[4]]
        self.handles = (
            [s.handle for s in subscriptions],
            [c.handle for c in clients],
            [s.handle for s in services],
            [t.handle for t in timers],
            [g.handle for g in guards],
        )
        self.held = [handle for handles in self.handles for handle in handles] + self.waitables
        """what a wait holds (entered: not destroyed while rcl waits on it), the context's handle last."""
        self.held.append(executor.context.handle)
        count = NumberOfEntities(len(subscriptions), len(guards), len(timers), len(clients), len(services))
        for waitable in self.waitables:
            count += waitable.get_num_entities()
        context = executor.context.handle
        with context:
            self.wait_set = _rclpy.WaitSet(
                count.num_subscriptions,
                count.num_guard_conditions,
                count.num_timers,
                count.num_clients,
                count.num_services,
                count.num_events,
                context,
            )


class LeanExecutor(SingleThreadedExecutor):
    """A SingleThreadedExecutor (spin, spin_once, spin_until_future_complete, create_task, shutdown as rclpy's)
    whose wake-up costs one wait on a kept wait set and one call per ready callback."""

    def __init__(self, *, context=None) -> None:
        super().__init__(context=context)
        self._entities: _Entities | None = None
        self._context_down = False

    def spin(self) -> None:
        """Execute callbacks until the executor or its context is shut down. The context is asked whether it is
        still up only when the executor's guard condition wakes it (the context's shutdown triggers it), not at
        every wake-up: Context.ok takes the context's lock, which a hundred spinning threads contend for (12 % of
        the 20-robot fleet's busy samples)."""
        if not self._context.ok():
            return
        while not self._is_shutdown and not self._context_down:
            self._spin_once_impl()

    # -- what changes the wait set ------------------------------------------------------------------------------

    def wake(self) -> None:
        self._entities = None  # a node created or destroyed an entity: gather again before the next wait
        super().wake()

    def add_node(self, node) -> bool:
        self._entities = None
        return super().add_node(node)

    def remove_node(self, node) -> None:
        self._entities = None
        super().remove_node(node)

    # -- one wake-up ----------------------------------------------------------------------------------------------

    def _spin_once_impl(self, timeout_sec=None, wait_condition: Callable[[], bool] = lambda: False) -> None:
        if self._is_shutdown:
            return
        pending = self._run_tasks()
        if self._is_shutdown or wait_condition():
            return
        timeout = 0 if pending else timeout_sec_to_nsec(getattr(timeout_sec, "timeout", timeout_sec))
        entities = self._entities
        if entities is None:
            entities = self._entities = _Entities(self)
        wait_set = entities.wait_set
        held = entities.held
        entered = 0  # no handle is destroyed while rcl waits on it (an ExitStack's per-handle cost, without it)
        try:
            try:
                for handle in held:
                    handle.__enter__()
                    entered += 1
            except InvalidHandle:  # destroyed since the gathering (its wake() is on its way): gather again
                self._entities = None
                self._check_context()
                return
            subscriptions, clients, services, timers, guards = entities.handles
            wait_set.clear_entities()
            for handle in subscriptions:
                wait_set.add_subscription(handle)
            for handle in clients:
                wait_set.add_client(handle)
            for handle in services:
                wait_set.add_service(handle)
            for handle in timers:
                wait_set.add_timer(handle)
            for handle in guards:
                wait_set.add_guard_condition(handle)
            for waitable in entities.waitables:
                waitable.add_to_wait_set(wait_set)
            wait_set.wait(timeout)
            if self._is_shutdown:
                return
            ready_guards = set(wait_set.get_ready_entities("guard_condition"))
            if any(guard.handle.pointer in ready_guards for guard in entities.executor_guards):
                self._entities = None  # a change, or a gathering raced with one: gather again
                self._check_context()  # the context's shutdown triggers the executor's guard
            ready_subscriptions = set(wait_set.get_ready_entities("subscription"))
            ready_timers = set(wait_set.get_ready_entities("timer"))
            ready_clients = set(wait_set.get_ready_entities("client"))
            ready_services = set(wait_set.get_ready_entities("service"))
            ready_waitables = [(w, w.take_data()) for w in entities.waitables if w.is_ready(wait_set)]
        finally:
            for index in range(entered - 1, -1, -1):
                held[index].__exit__(None, None, None)
        for waitable, data in ready_waitables:
            self._run(self._execute_waitable, waitable, data)
        for timers, subscriptions, guards, clients, services in entities.per_node:
            if ready_timers:
                for timer in timers:
                    if timer.handle.pointer in ready_timers:
                        self._call_timer(timer)
            if ready_subscriptions:
                for subscription in subscriptions:
                    if subscription.handle.pointer in ready_subscriptions:
                        self._take_message(subscription)
            if ready_guards:
                for guard in guards:
                    if guard.handle.pointer in ready_guards and guard.callback is not None:
                        self._run(guard.callback)
            if ready_clients:
                for client in clients:
                    if client.handle.pointer in ready_clients:
                        self._take_response(client)
            if ready_services:
                for service in services:
                    if service.handle.pointer in ready_services:
                        self._answer(service)

    def _check_context(self) -> None:
        if not self._context.ok():
            self._context_down = True
            raise ExternalShutdownException()

    def _run_tasks(self) -> bool:
        """Run (or resume) every task made with create_task; whether some are still pending (awaiting)."""
        with self._tasks_lock:
            if not self._tasks:
                return False
            tasks = list(self._tasks)
        for task, _, _ in tasks:
            if not task.executing() and not task.done() and not task.cancelled():
                task()
                if task.done() and task.exception() is not None:
                    with self._tasks_lock:
                        self._tasks = [entry for entry in self._tasks if entry[0] is not task]
                    raise task.exception()
        with self._tasks_lock:
            self._tasks = [entry for entry in self._tasks if not entry[0].done() and not entry[0].cancelled()]
            return bool(self._tasks)

    def _run(self, callback, *args) -> None:
        """A callback in place; a coroutine (async def) as a Task, resumed at the next wake-ups until done."""
        result = callback(*args)
        if inspect.iscoroutine(result):
            task = Task(result, executor=self)
            task()
            if task.done():
                task.result()  # raises its exception
            else:
                with self._tasks_lock:
                    self._tasks.append((task, None, None))

    async def _execute_waitable(self, waitable, data) -> None:
        for future in waitable._futures:
            future._set_executor(self)
        await waitable.execute(data)

    # -- one ready entity -----------------------------------------------------------------------------------------

    def _call_timer(self, timer) -> None:
        try:
            with timer.handle:
                if not timer.handle.is_timer_ready():  # a cancelled timer may be reported ready (rcl)
                    return
                timer.handle.call_timer()
        except InvalidHandle:
            return
        self._run(timer.callback)

    def _take_message(self, subscription) -> None:
        try:
            with subscription.handle:
                taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
        except InvalidHandle:
            return
        if taken is None:
            return
        if subscription._callback_type is Subscription.CallbackType.MessageOnly:
            self._run(subscription.callback, taken[0])
        else:
            self._run(subscription.callback, *taken)

    def _take_response(self, client) -> None:
        try:
            with client.handle:
                header, response = client.handle.take_response(client.srv_type.Response)
        except InvalidHandle:
            return
        if header is None:
            return
        try:
            future = client.get_pending_request(header.request_id.sequence_number)
        except KeyError:  # the request was cancelled
            return
        future._set_executor(self)
        future.set_result(response)

    def _answer(self, service) -> None:
        try:
            with service.handle:
                request, header = service.handle.service_take_request(service.srv_type.Request)
        except InvalidHandle:
            return
        if header is None:
            return
        response = service.callback(request, service.srv_type.Response())
        if inspect.iscoroutine(response):
            self._run(_answer_later, service, response, header)
        else:
            service.send_response(response, header)


async def _answer_later(service, coroutine, header) -> None:
    service.send_response(await coroutine, header)
