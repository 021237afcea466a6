"""Approximate-time synchronizer: N message streams in, sets of one message per stream out.

Why our own: message_filters is not on our registries, and its Python
``ApproximateTimeSynchronizer`` is not the ROS approximate-time *policy*.
This module follows the policy of message_filters' C++
``sync_policies::ApproximateTime`` (the one documented on the ROS wiki):

* every published set holds one message per input, and its stamps span at
  most ``slop`` (``max(stamps) - min(stamps) <= slop``);
* each message is used at most once, and sets never cross: for every input,
  the stamps of successive sets strictly increase (older messages are
  discarded once a later set is published);
* among the candidate sets that contain the "pivot" (the latest of the
  oldest queued message of each input), the one with the smallest spread is
  published, and only once it is provably optimal, i.e. once no message still
  to come can form a better set. Hence the output is a function of the stamps
  alone, not of the order in which the inputs interleave, as long as each
  input delivers its own messages in stamp order and no queue overflows.

How it is computed (and how that differs from the C++ code). The C++ code
keeps its search state (candidate, pivot, "past" vectors) between
arrivals. Here every ``add`` re-runs the same sweep from scratch over
per-input queues kept sorted by stamp: with queues of a few messages this
costs microseconds and leaves no hidden state to get wrong. Kept from C++:
the pivot and candidate sweep, the age penalty (default 0.1, a newer
candidate must beat the older one by that margin), the maximum interval
(our ``slop``), the rule that an input which just overflowed cannot be the
pivot, and the optional inter-message lower bounds (the "virtual" search
that proves a candidate optimal before the next message of a silent input
arrives; for two inputs without bounds it can never succeed, so it only
matters when bounds are given). Differences: queues are sorted by stamp
(C++ assumes arrival in stamp order and only warns otherwise); a message
whose stamp is not newer than the last published one of its input is
dropped on arrival (C++ would queue it), which makes repeated stamps
harmless; messages older than the current candidate are discarded at
publication rather than when the candidate is formed, so under overflow the
two may pick different sets.

How message_filters' Python ``ApproximateTimeSynchronizer`` differs (read
from ros2/message_filters ``src/message_filters/__init__.py``): it is greedy.
On every arrival it pairs the new message with the queued message of each
other input nearest to it in time and publishes the first combination
within slop at once, without waiting for a better partner; the new message
is always in the set, so the sets depend on arrival order. Only the used
messages are removed, so an older unused message can be paired later with
a newer one and the output stamps can go backwards (sets cross). Queues are
dicts keyed by stamp, so a second message with the same stamp on one input
silently replaces the first. Its slop test is strict (``spread < slop``);
here, as in C++, ``spread <= slop`` is accepted.

Stamps that jump: a message more than ``jump_threshold`` older than the last
published stamp of its input is not "late" but a sign that the clock jumped
(time going backwards after a simulator reset, or normal stamps resuming after
one bad stamp far in the future, which would otherwise make every later
message "late" forever). The synchronizer then forgets its queues and history,
counts a ``clock_jumps``, calls ``on_jump`` and goes on from that message, as
rclpy's time-jump handling resets what depends on the clock.

Lockstep note: a set is published when the stamps prove it optimal. If a
simulator stamps the /odometry and /scan of one step identically, the pair
goes out as soon as both arrive. If their stamps differ, the synchronizer
waits for the next message of the earlier input, which in lockstep never
comes unless ``inter_message_lower_bounds`` (e.g. half the step period)
tell it that no closer message can follow.
"""

from __future__ import annotations

import bisect
import itertools
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from numbers import Integral
from typing import Any

from amr_util.geometry import is_finite_number
from amr_util.stamps import NANOSECONDS_PER_SECOND


class SyncError(ValueError):
    """A synchronizer was built or fed with invalid arguments."""


@dataclass
class SyncStats:
    """Counters the node can log: what was published and why messages were dropped."""

    published: int = 0
    dropped_late: int = 0  # stamp not newer than the last published one of its input
    dropped_unmatched: int = 0  # could never be in a set within slop (or its partner overflowed)
    dropped_overflow: int = 0  # oldest message pushed out of a full queue
    dropped_superseded: int = 0  # older than a published set, never used
    clock_jumps: int = 0  # stamps went back by more than jump_threshold: history forgotten


@dataclass(order=True)
class _Entry:
    stamp: int
    seq: int
    message: Any = field(compare=False)


