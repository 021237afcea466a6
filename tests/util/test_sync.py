"""The approximate-time synchronizer on crafted stamp sequences and random ones (hypothesis)."""

from __future__ import annotations

import random
from itertools import pairwise

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from amr_util.stamps import to_nanoseconds
from amr_util.sync import ApproximateTimeSynchronizer, SyncError

MS = 1_000_000  # nanoseconds per millisecond


class Recorder:
    """Collects published sets as tuples of (input, stamp_ms) messages."""

    def __init__(self) -> None:
        self.sets: list[tuple] = []

    def __call__(self, *messages) -> None:
        self.sets.append(messages)


def make(n=2, slop=0.05, queue_size=10, **kwargs):
    rec = Recorder()
    return ApproximateTimeSynchronizer(n, slop, queue_size, rec, **kwargs), rec


def feed(sync, events):
    """events: (input, stamp_ms); the message is (input, stamp_ms) itself."""
    for index, ms in events:
        sync.add(index, round(ms * MS), (index, ms))


def stamps(rec):
    return [tuple(ms for _, ms in s) for s in rec.sets]


def test_equal_rates_identical_stamps_publish_as_soon_as_complete():
    sync, rec = make()
    for k in range(5):
        sync.add(0, k * 50 * MS, (0, k * 50))
        assert len(rec.sets) == k  # odometry alone is not a set
        assert sync.add(1, k * 50 * MS, (1, k * 50)) == 1
    assert stamps(rec) == [(k * 50, k * 50) for k in range(5)]
    assert sync.queue_lengths() == [0, 0]


def test_equal_rates_with_offset_pair_each_message_with_its_partner():
    sync, rec = make(slop=0.02)
    events = [e for k in range(6) for e in ((0, 100 * k), (1, 100 * k + 10))]
    feed(sync, events)
    # The last pair waits: a closer odometry message could still come.
    assert stamps(rec) == [(100 * k, 100 * k + 10) for k in range(5)]


def test_mixed_rates_pair_slow_input_with_nearest_fast_message():
    sync, rec = make(slop=0.05)
    fast = [(0, 10 * k) for k in range(40)]  # 100 Hz
    slow = [(1, 100 * k + 3) for k in range(4)]  # 10 Hz
    feed(sync, sorted(fast + slow, key=lambda e: e[1]))
    assert stamps(rec) == [(0, 3), (100, 103), (200, 203), (300, 303)]
    assert sync.stats.dropped_superseded > 0  # the fast messages in between are not used


def test_a_dropped_message_leaves_its_partner_unpublished():
    sync, rec = make(slop=0.05)
    events = []
    for k in range(6):
        events.append((0, 100 * k))
        if k != 2:
            events.append((1, 100 * k))
    feed(sync, events)
    assert stamps(rec) == [(0, 0), (100, 100), (300, 300), (400, 400), (500, 500)]
    assert sync.stats.dropped_unmatched == 1


def test_waits_for_a_better_partner_instead_of_greedy_pairing():
    # message_filters' Python version would publish (0, 40) when stamp 40 arrives.
    sync, rec = make(slop=0.1)
    feed(sync, [(0, 0), (1, 40)])
    assert rec.sets == []
    feed(sync, [(0, 50)])
    assert stamps(rec) == [(50, 40)]


def test_out_of_order_arrival_within_an_input_is_sorted_before_deciding():
    sync, rec = make(slop=0.02)
    feed(sync, [(0, 200), (0, 100), (1, 100), (1, 200)])
    assert stamps(rec) == [(100, 100), (200, 200)]


def test_message_older_than_a_published_set_is_dropped():
    sync, rec = make()
    feed(sync, [(0, 100), (1, 100), (0, 50), (1, 50), (0, 200), (1, 200)])
    assert stamps(rec) == [(100, 100), (200, 200)]
    assert sync.stats.dropped_late == 2


def test_duplicate_stamps_are_used_once():
    sync, rec = make()
    feed(sync, [(0, 100), (0, 100), (1, 100), (1, 100), (0, 150), (1, 150)])
    assert stamps(rec) == [(100, 100), (150, 150)]
    assert sync.stats.dropped_late == 2
    assert len({id(m) for s in rec.sets for m in s}) == 4


