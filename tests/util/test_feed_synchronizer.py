"""amr_util.managed_node.ManagedNode.feed_synchronizer: the one way a node's synchronized inputs enter (the path and
wall followers, the localizers, slam): only while active, a bad stamp said, nothing raised out of the callback."""

from __future__ import annotations

from types import SimpleNamespace

from builtin_interfaces.msg import Time
from std_msgs.msg import Header

from amr_util.managed_node import ManagedNode
from amr_util.sync import ApproximateTimeSynchronizer


class _Stamped:
    """A message with a header (what add_stamped reads)."""

    def __init__(self, sec: int, nanosec: int = 0) -> None:
        self.header = Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id="base_scan")


def test_inputs_are_fed_only_while_active_and_no_error_escapes(ros_context):
    node = ManagedNode("feed_probe", context=ros_context)
    sets, warnings = [], []

    def pair(first, second):
        sets.append((first, second))
        if len(sets) == 2:
            raise RuntimeError("the set's own callback failed")

    sync = ApproximateTimeSynchronizer(2, 0.05, 10, pair)

    def feed_pairs(*seconds):
        for sec in seconds:
            node.feed_synchronizer(sync, 0, _Stamped(sec), warnings.append)
            node.feed_synchronizer(sync, 1, _Stamped(sec, 1_000), warnings.append)

    try:
        feed_pairs(1)  # unconfigured: ignored
        assert sync.stats.published == 0
        node.trigger_configure()
        node.trigger_activate()
        assert node.state_label == "active"
        feed_pairs(2, 3, 4)  # the second set's callback raises: logged, not raised out of the feed
        assert len(sets) >= 2 and not warnings
        bad = _Stamped(5)
        bad.header = SimpleNamespace(stamp=SimpleNamespace(sec=-1, nanosec=0))  # said through the node's warning
        node.feed_synchronizer(sync, 0, bad, warnings.append)
        assert len(warnings) == 1 and "negative stamp" in warnings[0]
        node.feed_synchronizer(sync, 0, object(), warnings.append)  # no header at all: logged, not raised
        assert len(warnings) == 1
        node.feed_synchronizer(None, 0, _Stamped(6), warnings.append)  # not configured with one: ignored
        node.trigger_deactivate()
        published = sync.stats.published
        feed_pairs(7, 8, 9)
        assert sync.stats.published == published and len(warnings) == 1
    finally:
        node.destroy_node()