def _positive_seconds_to_ns(name: str, value: Any) -> int:
    if not is_finite_number(value) or value < 0:
        raise SyncError(f"{name} must be a finite number of seconds >= 0, got {value!r}")
    return round(float(value) * NANOSECONDS_PER_SECOND)


def checked_stamp(message: Any) -> int:
    """Integer nanoseconds of ``message.header.stamp``; SyncError saying what is wrong with a malformed (nanosec out
    of range) or negative stamp (rclpy's Time.from_msg raises ValueError on a negative sec instead)."""
    stamp = message.header.stamp
    if not 0 <= stamp.nanosec < NANOSECONDS_PER_SECOND:
        raise SyncError(f"a message with a malformed stamp (nanosec {stamp.nanosec}) was dropped")
    stamp_ns = stamp.sec * NANOSECONDS_PER_SECOND + stamp.nanosec
    if stamp_ns < 0:
        raise SyncError("a message with a negative stamp was dropped")
    return stamp_ns


class ApproximateTimeSynchronizer:
    """Calls ``callback(*messages)`` with one message per input whenever a set is decided.

    Stamps are integer nanoseconds (``rclpy.time.Time.from_msg(stamp).nanoseconds``
    or :func:`amr_util.stamps.to_nanoseconds`); ``slop`` and the lower bounds are in seconds.
    Thread-safe: ``add`` may be called from several executor threads; the
    callback runs inside the lock, in publication order, so it must not call
    ``add`` from another thread and wait for it.
    """

    def __init__(
        self,
        n_inputs: int,
        slop: float,
        queue_size: int,
        callback: Callable[..., Any],
        *,
        age_penalty: float = 0.1,
        inter_message_lower_bounds: Sequence[float] | None = None,
        jump_threshold: float = 1.0,
        on_jump: Callable[[int, int], Any] | None = None,
    ) -> None:
        if isinstance(n_inputs, bool) or not isinstance(n_inputs, Integral) or n_inputs < 2:
            raise SyncError(f"n_inputs must be an integer >= 2, got {n_inputs!r}")
        if isinstance(queue_size, bool) or not isinstance(queue_size, Integral) or queue_size < 1:
            raise SyncError(f"queue_size must be an integer >= 1, got {queue_size!r}")
        if not callable(callback):
            raise SyncError(f"callback must be callable, got {callback!r}")
        if not is_finite_number(age_penalty) or age_penalty < 0:
            raise SyncError(f"age_penalty must be a finite number >= 0, got {age_penalty!r}")
        bounds = [0.0] * n_inputs if inter_message_lower_bounds is None else list(inter_message_lower_bounds)
        if len(bounds) != n_inputs:
            raise SyncError(f"inter_message_lower_bounds needs {n_inputs} values (one per input), got {len(bounds)}")
        self._n = int(n_inputs)
        self._slop = _positive_seconds_to_ns("slop", slop)
        self._queue_size = int(queue_size)
        self._callback = callback
        self._age_factor = 1.0 + float(age_penalty)
        self._bounds = [_positive_seconds_to_ns(f"inter_message_lower_bounds[{i}]", b) for i, b in enumerate(bounds)]
        self._jump = _positive_seconds_to_ns("jump_threshold", jump_threshold)
        self._on_jump = on_jump
        self._lock = threading.RLock()
        self._seq = itertools.count()
        self.reset()

    @property
    def n_inputs(self) -> int:
        return self._n

    @property
    def stats(self) -> SyncStats:
        """A copy of the counters."""
        with self._lock:
            return SyncStats(**vars(self._stats))

    def queue_lengths(self) -> list[int]:
        """Messages waiting per input (for diagnostics)."""
        with self._lock:
            return [len(q) for q in self._queues]

    def reset(self) -> None:
        """Forget every queued message and the publication history (lifecycle cleanup)."""
        with self._lock:
            self._stats = SyncStats()
            self._forget()

    def _forget(self) -> None:
        """Drop the queues and the publication history (not the counters)."""
        self._queues: list[list[_Entry]] = [[] for _ in range(self._n)]
        self._last_published: list[int | None] = [None] * self._n
        self._overflowed = [False] * self._n

    def add_stamped(self, index: int, message: Any) -> int:
        """add() with the stamp of ``message.header`` (a ROS message), checked by checked_stamp: the one input stamp
        check of the suite's nodes. Raises SyncError saying what is wrong with a malformed or negative stamp."""
        return self.add(index, checked_stamp(message), message)

    def add(self, index: int, stamp_ns: int, message: Any) -> int:
        """Queue ``message`` of input ``index`` stamped ``stamp_ns``; returns the number of sets published."""
        if isinstance(index, bool) or not isinstance(index, Integral) or not 0 <= index < self._n:
            raise SyncError(f"index must be an integer in [0, {self._n}), got {index!r}")
        if isinstance(stamp_ns, bool) or not isinstance(stamp_ns, Integral) or stamp_ns < 0:
            raise SyncError(f"stamp_ns must be an integer number of nanoseconds >= 0, got {stamp_ns!r}")
        with self._lock:
            last = self._last_published[index]
            if last is not None and stamp_ns <= last:
                if last - stamp_ns <= self._jump:
                    self._stats.dropped_late += 1
                    return 0
                self._forget()
                self._stats.clock_jumps += 1
                if self._on_jump is not None:
                    self._on_jump(index, stamp_ns - last)
            queue = self._queues[index]
            bisect.insort(queue, _Entry(int(stamp_ns), next(self._seq), message))
            published = self._process()
            # As in C++, the new message takes part in one search before the oldest is pushed out.
            if len(queue) > self._queue_size:
                del queue[0]
                self._stats.dropped_overflow += 1
                self._overflowed[index] = True
                published += self._process()
            return published

    def _process(self) -> int:
        published = 0
        while all(self._queues):
            outcome = self._search()
            if outcome is None:
                break
            published += outcome
        return published

    def _search(self) -> int | None:
        """One sweep from the queue heads: 1 if a set was published, 0 if a head was dropped, None to wait."""
        queues = self._queues
        pos = [0] * self._n
        pivot = -1
        pivot_time = cand_start = cand_end = 0
        cand: list[int] = []
        while True:
            times = [queues[i][pos[i]].stamp for i in range(self._n)]
            end_index = max(range(self._n), key=times.__getitem__)  # first index among ties
            start_index = min(range(self._n), key=times.__getitem__)
            end_time, start_time = times[end_index], times[start_index]
            for i in range(self._n):
                if i != end_index:
                    self._overflowed[i] = False  # no lost message could have paired better
            if pivot < 0:
                if end_time - start_time > self._slop or self._overflowed[end_index]:
                    # The oldest head can never join a set within slop (later messages only get later).
                    del queues[start_index][0]
                    self._stats.dropped_unmatched += 1
                    return 0
                pivot, pivot_time = end_index, end_time
                cand, cand_start, cand_end = list(pos), start_time, end_time
            elif (end_time - cand_end) * self._age_factor < start_time - cand_start:
                cand, cand_start, cand_end = list(pos), start_time, end_time
            pos[start_index] += 1
            if start_index == pivot or (end_time - cand_end) * self._age_factor >= pivot_time - cand_start:
                # Every later candidate contains [pivot_time, end_time]: none can be better.
                self._publish(cand)
                return 1
            if pos[start_index] == len(queues[start_index]):
                return 1 if self._virtual_search(pos, pivot_time, cand_start, cand_end, cand) else None

    def _virtual_search(self, pos: list[int], pivot_time: int, cand_start: int, cand_end: int, cand: list[int]) -> bool:
        """Try to prove the candidate optimal with optimistic stamps for the inputs that ran dry."""
        queues = self._queues
        vpos = list(pos)
        while True:
            times = []
            for i in range(self._n):
                if vpos[i] < len(queues[i]):
                    times.append(queues[i][vpos[i]].stamp)
                else:  # the earliest a next message of input i could be stamped, but no earlier than the pivot
                    times.append(max(queues[i][-1].stamp + self._bounds[i], pivot_time))
            end_index = max(range(self._n), key=times.__getitem__)
            start_index = min(range(self._n), key=times.__getitem__)
            grown = (times[end_index] - cand_end) * self._age_factor
            if grown >= pivot_time - cand_start:
                self._publish(cand)
                return True
            if grown < times[start_index] - cand_start:
                return False  # an optimistic future candidate would be better: wait
            vpos[start_index] += 1  # start_time < pivot_time here, so this is a real message

    def _publish(self, cand: list[int]) -> None:
        messages = []
        for i, queue in enumerate(self._queues):
            entry = queue[cand[i]]
            messages.append(entry.message)
            self._stats.dropped_superseded += cand[i]
            # Drop the used message, everything older, and later duplicates of its stamp.
            cut = bisect.bisect_right(queue, entry.stamp, key=lambda e: e.stamp)
            self._stats.dropped_late += cut - cand[i] - 1
            del queue[:cut]
            self._last_published[i] = entry.stamp
        self._stats.published += 1
        self._callback(*messages)