def test_duplicate_stamps_across_inputs_are_a_perfect_set():
    sync, rec = make(n=3)
    feed(sync, [(0, 10), (2, 10), (1, 10)])
    assert stamps(rec) == [(10, 10, 10)]


def test_queue_overflow_keeps_the_newest_and_pairs_with_the_nearest():
    sync, rec = make(slop=0.05, queue_size=3)
    feed(sync, [(0, 10 * k) for k in range(10)])  # the other input is silent
    assert sync.queue_lengths() == [3, 0]
    assert sync.stats.dropped_overflow == 7
    feed(sync, [(1, 88)])
    assert stamps(rec) == [(90, 88)]


def test_equal_spread_goes_to_the_older_set():
    # 80 and 90 are both 5 ms from 85: the age penalty keeps the older candidate.
    sync, rec = make(slop=0.05)
    feed(sync, [(0, 80), (0, 90), (1, 85)])
    assert stamps(rec) == [(80, 85)]


def test_slop_edge_is_inclusive():
    sync, rec = make(slop=0.05)
    feed(sync, [(0, 0), (1, 50), (0, 100)])
    assert stamps(rec) == [(0, 50)]
    sync2, rec2 = make(slop=0.05)
    sync2.add(0, 0, "a")
    sync2.add(1, 50 * MS + 1, "b")
    sync2.add(0, 100 * MS, "c")
    assert rec2.sets == []
    assert sync2.stats.dropped_unmatched == 1


def test_lockstep_with_different_stamps_needs_lower_bounds():
    # One simulator step stamps odometry at t and the scan 1 ms later.
    sync, rec = make(slop=0.05)
    feed(sync, [(0, 0), (1, 1)])
    assert rec.sets == []  # a closer odometry message could still come: without bounds it waits
    bounded, rec_b = make(slop=0.05, inter_message_lower_bounds=[0.025, 0.025])
    feed(bounded, [(0, 0), (1, 1)])
    assert stamps(rec_b) == [(0, 1)]


def test_reset_forgets_queues_and_history():
    sync, rec = make()
    feed(sync, [(0, 100), (1, 100), (0, 200)])
    sync.reset()
    assert sync.queue_lengths() == [0, 0]
    feed(sync, [(0, 50), (1, 50)])  # older than the set before the reset: accepted again
    assert stamps(rec) == [(100, 100), (50, 50)]
    assert sync.stats.published == 1


def test_to_nanoseconds():
    assert to_nanoseconds(3, 250_000_000) == 3_250_000_000


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(n_inputs=1), "n_inputs"),
        (dict(slop=-0.1), "slop"),
        (dict(slop=float("nan")), "slop"),
        (dict(queue_size=0), "queue_size"),
        (dict(queue_size=2.0), "queue_size"),
        (dict(callback=None), "callback"),
        (dict(age_penalty=-1.0), "age_penalty"),
        (dict(inter_message_lower_bounds=[0.1]), "inter_message_lower_bounds"),
        (dict(inter_message_lower_bounds=[0.1, float("inf")]), r"inter_message_lower_bounds\[1\]"),
    ],
)
def test_invalid_construction_is_refused(kwargs, match):
    args = dict(n_inputs=2, slop=0.1, queue_size=10, callback=print) | kwargs
    with pytest.raises(SyncError, match=match):
        ApproximateTimeSynchronizer(**args)


@pytest.mark.parametrize("index, stamp", [(2, 0), (-1, 0), (True, 0), (0, 1.5), (0, -1), (0, None)])
def test_invalid_add_is_refused(index, stamp):
    sync, _ = make()
    with pytest.raises(SyncError):
        sync.add(index, stamp, "m")


# --- properties -------------------------------------------------------------------------

stamp_lists = st.lists(st.integers(0, 400), min_size=0, max_size=25).map(sorted)


@st.composite
def scenario(draw):
    n = draw(st.integers(2, 3))
    bounds = draw(st.sampled_from([None, 3]))
    per_input = []
    for i in range(n):
        values = draw(stamp_lists)
        if bounds is not None:  # the data must honour the promised minimum spacing
            spaced: list[int] = []
            for v in values:
                if not spaced or v - spaced[-1] >= bounds:
                    spaced.append(v)
            values = spaced
        per_input.append([(i, ms) for ms in values])
    slop_ms = draw(st.sampled_from([0, 5, 20, 60, 1000]))
    seed = draw(st.integers(0, 2**32 - 1))
    return n, per_input, slop_ms, seed, bounds


