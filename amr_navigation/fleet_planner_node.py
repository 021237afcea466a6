"""fleet_planner: plans the robots of a fleet together and hands each navigator its route (lifecycle node, a thin
shell over amr_navigation.fleet_coordinator.FleetCoordinator).

One per fleet, in the root namespace (/fleet_planner). It reads every robot's navigator status
(/<robot>/navigator/status: where the robot stands, whether its navigator is confident, its goal) and the one /map
(transient local), and publishes each robot's amr_interfaces/FleetRoute on /<robot>/fleet_route (reliable,
transient local): NONE (go by the traffic rules) until every robot is confident at once, then HOLD while it plans
(amr_planning.fleet_lacam on a lattice of the map's costmap), then FOLLOW: the waypoints the robot may drive to now,
sent again whenever the robots' progress lets it go farther; a robot stuck on its way (something not on the map)
has the lattice vertex it could not reach cut off and the fleet planned again. The navigators run `coordination: plan`
(docs/amr_navigation.md); it plans only when every robot's route has a listener (with coordination: rules the
navigators do not subscribe, and it stays idle). The robots are the world's `robots` list (or the `robots`
parameter).

configure  reads the fleet's names, creates the routes' publishers and subscribes to the statuses and the map.
activate   tells every robot NONE (the traffic rules until the fleet is planned), then plans when due.
deactivate tells every robot NONE: the navigators go back to the traffic rules.
cleanup    forgets the plan, the statuses and the map.

Planning never runs in a callback: a status callback records the status and, when a plan is due, hands the job
(FleetCoordinator.begin_plan) to a worker thread (compute_plan) and publishes the HOLDs; the worker triggers a guard
condition when done, and its callback adopts the plan (finish_plan) and publishes the routes. Meanwhile statuses go on
being read (the robots not planned again drive on their routes). Every FOLLOW route is renewed halfway to its expiry
(`route_lifetime`; the navigators fall back to their own planning when a route expires).

A malformed status (a pose or goal that is not finite) or map is refused with a throttled warning; nothing raises
out of a callback; no route with a NaN is published.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor

from nav_msgs.msg import OccupancyGrid as OccupancyGridMessage
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.lifecycle import State, TransitionCallbackReturn

from amr_interfaces.msg import FleetRoute, NavigatorStatus
from amr_maps.messages import grid_from_message
from amr_navigation.fleet_coordinator import NONE, FleetCoordinator, Route, compute_plan
from amr_navigation.fleet_file import load_fleet
from amr_navigation.fleet_planner_config import NODE_NAME, FleetPlannerConfig
from amr_navigation.fleet_route_messages import route_message
from amr_planning.costmap import shared_costmap
from amr_util.managed_node import ManagedNode, run
from amr_util.qos import LATCHED, reliable
from amr_util.stamps import stamp_nanoseconds

QUIET = PublisherEventCallbacks(use_default_callbacks=False)
"""the routes' publishers' event callbacks: none (fewer waitables in every wait set; the navigators' subscriptions
report an incompatible QoS)."""


def fleet_names(config: FleetPlannerConfig) -> list[str]:
    """The robots' names: the robots parameter, else the world's robots list (ValueError naming the world)."""
    return fleet_roster(config)[0]


def fleet_roster(config: FleetPlannerConfig) -> tuple[list[str], list[int]]:
    """The robots' names and priorities: the robots parameter (priorities in its order), else the fleet file's (the
    world's robots list and their `priority` keys: amr_navigation.fleet_file; ValueError naming file, key, value)."""
    if config.robots:
        return list(config.robots), list(range(len(config.robots)))
    from amr_maps.world import resolve_world_path

    fleet = load_fleet(resolve_world_path(config.world))
    return fleet.names, fleet.priorities


class FleetPlannerNode(ManagedNode):
    """Wires FleetCoordinator to the navigators' statuses, /map and the robots' fleet_route; holds no logic."""

    def __init__(self, **kwargs) -> None:
        super().__init__(NODE_NAME, **kwargs)
        self.declare_specs(FleetPlannerConfig.parameter_specs())
        self.coordinator: FleetCoordinator | None = None
        self.config: FleetPlannerConfig | None = None
        self.configure_error = ""
        self.statuses_refused = 0
        self._routes: dict = {}
        self._entities: list = []
        self._worker: ThreadPoolExecutor | None = None
        self._job: Future | None = None
        """the plan being made on the worker thread."""
        self._job_done = None
        """guard condition the worker triggers when the plan is made (its callback adopts it on the executor)."""

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        if not problems:
            try:
                config = FleetPlannerConfig.from_params(self.parameter_values())
                names, priorities = fleet_roster(config)
                coordinator = config.coordinator(names, priorities)
            except (ValueError, OSError) as error:  # ConfigError names the key; a world names its file
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self.config, self.coordinator = config, coordinator
        for name in coordinator.names:
            self._routes[name] = self.create_lifecycle_publisher(
                FleetRoute, f"/{name}/{config.route_topic}", LATCHED, event_callbacks=QUIET
            )
            self._entities.append(
                self.create_subscription(
                    NavigatorStatus, f"/{name}/{config.status_topic}", self._status_callback(name), reliable(depth=50)
                )
            )
        self._entities.append(self.create_subscription(OccupancyGridMessage, config.map_topic, self._on_map, LATCHED))
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="fleet_planning")
        self._job_done = self.create_guard_condition(self._on_plan_done)
        self.get_logger().info(
            f"configured: {len(coordinator.names)} robots ({', '.join(coordinator.names)}), "
            f"lattice {config.lattice_spacing} m, routes on /<robot>/{config.route_topic}"
        )
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        self._publish(
            {
                name: Route(NONE, reason="no fleet plan yet: by the traffic rules until every robot is confident")
                for name in self.coordinator.names
            }
        )
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._publish(self.coordinator.drop("the fleet planner was deactivated"))
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        if self._worker is not None:
            self._worker.shutdown(wait=True, cancel_futures=True)
        self._worker = self._job = self._job_done = None
        self._entities, self._routes = [], {}
        self.coordinator = self.config = None
        return super().on_cleanup(state)  # destroys what configure made

    @property
    def active(self) -> bool:
        return self.state_label == "active" and self.coordinator is not None

    # -- inputs -------------------------------------------------------------------------------------------

    def _on_map(self, message: OccupancyGridMessage) -> None:
        if self.coordinator is None:
            return
        try:  # the planners' own costmap when composed with them (the same map and costmap parameters)
            costmap = shared_costmap(grid_from_message(message), self.config.costmap)
        except Exception as error:  # a bad map must not take the node down
            self.get_logger().error(f"{self.config.map_topic} refused, keeping the previous one: {error}")
            return
        routes = self.coordinator.set_costmap(costmap)
        if self.active:
            self._publish(routes)
            self._plan_if_due()

    def _status_callback(self, name: str):
        def on_status(message: NavigatorStatus) -> None:
            if not self.active:
                return
            if message.header.frame_id not in ("", self.config.global_frame):
                self._refuse(
                    f"{name}: status in frame {message.header.frame_id!r}, expected {self.config.global_frame!r}"
                )
                return
            position = message.pose.position
            goal = (message.goal.x, message.goal.y) if message.has_goal else None
            try:
                routes = self.coordinator.observe(
                    name,
                    stamp_nanoseconds(message.header.stamp) * 1e-9,
                    position.x,
                    position.y,
                    message.confident,
                    goal,
                )
            except ValueError as error:
                self._refuse(str(error))
                return
            for event in self.coordinator.take_events():
                self.get_logger().warning(event)
            self._publish({**self.coordinator.renewals(), **routes})
            self._plan_if_due()

        return on_status

    def _refuse(self, problem: str) -> None:
        self.statuses_refused += 1
        self.get_logger().warning(f"a navigator status was refused: {problem}", throttle_duration_sec=2.0)

    # -- planning -----------------------------------------------------------------------------------------

    def _plan_if_due(self) -> None:
        """A plan due: its job handed to the worker thread (never planned here), the HOLDs published."""
        coordinator = self.coordinator
        if self._job is not None or not coordinator.plan_due():
            return
        deaf = [name for name, publisher in self._routes.items() if publisher.get_subscription_count() == 0]
        if deaf:  # a navigator of coordination rules: a plan it would not follow would lead the others astray
            self.get_logger().info(
                f"not planning: no navigator listens to the route of {', '.join(deaf)} (coordination: rules)",
                throttle_duration_sec=30.0,
            )
            return
        job, holds = coordinator.begin_plan()
        self._publish(holds)
        self._job = self._worker.submit(compute_plan, job)
        guard = self._job_done
        self._job.add_done_callback(lambda _: guard.trigger())

    def _on_plan_done(self) -> None:
        """The worker's plan adopted (on the executor's thread) and the routes published."""
        job, self._job = self._job, None
        if job is None or not job.done() or self.coordinator is None:
            self._job = job if job is not None and not job.done() else None
            return
        try:
            outcome = job.result()
        except Exception as error:  # a planner bug must not take the node down: the robots go by the rules
            self.coordinator.planning = False
            self.get_logger().error(f"the fleet plan raised {type(error).__name__}: {error}")
            self._publish(self.coordinator.drop(f"planning raised {type(error).__name__}"))
            return
        routes = self.coordinator.finish_plan(outcome)
        for event in self.coordinator.take_events():
            self.get_logger().warning(event)
        coordinator = self.coordinator
        if coordinator.schedule is None:
            if routes:
                self.get_logger().error(next(iter(routes.values())).reason)
        elif routes:
            self.get_logger().info(
                f"fleet plan {coordinator.plans}{' (partial)' if outcome.partial else ''}: {len(coordinator.names)} "
                f"robots on a lattice of {coordinator.lattice_size} points, planned in {outcome.seconds:.2f} s on "
                f"the worker thread; the longest {max(len(w) for w in coordinator.schedule.waypoints) - 1} waypoints"
            )
        if self.active:
            self._publish(routes)
            self._plan_if_due()

    def wait_for_plan(self, timeout: float = 30.0) -> bool:
        """Block until the plan being made is done and adopted (tests; never from a callback). False on timeout."""
        job = self._job
        if job is None:
            return True
        try:
            job.result(timeout=timeout)
        except TimeoutError:
            return False
        except Exception:  # adopted (and logged) by _on_plan_done
            pass
        self._on_plan_done()
        return True

    def _publish(self, routes: dict[str, Route]) -> None:
        stamp = self.get_clock().now().to_msg()
        for name, route in routes.items():
            self._routes[name].publish(route_message(route, stamp, self.config.global_frame))


def main(args=None) -> None:
    run(FleetPlannerNode, args=args)


if __name__ == "__main__":
    main()
