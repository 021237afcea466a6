import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from amr_turtlebot3.odometry import PoseDifferentiator, PoseSample, Verdict
from amr_util.geometry import wrap_angle


def run(samples):
    differentiator = PoseDifferentiator()
    return [differentiator.update(PoseSample(*s)) for s in samples]


def test_first_sample_gives_zero_twist():
    (first,) = run([(1.0, 3.0, 4.0, 0.5)])
    assert first.verdict is Verdict.FIRST and first.linear == 0.0 and first.angular == 0.0


def test_straight_line_along_a_diagonal_heading():
    heading = math.radians(30)
    samples = [(0.1 * k, 0.02 * k * math.cos(heading), 0.02 * k * math.sin(heading), heading) for k in range(5)]
    estimates = run(samples)[1:]
    assert all(e.linear == pytest.approx(0.2) and e.angular == pytest.approx(0.0, abs=1e-12) for e in estimates)


def test_reversing_gives_negative_speed():
    estimates = run([(0.0, 0.0, 0.0, 0.0), (0.5, -0.05, 0.0, 0.0)])
    assert estimates[1].linear == pytest.approx(-0.1)


def test_arc_recovers_speed_and_turn_rate():
    v, w, dt = 0.15, 0.6, 0.05
    radius = v / w
    samples = [
        (k * dt, radius * math.sin(w * k * dt), radius * (1 - math.cos(w * k * dt)), wrap_angle(w * k * dt))
        for k in range(200)
    ]
    for estimate in run(samples)[1:]:
        assert estimate.angular == pytest.approx(w, rel=1e-9)
        # the chord is slightly shorter than the arc: v * sinc(w dt / 2)
        assert estimate.linear == pytest.approx(v * math.sin(w * dt / 2) / (w * dt / 2), rel=1e-9)


def test_spin_in_place():
    estimates = run([(k * 0.1, 1.0, 2.0, wrap_angle(-1.5 * k * 0.1)) for k in range(50)])[1:]
    assert all(e.linear == pytest.approx(0.0, abs=1e-12) and e.angular == pytest.approx(-1.5) for e in estimates)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_heading_wrap_at_pi_keeps_speed_positive(direction):
    before, after = direction * math.radians(179), -direction * math.radians(179)
    x_step = 0.01 * math.cos(math.pi)
    estimates = run([(0.0, 0.0, 0.0, before), (0.1, x_step, 0.0, after)])
    assert estimates[1].angular == pytest.approx(direction * math.radians(2) / 0.1)
    assert estimates[1].linear == pytest.approx(0.1, rel=1e-3)


@pytest.mark.parametrize("bad", [(math.nan, 0.0, 0.0, 0.0), (1.0, math.inf, 0.0, 0.0), (1.0, 0.0, 0.0, math.nan)])
def test_non_finite_samples_are_rejected_and_state_kept(bad):
    differentiator = PoseDifferentiator()
    differentiator.update(PoseSample(0.0, 0.0, 0.0, 0.0))
    assert differentiator.update(PoseSample(*bad)).verdict is Verdict.NON_FINITE
    assert differentiator.update(PoseSample(1.0, 0.3, 0.0, 0.0)).linear == pytest.approx(0.3)


@pytest.mark.parametrize("stamp", [1.0, 0.5])
def test_repeated_or_older_stamps_are_rejected(stamp):
    differentiator = PoseDifferentiator()
    differentiator.update(PoseSample(1.0, 0.0, 0.0, 0.0))
    assert differentiator.update(PoseSample(stamp, 5.0, 0.0, 0.0)).verdict is Verdict.NOT_LATER
    assert differentiator.update(PoseSample(2.0, 0.2, 0.0, 0.0)).linear == pytest.approx(0.2)


@given(
    st.lists(
        st.tuples(
            st.floats(allow_nan=True, allow_infinity=True, width=64),
            st.floats(-1e6, 1e6),
            st.floats(-1e6, 1e6),
            st.floats(-10, 10),
        ),
        max_size=20,
    )
)
def test_never_raises_and_never_outputs_nan(samples):
    for estimate in run(samples):
        assert math.isfinite(estimate.linear) and math.isfinite(estimate.angular)


def test_huge_jump_over_tiny_dt_is_rejected():
    estimates = run([(0.0, 0.0, 0.0, 0.0), (1e-320, 1e300, 0.0, 0.0)])
    assert estimates[1].verdict is Verdict.OVERFLOW
