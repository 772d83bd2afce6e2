"""Eq (32) of seed 004 against its own procedure on the rodless model: the ARX(3) estimator
recovers a known model, and the damping row is a bracket that can fail."""

import dataclasses

import numpy as np
import pytest
from scipy import signal

from hydro_envs.plants.rodless_cylinder import validation as rv
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams


def test_arx3_least_squares_recovers_eq32_from_its_own_simulation():
    """Eq (32) driven by a white input with small white equation error: the fit returns it."""
    rng = np.random.default_rng(1)
    u = rng.standard_normal(4000)
    e = 1e-3 * rng.standard_normal(u.size)
    y = signal.lfilter(np.r_[0.0, rv.EQ32_B], rv.EQ32_A, u) + signal.lfilter([1.0], rv.EQ32_A, e)
    a, b = rv.arx3_least_squares(y, u)
    assert a == pytest.approx(rv.EQ32_A, abs=2e-3) and b == pytest.approx(rv.EQ32_B, abs=2e-3)


def test_eq32_summary_reads_the_printed_model():
    s = rv.eq32_summary(rv.EQ32_A, rv.EQ32_B)
    assert s["integrator"] == pytest.approx(0.9965, abs=1e-4)  # the real root of eq (32)
    assert s["zeta"] == pytest.approx(0.3269, abs=1e-4)  # its complex pair 0.216 +- 0.616j


@pytest.fixture(scope="module")
def eq32_rows():
    return {r.name: r for r in rv.eq32_rows()}


def test_the_bracket_encloses_eq32_between_compensated_and_uncompensated_friction(eq32_rows):
    row = eq32_rows["rodless_cylinder: eq (32) damping bracketed by the sec. 4.2 procedure, friction compensated / none"]
    assert row.kind == "independent" and row.reproduced_high is not None and row.tolerance == 0.0
    assert row.reproduced < 0.1 < row.published < 1.0 < row.reproduced_high  # air spring alone / Table 2
    assert row.passed
    pole = eq32_rows["rodless_cylinder: sec. 4.2 loop ARX(3), pole near z = 1 vs eq (32)"]
    assert pole.passed


def test_the_bracket_fails_when_the_uncompensated_model_cannot_reach_eq32():
    """A twentieth of Table 2's friction (Stribeck levels, sigma and bristle damping) leaves the air
    spring damped less than eq (32)'s pair at both ends (0.18 here, 0.47 at a tenth): the row fails."""
    p = RodlessCylinderParams()
    weak = dataclasses.replace(p, static_friction=0.05 * p.static_friction, coulomb_friction=0.05 * p.coulomb_friction,
                               viscous_friction=0.05 * p.viscous_friction, bristle_damping=0.05 * p.bristle_damping)
    row = rv.eq32_rows(weak)[1]
    assert row.reproduced_high < row.published and not row.passed
