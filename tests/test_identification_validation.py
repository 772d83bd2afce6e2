"""Rows that run 004 sec. 4.2 on the rodless model (identification.validation)."""

import cmath
import math

import numpy as np
import pytest

from identification import validation as iv


@pytest.mark.parametrize("zeta", [0.05, 0.327, 0.9, 1.5, 4.0])
def test_pole_pair_damping_is_that_of_the_continuous_pair(zeta):
    """Discrete poles exp(s T) of s^2 + 2 zeta w s + w^2 give back zeta at any sample time."""
    w = 130.0
    s = np.roots([1.0, 2.0 * zeta * w, w * w]).astype(complex)
    for t in (1e-3, 5e-3, 1e-2):
        z1, z2 = (cmath.exp(x * t) for x in s)
        assert iv.pole_pair_damping(z1, z2) == pytest.approx(zeta, rel=1e-9)


def test_pole_pair_damping_of_a_negative_real_pole_is_nan():
    assert math.isnan(iv.pole_pair_damping(0.7, -0.4))


def test_the_eq32_rows_live_with_the_plant():
    """The procedure's rows are the rodless plant's (eq32_rows); this provider adds none."""
    assert iv.rows() == []


def test_seed_procedure_record_is_a_clean_closed_loop():
    r = iv.rodless_eq32_poles()
    assert r["clamps"] == 0 and not r["saturated"]
    assert abs(r["integrator"] - 1.0) < 0.01


def test_eq32_damping_lies_between_the_model_with_and_without_friction():
    """The damping row's source says eq (32)'s pair lies between the model without friction
    (a lightly damped air spring) and the model without Table 2's viscous sigma (still
    overdamped by the Coulomb and bristle parts: a real pair)."""
    import dataclasses

    from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams

    nominal = RodlessCylinderParams()
    free = iv.rodless_eq32_poles(dataclasses.replace(nominal, **iv.FRICTIONLESS))
    no_sigma = iv.rodless_eq32_poles(dataclasses.replace(nominal, viscous_friction=0.0))
    _, z1, z2 = iv._split(np.roots(iv.SEED_004_EQ32["a"]))
    seed = iv.pole_pair_damping(z1, z2)
    assert free["zeta"] < 0.1 < seed < 1.0
    # without sigma the pair is real (no oscillatory mode): damping > 1, or no continuous pair at
    # all when the fit of the nearly stuck piston puts one pole on the negative real axis
    _, n1, n2 = iv._split(no_sigma["poles"])
    assert abs(n1.imag) < 1e-12 and abs(n2.imag) < 1e-12
    assert not no_sigma["zeta"] <= 1.0


def test_eq32_pair_at_the_gain_matched_sample_time_is_the_model_air_spring():
    """The damping row's source: at the sample time where the model's gain per sample is eq
    (32)'s, eq (32)'s pair sits within 25 % of the model's air-spring frequency (eq (24)) and is
    damped as by far less viscous friction than Table 2's sigma."""
    import cmath

    from hydro_envs.plants.rodless_cylinder.model import linearize_mid_stroke
    from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams

    nominal = RodlessCylinderParams()
    seed = iv._summary(np.roots(iv.SEED_004_EQ32["a"]), iv.SEED_004_EQ32["b"])
    t = iv.gain_matched_sample_time(nominal, seed["gain"])
    assert iv.GAIN_SAMPLE_TIMES[0] < t < iv.GAIN_SAMPLE_TIMES[-1]
    _, z1, _ = iv._split(seed["poles"])
    omega = abs(cmath.log(z1)) / t
    assert omega == pytest.approx(linearize_mid_stroke(nominal).omega_n, rel=0.25)
    assert 2.0 * seed["zeta"] * omega * nominal.mass < 0.3 * nominal.viscous_friction
    # no bracket: NaN
    assert np.isnan(iv.gain_matched_sample_time(nominal, 100.0))
