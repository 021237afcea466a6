"""beacon_localizer: seed 000's beacon localizer as a lifecycle node (`ros2 run amr_localization beacon_localizer`).

A thin shell over amr_localization.beacon_localizer.BeaconLocalizer: /beacons (amr_interfaces/BeaconRanges:
beacon positions, ranges in their order, compass) and /odometry are paired by stamp; each pair tracks
the pose by odometry and, when the ranges and heading disagree with it by more than `threshold`,
relocalizes by the pyramidal grid search. Out, as the particle filter: /pose (LocalizedPose,
localized when the measured ranges fit the pose within `threshold`), map -> odom on /tf, ~/status.
The localizer is built from the first reading's beacon positions (and rebuilt, with a warning, if they
change). Malformed readings (NaN ranges, a wrong count) are logged and the pose follows odometry.
"""

from __future__ import annotations

import math

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.lifecycle import State, TransitionCallbackReturn

from amr_interfaces.msg import BeaconRanges, LocalizerStatus
from amr_localization import messages
from amr_localization.beacon_localizer import BeaconLocalizer, BeaconLocalizerConfig
from amr_localization.beacons import BeaconReading
from amr_localization.errors import BeaconError, OdometryError
from amr_localization.localizer_node import SHELL_SPECS, LocalizerNode
from amr_localization.pose_estimate import PoseEstimate
from amr_util.managed_node import WARNING_PERIOD, run
from amr_util.parameter_spec import ParameterSpec
from amr_util.qos import reliable

BEACONS, ODOMETRY = 0, 1
INITIAL_POSE = ParameterSpec(
    "initial_pose",
    [0.0, 0.0, 0.0],
    "[x, y, theta] the pose is tracked from until the first relocalization",
    kind="float_array",
    check=lambda v: None if len(v) == 3 else "must be [x, y, theta]",
)


def parameter_specs() -> tuple[ParameterSpec, ...]:
    """BeaconLocalizerConfig's (all live: read at each relocalization), the initial pose, the shell's."""
    return BeaconLocalizerConfig.parameter_specs() + (INITIAL_POSE,) + SHELL_SPECS


def config_of(values: dict) -> BeaconLocalizerConfig:
    names = {spec.name for spec in BeaconLocalizerConfig.parameter_specs()}
    return BeaconLocalizerConfig.from_params({name: value for name, value in values.items() if name in names})


class BeaconLocalizerNode(LocalizerNode):
    INPUTS = ("beacons", "odometry")

    def __init__(self, **kwargs) -> None:
        super().__init__("beacon_localizer", **kwargs)
        self.declare_specs(parameter_specs())
        self.localizer: BeaconLocalizer | None = None
        self._config: BeaconLocalizerConfig | None = None
        self._inputs: list = []
        self.configure_error = ""

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        problems = self.parameter_problems()
        values = self.parameter_values()
        if not problems:
            try:
                self._config = config_of(values)
            except ValueError as error:  # ConfigError names the key
                problems = [str(error)]
        if problems:
            self.configure_error = "; ".join(problems)
            return self.fail_configure(problems)
        self._settings = {spec.name: values[spec.name] for spec in SHELL_SPECS}
        self._start_pairing(values, self._on_pair)
        self._create_estimate_outputs(values)
        qos = reliable(values["sync_queue_size"])
        self._inputs = [
            self.create_subscription(BeaconRanges, "beacons", lambda m: self._on_message(BEACONS, m), qos),
            self.create_subscription(Odometry, "odometry", lambda m: self._on_message(ODOMETRY, m), qos),
        ]
        return TransitionCallbackReturn.SUCCESS

    def apply_live(self, changes: dict) -> None:
        config = config_of({**self.parameter_values(), **changes})
        self._config = config
        if self.localizer is not None:
            self.localizer.config = config

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self._sync.reset()
        return super().on_activate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._inputs, self._outputs, self.localizer, self._sync = [], {}, None, None
        return super().on_cleanup(state)  # destroys what configure made

    def _on_pair(self, reading: BeaconRanges, odometry: Odometry) -> None:
        try:
            self._localize(reading, odometry)
        except Exception as error:  # a localizer bug must not take the node down
            self.get_logger().error(
                f"beacon update failed: {type(error).__name__}: {error}", throttle_duration_sec=WARNING_PERIOD
            )

    def _localize(self, reading: BeaconRanges, odometry: Odometry) -> None:
        positions = messages.beacon_positions(reading)
        if self.localizer is None or not np.array_equal(positions, self.localizer.beacons):
            if self.localizer is not None:
                self.warn_throttled("the beacon positions changed: localizer rebuilt")
            initial = tuple(self.get_parameter("initial_pose").value)
            self.localizer = BeaconLocalizer(positions, self._config, initial)
        odom = messages.odometry_pose(odometry)
        localizer = self.localizer
        status = LocalizerStatus(clusters=1)
        try:
            update = localizer.update(odom, list(reading.ranges), reading.compass)
        except OdometryError as error:
            self.warn_throttled(f"beacon reading refused ({error})")
            return
        except BeaconError as error:
            self.warn_throttled(f"beacon reading refused ({error})")
            status.event = str(error)
            localizer.track(odom)
            localized = False
        else:
            checked = BeaconReading.checked(list(reading.ranges), reading.compass, len(localizer.beacons))
            localized = localizer.mismatch(localizer.pose, checked) <= localizer.config.threshold
            status.updated = True
            status.update_time = update.search_time
            if update.relocalized:
                status.event = (
                    f"relocalized: mismatch {update.mismatch:.3f} -> {update.search.cost:.3f}, "
                    f"{update.search.evaluations} evaluations"
                )
        status.localized = localized
        status.confidence = 1.0 if localized else 0.0  # the pyramid search's verdict: no probability of its own
        x, y, theta = localizer.pose
        sigma_xy = self._config.resolution
        sigma_theta = reading.compass_noise_std if reading.compass_noise_std > 0.0 else math.radians(1.0)
        pose = PoseEstimate(x, y, theta, np.diag([sigma_xy**2, sigma_xy**2, sigma_theta**2]))
        self._publish_estimate(reading.header.stamp, odometry, pose, localized, status)


def main(args=None) -> None:
    run(BeaconLocalizerNode, args=args)


if __name__ == "__main__":
    main()
