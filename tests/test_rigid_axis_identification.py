"""Rigid-axis inverse-dynamics identification on records from an independent generator.

The records here are not made by the project's slider kernel: a stiff SciPy integrator
(``solve_ivp``, Radau) of ``m x'' = f - F(v)`` with *direction-dependent* friction and no
Stribeck dip, driven by a PI position loop plus excitation (as a positioning rig is run),
sampled on a jittered logger clock (relative jitter 3e-5, as the public rigid-axis records)
with position quantisation and force noise.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from identification.slider import SliderIdentificationError, identify_slider, identify_slider_measured

TRUE = dict(mass=95.0, coulomb_friction_pos=20.0, viscous_friction_pos=170.0,
            coulomb_friction_neg=21.0, viscous_friction_neg=240.0)
DT = 1e-3


def _friction(v):
    pos = TRUE["coulomb_friction_pos"] * np.tanh(v / 1e-4) + TRUE["viscous_friction_pos"] * v
    neg = TRUE["coulomb_friction_neg"] * np.tanh(v / 1e-4) + TRUE["viscous_friction_neg"] * v
    return np.where(v >= 0.0, pos, neg)


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(11)
    duration = 24.0
    # reference: smoothed random levels (pulses of 0.5-2 s) within +-0.08 m
    knots = np.cumsum(rng.uniform(0.5, 2.0, 40))
    levels = rng.uniform(-0.08, 0.08, knots.size)

    def ref(t):
        return float(np.interp(t, knots, levels))

    kp, kd = 20000.0, 1500.0  # PD force loop [N/m], [N s/m] (continuous, outside the plant)

    def rhs(t, y):
        x, v = y
        f = kp * (ref(t) - x) - kd * v + 30.0 * math.sin(2 * math.pi * 3.1 * t)
        f = max(min(f, 300.0), -300.0)
        return [v, (f - float(_friction(np.array(v)))) / TRUE["mass"]]

    sol = solve_ivp(rhs, (0.0, duration), [0.0, 0.0], method="Radau", dense_output=True,
                    rtol=1e-9, atol=[1e-12, 1e-10], max_step=2e-3)
    n = int(duration / DT)
    t = np.arange(n) * DT + 3e-5 * DT * rng.standard_normal(n)  # logger clock jitter
    x, v = sol.sol(t)
    f = np.array([max(min(kp * (ref(tk) - xk) - kd * vk + 30.0 * math.sin(2 * math.pi * 3.1 * tk), 300.0), -300.0)
                  for tk, xk, vk in zip(t, x, v)])
    x_meas = np.round(x / 1e-7) * 1e-7  # encoder quantisation 0.1 um
    f_meas = f + 0.5 * rng.standard_normal(n)
    return t, f_meas, x_meas


class _Record:
    plant = "slider"

    def __init__(self, t, f, x):
        self.t, self._c = t, {"f": f, "x": x}

    def __contains__(self, k):
        return k in self._c

    def __getitem__(self, k):
        return self._c[k]


def test_jittered_clock_is_accepted_and_symmetric_levels_are_the_direction_means(record):
    t, f, x = record
    est = identify_slider_measured(_Record(t, f, x))
    assert est.stribeck == "none" and any("no Stribeck dip reported" in n for n in est.notes)
    assert est.params["mass"] == pytest.approx(TRUE["mass"], rel=0.01)
    mean_fc = 0.5 * (TRUE["coulomb_friction_pos"] + TRUE["coulomb_friction_neg"])
    assert est.params["coulomb_friction"] == pytest.approx(mean_fc, rel=0.1)


def test_asymmetric_model_recovers_each_direction(record):
    t, f, x = record
    est = identify_slider_measured(_Record(t, f, x), asymmetric=True)
    for name, value in TRUE.items():
        assert est.direction_params[name] == pytest.approx(value, rel=0.03), name
        assert 0.0 < est.direction_std_errors[name] < 0.05 * abs(value), name
    # viscous friction differs by 40 % between the directions; the symmetric model cannot say so
    assert est.direction_params["viscous_friction_neg"] > 1.3 * est.direction_params["viscous_friction_pos"]


def test_asymmetric_with_a_dip_is_refused(record):
    t, f, x = record
    with pytest.raises(SliderIdentificationError, match="asymmetric"):
        identify_slider(f, x, DT, asymmetric=True, stribeck="fit")


def test_a_gap_is_refused_not_interpolated(record):
    t, f, x = record
    t2 = t.copy()
    t2[5000:] += 0.5  # half a second missing
    with pytest.raises(SliderIdentificationError, match="sample 5000"):
        identify_slider_measured(_Record(t2, f, x))