def interleave(per_input, rng):
    """A random arrival order that keeps each input's own order."""
    cursors = [0] * len(per_input)
    out = []
    while any(c < len(s) for c, s in zip(cursors, per_input, strict=True)):
        i = rng.choice([k for k, s in enumerate(per_input) if cursors[k] < len(s)])
        out.append(per_input[i][cursors[i]])
        cursors[i] += 1
    return out


@settings(max_examples=300, deadline=None)
@given(scenario())
def test_sets_are_within_slop_unique_ordered_and_independent_of_interleaving(case):
    n, per_input, slop_ms, seed, bounds = case
    rng = random.Random(seed)
    results = []
    for _ in range(2):
        lower = None if bounds is None else [bounds / 1000.0] * n
        sync, rec = make(n=n, slop=slop_ms / 1000.0, queue_size=100, inter_message_lower_bounds=lower)
        # Distinct message objects even for duplicate stamps.
        events = interleave(per_input, rng)
        for index, ms in events:
            sync.add(index, ms * MS, [index, ms])
        results.append(rec.sets)
        used = [id(m) for s in rec.sets for m in s]
        assert len(used) == len(set(used)), "a message was used twice"
        for s in rec.sets:
            assert [m[0] for m in s] == list(range(n))
            ms_values = [m[1] for m in s]
            assert max(ms_values) - min(ms_values) <= slop_ms
        for i in range(n):
            seq = [s[i][1] for s in rec.sets]
            assert all(a < b for a, b in pairwise(seq)), "sets cross or repeat a stamp"
    # Output depends on stamps only (as values: duplicates may swap equal-stamp objects).
    assert [[m[1] for m in s] for s in results[0]] == [[m[1] for m in s] for s in results[1]]


@settings(max_examples=300, deadline=None)
@given(scenario(), st.integers(1, 4))
def test_small_queues_keep_the_guarantees_and_bound_memory(case, queue_size):
    n, per_input, slop_ms, seed, _ = case
    sync, rec = make(n=n, slop=slop_ms / 1000.0, queue_size=queue_size)
    for index, ms in interleave(per_input, random.Random(seed)):
        sync.add(index, ms * MS, [index, ms])
        assert max(sync.queue_lengths()) <= queue_size
    used = [id(m) for s in rec.sets for m in s]
    assert len(used) == len(set(used))
    for s in rec.sets:
        assert max(m[1] for m in s) - min(m[1] for m in s) <= slop_ms
    for i in range(n):
        seq = [s[i][1] for s in rec.sets]
        assert all(a < b for a, b in pairwise(seq))
    total = sum(len(p) for p in per_input)
    stats = sync.stats
    dropped = stats.dropped_late + stats.dropped_unmatched + stats.dropped_overflow + stats.dropped_superseded
    assert n * stats.published + dropped + sum(sync.queue_lengths()) == total  # every message accounted for


def test_a_clock_jump_back_is_recovered_from_not_taken_for_late_messages():
    got, jumps = [], []
    sync = ApproximateTimeSynchronizer(
        2,
        0.01,
        10,
        lambda *m: got.append(m),
        jump_threshold=0.5,
        on_jump=lambda index, jump: jumps.append((index, jump)),
    )
    for stamp in (1.0, 1.05, 1e6, 1.10, 1.15):  # 1e6: one bad stamp far ahead, then normal ones
        sync.add(0, int(stamp * 1e9), f"a{stamp}")
        sync.add(1, int(stamp * 1e9), f"b{stamp}")
    assert [a for a, _ in got] == ["a1.0", "a1.05", "a1000000.0", "a1.1", "a1.15"]
    assert sync.stats.clock_jumps == 1 and jumps[0][0] == 0 and jumps[0][1] < -999_000 * 10**9
    sync.add(0, int(1.12 * 1e9), "late")  # a little older than the last set: late, not a jump
    assert sync.stats.dropped_late == 1 and sync.stats.clock_jumps == 1
