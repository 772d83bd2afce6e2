"""Truth tests of the seed-001 virtual experiments (hydro_envs.plants.force_actuator.experiments)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydro_envs.data.measured import MeasuredDataError, load_measured
from hydro_envs.plants.force_actuator import model as fa
from hydro_envs.plants.force_actuator import experiments as fe

NOMINAL = fa.ForceActuatorParams()
FRICTIONLESS = dataclasses.replace(NOMINAL, coulomb_friction=0.0, stiction_retract=0.0, stiction_extend=0.0)
RAMP = 4.0  # s per full leg (-current_max -> +current_max: -45 mA -> +45 mA, 22.5 mA/s)
LEVELS = np.array([-600.0, -300.0, 0.0, 300.0, 600.0])


def _ramp_lag() -> float:
    """DC group delay [s] of valve G(s) and fluid D(s) (Pade delay + eq (8) resonances)."""
    lag = 1.0 / fa.VALVE_A + 1.0 / fa.VALVE_B - 1.0 / fa.VALVE_C + fa.FLUID_DELAY
    return lag + sum(2.0 * z / w for w, z in fa.FLUID_RESONANCES)


@pytest.fixture(scope="module")
def blocked_ideal():
    return fe.blocked_force_test(FRICTIONLESS, ramp_time=RAMP)


@pytest.fixture(scope="module")
def blocked_nominal():
    return fe.blocked_force_test(NOMINAL, ramp_time=RAMP)


@pytest.fixture(scope="module")
def hanging():
    return fe.hanging_mass_test()


def test_blocked_matches_static_characteristic(blocked_ideal):
    r = blocked_ideal
    m = r["branch"] != 0
    err = np.abs(r["f_true"] - r["f_static"])[m]
    # slow ramp: only the ~9 ms valve/fluid lag separates them (14 N); tolerance 2 % of A1 ps
    assert err.max() < 0.02 * NOMINAL.max_thrust
    assert r["clamps"] == 0
    # saturation at +A1 ps and -A2 ps
    assert r["f_true"].max() == pytest.approx(NOMINAL.max_thrust, rel=1e-3)
    assert r["f_true"].min() == pytest.approx(NOMINAL.min_thrust, rel=1e-3)
    # the xi trace is the kernel's valve state, near the quasi-static one
    _, xi_qs = fe.quasi_static_force(FRICTIONLESS, r["i"])
    assert np.max(np.abs(r["xi"] - xi_qs)[m]) < 0.02


def test_blocked_nominal_friction_bounded(blocked_nominal):
    """The seals' pre-sliding friction shifts the locked characteristic by at most the stiction level."""
    r = blocked_nominal
    m = r["branch"] != 0
    dev = (r["f_static"] - r["f_true"])[m]
    assert np.max(np.abs(dev)) < max(NOMINAL.stiction_extend, NOMINAL.stiction_retract) + 20.0
    # rising force: friction takes ~ +54 N (extend), falling: ~ -99 N (retract), mid-range
    mid = np.abs(r["f_true"]) < 500.0
    up = m & mid & (r["branch"] == 1)
    dn = m & mid & (r["branch"] == -1)
    assert np.median((r["f_static"] - r["f_true"])[up]) == pytest.approx(NOMINAL.stiction_extend, abs=15.0)
    assert np.median((r["f_static"] - r["f_true"])[dn]) == pytest.approx(-NOMINAL.stiction_retract, abs=15.0)


def test_positive_bias_at_zero_valve_position():
    """Without the valve offset (001 sec. 3.1) zero current gives the single-rod bias (A1 - A2) ps / 2."""
    p = dataclasses.replace(FRICTIONLESS, valve_offset=0.0)
    r = fe.blocked_force_test(p, ramp_time=RAMP)
    bias = 0.5 * p.rod_area * p.supply_pressure  # 122.9 N
    f0 = []
    for br in (1, -1):
        s = r["branch"] == br
        f0.append(np.interp(0.0, r["i"][s][::br], r["f_true"][s][::br]))
    assert f0[0] < bias < f0[1]  # hysteresis brackets it
    assert 0.5 * (f0[0] + f0[1]) == pytest.approx(bias, abs=5.0)


def test_offset_nulls_force_at_zero_current(blocked_ideal):
    r = blocked_ideal
    f0 = [np.interp(0.0, r["i"][r["branch"] == b][::b], r["f_true"][r["branch"] == b][::b]) for b in (1, -1)]
    assert 0.5 * (f0[0] + f0[1]) == pytest.approx(0.0, abs=5.0)


def test_branch_width_is_hysteresis_width(blocked_ideal):
    r = blocked_ideal
    di = fe.branch_current_offset(r["i"], r["f_true"], r["branch"], LEVELS)
    width = NOMINAL.hysteresis_width * NOMINAL.rated_current  # 1.875 mA
    rate = 2 * NOMINAL.current_max / RAMP
    # quasi-static reference: exactly the configured width
    ref = fe.branch_current_offset(r["i"], r["f_static"], r["branch"], LEVELS)
    assert np.allclose(ref, width, atol=1e-6)
    # experiment: width + the ramp lag on both branches (2 rate tau = 0.42 mA at 22.5 mA/s)
    assert np.allclose(di, width + 2 * rate * _ramp_lag(), atol=0.05e-3)
    assert np.all(np.abs(di - width) < 0.25 * width)


def test_hanging_mass_steady_force_balance(hanging):
    h = hanging
    assert h["steady"].all()
    assert np.all(h["velocity"] > 0)
    for k in range(h["mass"].size):
        res = fe.steady_force_balance_residual(NOMINAL, h["xi"][k], h["velocity"][k], h["load"][k])
        assert abs(res) < 1.0, (k, res)
    # more load -> faster, at every current; force = blocked force + m g
    v = h["velocity"].reshape(3, 4)
    assert np.all(np.diff(v, axis=1) > 0)
    assert np.allclose(h["force"], h["f_blocked"] + h["mass"] * fe.G)
    # the locked phase measures the quasi-static blocked force (friction-shifted by < stiction)
    fq, _ = fe.quasi_static_force(NOMINAL, np.array([0.0, 0.005, 0.010, 0.015]))
    assert np.allclose(h["f_blocked"].reshape(3, 4)[:, 0], fq[1:], atol=NOMINAL.stiction_extend + 5.0)


def test_files_load(tmp_path, hanging):
    r = fe.blocked_force_test(NOMINAL, ramp_time=0.5, noise_std=2.0, seed=1, path=tmp_path / "blocked.csv")
    d = load_measured(r["path"])
    assert d.plant == "force_actuator"
    assert np.allclose(d["i"], r["i"]) and np.allclose(d["f"], r["f"], atol=1e-6)
    assert np.std(r["f"] - r["f_true"]) == pytest.approx(2.0, rel=0.1)
    h = fe.hanging_mass_test(masses=(0.0, 5.0), currents=(0.01,), path=tmp_path / "hang.csv")
    with pytest.raises(MeasuredDataError, match="gap"):  # one run after the other, a step apart: gaps
        load_measured(h["path"], allow_extra=True)
    dh = load_measured(h["path"], allow_extra=True, allow_gaps=True)
    assert len(dh.segments) == 2  # one segment per run (2 masses x 1 current)
    assert {"i", "f", "v", "load"} <= set(dh.names)
    assert np.all(np.diff(dh.t) > 0)
    assert np.allclose(h["velocity"], hanging["velocity"][4:7:2])
