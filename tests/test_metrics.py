"""agents/metrics.py: friction metrics against values worked out by hand on synthetic signals."""

import math

import numpy as np
import pytest

from agents import metrics as fm

DT = 1e-3


def _triangle(n: int, period: int) -> np.ndarray:
    """Integer triangle 0, 1, ..., period/2, ..., 0, 1, ... (reversals known exactly)."""
    k = np.arange(n) % period
    return np.minimum(k, period - k).astype(float)


def test_moving_mask_ignores_step_jumps_and_reversals_of_a_triangle():
    step = np.r_[np.zeros(100), np.ones(100), 3.0 * np.ones(100)]
    assert not fm.moving_mask(step).any()
    assert fm.reversal_indices(step).size == 0
    r = _triangle(2500, 1000)  # peaks at 500, 1500, 2500 (outside), valleys at 1000, 2000
    mov = fm.moving_mask(r)
    assert not mov[0] and mov[1:].all()
    # the first sample moving the other way: one after each peak / valley
    np.testing.assert_array_equal(fm.reversal_indices(r), [501, 1001, 1501, 2001])


def test_reversal_error_is_the_peak_in_the_window():
    r = _triangle(2500, 1000)
    y = r.copy()
    assert fm.reversal_error(y, r, DT) == 0.0
    y[501 + 50] -= 0.7  # inside the 0.2 s window of the first reversal
    y[1001 + 150] += 0.3  # inside the window of the second
    y[1501 + 300] += 5.0  # outside every window (0.3 s after the third, 0.2 s before the fourth is 2001)
    assert fm.reversal_error(y, r, DT) == pytest.approx((0.7 + 0.3 + 0 + 0) / 4)
    assert fm.reversal_error(y, r, DT, window=0.1) == pytest.approx(0.7 / 4)
    assert fm.reversal_error(r + 0.25, r, DT) == pytest.approx(0.25)
    assert math.isnan(fm.reversal_error(np.zeros(10), np.zeros(10), DT))


def test_reversal_error_of_a_lagging_sine():
    # y(t) = r(t - tau): e = 2 A sin(w tau / 2) cos(w (t - tau / 2)); after a reversal of r at
    # w t0 = pi/2 (mod pi) its modulus grows to 2 A sin(w tau / 2) sin(w (W - tau / 2)) at t0 + W.
    A, f, tau, W = 0.01, 0.5, 0.02, 0.2
    w = 2 * math.pi * f
    t = DT * np.arange(4000)
    r, y = A * np.sin(w * t), A * np.sin(w * (t - tau))
    expect = 2 * A * math.sin(w * tau / 2) * math.sin(w * (W - tau / 2))
    assert fm.reversal_indices(r).size == 4  # peaks at 0.5, 1.5, 2.5, 3.5 s
    assert fm.reversal_error(y, r, DT, window=W) == pytest.approx(expect, rel=0.01)


def test_holds_steady_state_error_and_limit_cycle():
    # two holds of 0.4 s; in the last half of the first the output sits 2e-5 below the level,
    # in the second it oscillates +-3e-5 about it at 25 Hz (40 samples per period)
    r = np.r_[np.zeros(400), 1e-3 * np.ones(400)]
    assert fm.holds(r, DT) == [(0, 400), (400, 800)]
    assert fm.holds(r, DT, min_hold=0.5) == []
    y = r.copy()
    y[:200] = 0.5 * r[:200]  # transient: not in the last half
    y[200:400] = -2e-5
    k = np.arange(200)
    y[600:] = 1e-3 + 3e-5 * np.sin(2 * math.pi * k / 40)
    ss = fm.steady_state_error(y, r, DT, guard=0.0)
    # mean |sin| over 40 samples of a period: sum_{k<20} sin(pi k / 20) / 20 = cot(pi / 40) / 20
    assert ss == pytest.approx((2e-5 + 3e-5 / math.tan(math.pi / 40) / 20) / 2, rel=1e-12)
    assert fm.limit_cycle_amplitude(y, r, DT, guard=0.0) == pytest.approx((0 + 6e-5) / 2)
    # the first half of every hold does not enter: the transient is invisible
    y2 = y.copy()
    y2[:200] += 1.0
    assert fm.steady_state_error(y2, r, DT, guard=0.0) == ss
    # a reference without holds has nothing to measure
    ramp = DT * np.arange(500)
    assert math.isnan(fm.steady_state_error(ramp, ramp, DT))
    assert math.isnan(fm.limit_cycle_amplitude(ramp, ramp, DT))


def test_hold_window_leaves_out_the_preview_anticipation_and_hunting_needs_long_holds():
    """A controller that starts the next step 50 ms early (it sees the reference preview) makes
    no hold error with the default 60 ms guard; hunting counts only holds of 2 s or more."""
    r = np.r_[np.zeros(500), 1e-3 * np.ones(500), np.zeros(2500)]
    y = r.copy()
    y[450:500] = np.linspace(0.0, 0.5e-3, 50)  # early start of the step at 0.5 s
    assert fm.steady_state_error(y, r, DT, guard=0.0) > 0.0
    assert fm.steady_state_error(y, r, DT) == 0.0
    assert fm.limit_cycle_amplitude(y, r, DT) == 0.0
    k = np.arange(2500)
    y[1000:] = 2e-5 * np.sin(2 * math.pi * k / 1000)  # a 1 Hz hunt in the long hold only
    assert fm.hunting(y, r, DT) == pytest.approx(4e-5, rel=1e-3)
    y_short = y.copy()
    y_short[1000:] = 0.0
    assert fm.hunting(y_short, r, DT) == 0.0
    assert math.isnan(fm.hunting(y[:1000], r[:1000], DT))  # no hold of 2 s


def test_stick_time_counts_resting_samples_while_the_reference_moves():
    v = 0.01  # m/s
    r = v * DT * np.arange(1000)
    y = r.copy()
    y[:300] = r[300]  # at rest until sample 300, then moving with the reference
    # moving samples 1..999; the plant rests at 1..300 (y[300] - y[299] = 0 too)
    assert fm.stick_time(y, r, DT) == pytest.approx(300 / 999)
    assert fm.stick_time(r, r, DT) == 0.0
    assert fm.stick_time(np.zeros(1000), r, DT) == 1.0
    # creeping at 10 % of the reference speed is not rest with the default 5 % tolerance
    assert fm.stick_time(0.1 * r, r, DT) == 0.0
    assert fm.stick_time(0.1 * r, r, DT, stick_frac=0.2) == 1.0
    # a step reference never moves: nothing to measure
    step = np.r_[np.zeros(50), np.ones(50)]
    assert math.isnan(fm.stick_time(step, step, DT))


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="y has 3 samples, r has 4"):
        fm.reversal_error(np.zeros(3), np.zeros(4), DT)
    with pytest.raises(ValueError, match=r"dt = 0"):
        fm.stick_time(np.zeros(3), np.zeros(3), 0.0)
    with pytest.raises(ValueError, match=r"tail = 1.5; allowed \(0, 1\]"):
        fm.steady_state_error(np.zeros(300), np.zeros(300), DT, tail=1.5)
    with pytest.raises(ValueError, match="window"):
        fm.reversal_error(np.zeros(3), np.zeros(3), DT, window=-1.0)
    with pytest.raises(ValueError, match="stick_frac"):
        fm.stick_time(np.zeros(3), np.zeros(3), DT, stick_frac=1.0)
