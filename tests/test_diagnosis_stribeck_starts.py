"""Start points of the slider's Stribeck refit (:func:`hydro_envs.plants.slider.diagnosis.stribeck_starts`):
the law's breakaway force, its inverse, the breakaway force read off an independent record (the
Radau axis of :mod:`test_diagnosis_unexplained`), and the scan around it."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from hydro_envs.plants.slider.diagnosis import (
    _static_for_peak,
    friction_peak,
    measured_friction_peak,
    stribeck_starts,
)
from hydro_envs.plants.slider.params import SliderParams
from test_diagnosis_unexplained import axis_record



@functools.lru_cache(maxsize=None)
def _record(fs: float, vs: float):
    """10 s of the Radau axis with Stribeck friction (F_C 10 N, v_eps 0.5 mm/s)."""
    return axis_record(None, 6, 10.0, stribeck=(fs, vs))


P = SliderParams(coulomb_friction=10.0, static_friction=20.0, stribeck_velocity=5e-3, friction_sign_velocity=5e-4)


def test_breakaway_force_limits():
    """A sharp sign (v_eps << v_S) reaches F_S; no Stribeck excess leaves F_C; the soft sign of
    the nominal slider lies between, below F_S by the excess lost over the sign's width:
    (F_S - F_C)(1 - exp(-v / v_S)) at v ~ 2 v_eps is 1.8 N."""
    assert friction_peak(dataclasses.replace(P, friction_sign_velocity=1e-7)) == pytest.approx(20.0, rel=1e-3)
    assert friction_peak(dataclasses.replace(P, static_friction=10.0)) == pytest.approx(10.0, rel=1e-6)
    assert 17.0 < friction_peak(P) < 18.2


def test_static_friction_for_a_breakaway_force_inverts_the_law():
    for vs in (1e-3, 5e-3, 1.6e-2):
        fs = _static_for_peak(P, 15.0, vs)
        assert fs is not None and fs > P.coulomb_friction
        assert friction_peak(dataclasses.replace(P, static_friction=fs, stribeck_velocity=vs)) == pytest.approx(15.0, rel=1e-6)
    assert _static_for_peak(P, 9.0, 5e-3) is None  # below the Coulomb level: no F_S >= F_C gives it


@pytest.mark.parametrize("fs, vs", [(20.0, 5e-3), (16.0, 2e-3)])
def test_breakaway_force_read_off_an_independent_record(fs, vs):
    """The binned medians read the narrow peak low (16.8 N for the true 17.6 N), never high, and
    within the coarse scan's range (0.95-1.25 times the reading)."""
    rec = _record(fs, vs)
    truth = friction_peak(dataclasses.replace(P, static_friction=fs, stribeck_velocity=vs))
    got = measured_friction_peak(dataclasses.replace(P, mass=1.0, viscous_friction=20.0), rec.channels["x"],
                                 rec.inputs[:, 0], rec.dt)
    assert 0.95 * got < truth < 1.25 * got and got < truth


def test_start_points_span_the_ridge_and_refine_about_a_point():
    rec = _record(20.0, 5e-3)
    base = dataclasses.replace(P, static_friction=10.0, mass=1.0, viscous_friction=20.0)
    coarse = stribeck_starts(base, rec.channels, rec.inputs, rec.dt)
    assert len(coarse) == 12 * 9
    peaks = np.array([friction_peak(dataclasses.replace(base, **c)) for c in coarse])
    truth = friction_peak(P)
    assert peaks.min() < truth < peaks.max()
    for level, (n, step) in enumerate([(11 * 9, 0.0251), (11 * 5, 0.0051)], start=1):
        fine = stribeck_starts(base, rec.channels, rec.inputs, rec.dt, around=coarse[40], level=level)
        centre = friction_peak(dataclasses.replace(base, **coarse[40]))
        fine_peaks = np.array([friction_peak(dataclasses.replace(base, **c)) for c in fine])
        assert len(fine) == n and np.all(np.abs(fine_peaks / centre - 1) <= step)
    assert stribeck_starts(base, rec.channels, rec.inputs, rec.dt, around=coarse[40], level=3) == []
    assert stribeck_starts(base, {}, rec.inputs, rec.dt) == []


def test_binned_friction_peak_is_the_largest_bin_median_of_enough_samples():
    from hydro_envs.data.friction_reading import binned_friction_peak

    rng = np.random.default_rng(0)
    speed = np.concatenate([np.full(50, 2e-4), np.full(50, -3e-3), np.full(19, 5e-2), np.full(5, 1.0)])
    friction = np.concatenate([12.0 + rng.normal(0, 0.1, 50), 15.0 + rng.normal(0, 0.1, 50),
                               np.full(19, 40.0), np.full(5, 90.0)])
    # the 19-sample bin and the speeds above 0.1 m/s do not count; the sign of the speed does not matter
    assert binned_friction_peak(speed, friction) == pytest.approx(15.0, abs=0.05)
    assert np.isnan(binned_friction_peak(speed[100:], friction[100:]))
