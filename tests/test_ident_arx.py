"""ARX identification (identification/arx.py) checked against systems with known coefficients.

The reference system is the closed-loop ARX(3, 3, 1) model of the rodless cylinder, 004 eq
(32); excitation is an M-sequence (``scipy.signal.max_len_seq``), as in 004 sec. 4.2 and the
PRBS of 001. Noise is seeded, so every number below is reproducible.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import signal

from identification.arx import (
    SEED_004_EQ32,
    ArxError,
    fit_arx,
    fit_percent,
    select_arx_order,
)

A32 = np.array(SEED_004_EQ32["a"])
B32 = np.array(SEED_004_EQ32["b"])
THETA32 = np.concatenate([A32[1:], B32])


def mls(nbits: int, n: int, hold: int = 1, seed_state: int | None = None) -> np.ndarray:
    """+-1 M-sequence of ``nbits`` (period 2^nbits - 1), each bit held ``hold`` samples."""
    state = None
    if seed_state is not None:
        state = np.array([(seed_state >> i) & 1 for i in range(nbits)], dtype=np.int8)
        if not state.any():
            state[0] = 1
    seq = signal.max_len_seq(nbits, state=state)[0].astype(float) * 2.0 - 1.0
    seq = np.repeat(seq, hold)
    reps = int(math.ceil(n / seq.size))
    return np.tile(seq, reps)[:n]


def arx_data(a, b, nk, u, sigma_e, rng):
    """Equation-error ARX: A y = B u + e."""
    e = sigma_e * rng.standard_normal(u.size)
    b_full = np.concatenate([np.zeros(nk), b])
    return signal.lfilter(b_full, a, u) + signal.lfilter([1.0], a, e)


def test_recovers_seed_004_eq32_coefficients_with_equation_noise():
    rng = np.random.default_rng(0)
    u = mls(10, 20000, hold=2)
    y = arx_data(A32, B32, 1, u, 0.05, rng)
    m = fit_arx(y, u, 3, 3, 1, dt=1e-3)
    err = m.theta - THETA32
    se = np.concatenate([m.std_a, m.std_b])
    assert np.all(np.abs(err) < 4.0 * se), (err, se)
    assert np.max(np.abs(err)) < 5e-3  # tight: 0.35 % of the largest coefficient
    # the residual variance is the equation-noise variance
    assert m.noise_variance == pytest.approx(0.05**2, rel=0.05)
    np.testing.assert_allclose(np.sort_complex(m.poles), np.sort_complex(np.roots(A32)), atol=5e-3)
    np.testing.assert_allclose(np.sort_complex(m.zeros), np.sort_complex(np.roots(B32)), atol=5e-2)
    assert m.is_stable
    # the pole at z = 0.9965 makes the DC gain (81) sensitive: check it against its own
    # delta-method standard error
    assert abs(m.dc_gain() - B32.sum() / A32.sum()) < 4 * m.dc_gain_std()


def test_standard_errors_match_the_monte_carlo_spread():
    """Across independent noise draws the estimates scatter by the reported std errors."""
    u = mls(9, 3000, hold=2)
    est, ses = [], []
    for seed in range(40):
        y = arx_data(A32, B32, 1, u, 0.5, np.random.default_rng(100 + seed))
        m = fit_arx(y, u, 3, 3, 1)
        est.append(m.theta)
        ses.append(np.concatenate([m.std_a, m.std_b]))
    spread = np.std(est, axis=0, ddof=1)
    ratio = spread / np.mean(ses, axis=0)
    assert np.all((ratio > 0.6) & (ratio < 1.5)), ratio


def test_closed_loop_direct_identification_as_in_004_sec_4_2():
    """P controller plus an M-sequence on the controller output; ARX fits (u, y) directly."""
    rng = np.random.default_rng(1)
    n = 16000
    dither = mls(10, n, hold=3, seed_state=5)
    ref = 20.0 * np.sign(np.sin(2 * np.pi * np.arange(n) / 2000.0))
    kp = 0.01
    b_full = np.concatenate([[0.0], B32])
    y = np.zeros(n)
    u = np.zeros(n)
    e = 0.02 * rng.standard_normal(n)
    for t in range(n):
        acc = e[t]
        for i in range(1, 4):
            if t - i >= 0:
                acc += -A32[i] * y[t - i] + b_full[i] * u[t - i]
        y[t] = acc
        u[t] = kp * (ref[t] - y[t]) + dither[t]
    m = fit_arx(y, u, 3, 3, 1)
    err = m.theta - THETA32
    se = np.concatenate([m.std_a, m.std_b])
    assert np.all(np.abs(err) < 4.0 * se), (err, se)
    assert np.max(np.abs(err)) < 1e-2, (err, se)


def test_output_error_noise_biases_least_squares_and_iv_removes_the_bias():
    """White noise on the measured output (OE system): LS is inconsistent, IV is not."""
    rng = np.random.default_rng(2)
    a = np.array([1.0, -1.5, 0.7])  # poles 0.75 +- 0.37i
    b = np.array([1.0, 0.5])
    u = mls(10, 20000, hold=1)
    y0 = signal.lfilter(np.concatenate([[0.0], b]), a, u)
    y = y0 + 0.5 * rng.standard_normal(u.size)  # output noise, 10 % of the output std
    theta_true = np.concatenate([a[1:], b])
    ls = fit_arx(y, u, 2, 2, 1)
    iv = fit_arx(y, u, 2, 2, 1, method="iv")
    ls_err = np.abs(ls.theta - theta_true)
    iv_err = np.abs(iv.theta - theta_true)
    se_iv = np.concatenate([iv.std_a, iv.std_b])
    assert ls_err.max() > 0.02  # LS visibly biased ...
    assert ls_err.max() > 10 * np.concatenate([ls.std_a, ls.std_b]).max()  # ... far beyond its std errors
    assert iv_err.max() < 0.01  # IV within 1 % of the coefficients
    assert np.all(iv_err < 4 * se_iv)


def test_order_and_delay_selection_picks_the_true_structure():
    """ARX(2, 2, 3): two extra delays, as 001 eq (6) (b starts at z^-3)."""
    rng = np.random.default_rng(3)
    a = np.array([1.0, -1.2, 0.5])
    b = np.array([0.8, 0.4])
    u = mls(10, 5000, hold=2)
    y = arx_data(a, b, 3, u, 0.05, rng)
    uv = mls(10, 3000, hold=3, seed_state=77)
    yv = arx_data(a, b, 3, uv, 0.05, np.random.default_rng(4))
    for crit in ("bic", "aic", "fpe", "validation"):
        sel = select_arx_order(y, u, range(1, 5), range(1, 5), range(0, 5), criterion=crit,
                               validation_data=(yv, uv))
        if crit == "bic" or crit == "validation":
            assert sel.orders == (2, 2, 3), (crit, sel.orders)
        else:  # AIC/FPE are not consistent: they may add a term, but never miss the delay
            assert sel.orders[2] == 3 and sel.orders[0] >= 2 and sel.orders[1] >= 2, (crit, sel.orders)
        assert sel.margin > 0
    sel = select_arx_order(y, u, range(1, 5), range(1, 5), range(0, 5), criterion="bic")
    np.testing.assert_allclose(sel.best.a, a, atol=5e-3)
    np.testing.assert_allclose(sel.best.b, b, atol=5e-3)
    # every candidate was fitted on the same rows
    assert len({row["n_samples"] for row in sel.table}) == 1
    js = json.loads(json.dumps(sel.to_json_dict(), allow_nan=False))
    assert js["orders"] == {"na": 2, "nb": 2, "nk": 3}
    assert len(js["candidates"]) == 4 * 4 * 5


def test_free_run_fit_is_high_on_held_out_data():
    rng = np.random.default_rng(5)
    u = mls(10, 6000, hold=2)
    y = arx_data(A32, B32, 1, u, 0.1, rng)
    m = fit_arx(y, u, 3, 3, 1, dt=1e-3)
    # held-out: different excitation (random steps) and noise
    rng_v = np.random.default_rng(6)
    uv = np.repeat(rng_v.uniform(-1, 1, 60), 50)
    yv_clean = signal.lfilter(np.concatenate([[0.0], B32]), A32, uv)
    yv = yv_clean + signal.lfilter([1.0], A32, 0.1 * rng_v.standard_normal(uv.size))
    val = m.validate(yv, uv)
    assert val["fit_one_step"] > 95.0  # observed 98.7
    # on measured (noisy) held-out data the free run cannot beat the noise, which the pole
    # at z = 0.9965 integrates into drift: the true system itself reaches only 84.6 %
    true_fit = fit_percent(yv[3:], yv_clean[3:])
    assert val["fit_free_run"] > true_fit - 2.0  # observed 85.5
    # against the noise-free held-out output the model's simulation is close to exact
    assert m.validate(yv_clean, uv)["fit_free_run"] > 95.0  # observed 96.8
    assert m.to_json_dict(val)["validation"]["fit_free_run"] == pytest.approx(val["fit_free_run"])


def test_dlti_conversion_and_simulation_agree():
    rng = np.random.default_rng(7)
    u = mls(9, 3000)
    y = arx_data(A32, B32, 1, u, 0.1, rng)
    m = fit_arx(y, u, 3, 3, 1, dt=0.01)
    sys = m.to_dlti()
    assert sys.dt == 0.01
    _, yd = signal.dlsim(sys, u)
    np.testing.assert_allclose(yd[:, 0], m.simulate(u), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.sort_complex(sys.poles[np.abs(sys.poles) > 1e-9]),
                               np.sort_complex(m.poles), atol=1e-9)
    # free run with initial conditions reproduces the measured start exactly
    ys = m.simulate(u, y_init=y[:3])
    assert np.array_equal(ys[:3], y[:3])


def test_tenth_order_structure_of_001_eq6():
    """ARX(10, 8, 3) as 001 eq (6), PRBS at 5 kHz: the poles of a known 10th-order system."""
    rng = np.random.default_rng(8)
    fs = 5000.0
    # five lightly damped pole pairs between 50 Hz and 1.2 kHz
    freqs = np.array([50.0, 150.0, 400.0, 800.0, 1200.0])
    radii = np.array([0.97, 0.95, 0.93, 0.9, 0.85])
    poles = np.concatenate([radii * np.exp(1j * 2 * np.pi * freqs / fs), radii * np.exp(-1j * 2 * np.pi * freqs / fs)])
    a = np.real(np.poly(poles))
    b = np.real(np.poly([0.5, -0.3, 0.2 + 0.3j, 0.2 - 0.3j, -0.6, 0.1, 0.4])) * 0.01
    u = mls(12, 20000)
    y = arx_data(a, b, 3, u, 1e-3, rng)
    m = fit_arx(y, u, 10, 8, 3, dt=1 / fs)
    assert m.n_params == 18
    got = np.sort_complex(m.poles)
    want = np.sort_complex(poles)
    assert np.max(np.abs(got - want)) < 3e-3
    assert m.fit_one_step > 99.0


@pytest.mark.parametrize(
    "y, u, orders, fragment",
    [
        (np.r_[np.ones(50), np.nan], np.ones(51), (2, 2, 1), "NaN"),
        (np.arange(100.0), np.ones(100), (2, 2, 1), "constant"),
        (np.arange(8.0), np.arange(8.0), (2, 2, 1), "regression rows"),
        (np.arange(100.0), np.arange(99.0), (2, 2, 1), "same length"),
        (np.arange(100.0), np.arange(100.0), (2, 0, 1), "nb"),
    ],
)
def test_bad_input_raises_a_clear_error(y, u, orders, fragment):
    with pytest.raises(ArxError, match=fragment):
        fit_arx(y, u, *orders)


def test_rank_deficient_excitation_is_rejected():
    u = np.sin(2 * np.pi * 0.05 * np.arange(500))  # one sinusoid excites only 2 parameters of B
    y = signal.lfilter([0.0, 1.0, 0.5, 0.2], [1.0, -0.5], u)
    with pytest.raises(ArxError, match="rank deficient"):
        fit_arx(y, u, 1, 4, 1)
