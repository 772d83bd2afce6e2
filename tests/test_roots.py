"""Brent's method without scipy.optimize (hydro_envs.sim.roots): the same roots as
``scipy.optimize.brentq``, bit for bit, on test functions and on the rest-state solves of the
envs' resets, and clear errors (that no env imports scipy.optimize: tests/test_env_contract.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from hydro_envs.plants.rodless_cylinder import model as rodless
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.shaking_table import bounds as table_bounds
from hydro_envs.plants.shaking_table import model as table
from hydro_envs.plants.shaking_table.params import ShakingTableParams
from hydro_envs.randomization import load_randomization
from hydro_envs.sim.roots import brent_root

TOLERANCES = ((2e-12, 4 * np.finfo(float).eps), (1e-6, 1e-14), (1.0, 1e-10), (1e-3, 1e-6))


def _functions(rng: np.random.Generator):
    c = rng.uniform(-3.0, 3.0, 3)
    return (
        lambda x: (x - c[0]) * (x - 0.1 * c[1]) * (x + 5.0) + 1e-3 * c[2],  # up to three roots
        lambda x: math.atan(x - c[0]) + 0.1 * c[1],  # flat far from the root
        lambda x: x**3 - c[0],  # a triple-root shape at 0
        lambda x: math.exp(0.5 * c[0] * x) - 1.5 - 0.4 * c[1],
    )


def test_same_roots_as_scipy_brentq():
    rng = np.random.default_rng(0)
    n = 0
    for _ in range(150):
        for f in _functions(rng):
            if f(-10.0) * f(10.0) > 0.0:
                continue
            for xtol, rtol in TOLERANCES:
                assert brent_root(f, -10.0, 10.0, xtol, rtol) == brentq(f, -10.0, 10.0, xtol=xtol, rtol=rtol)
                n += 1
    assert n > 1500


def test_root_at_a_bracket_end_and_default_tolerances():
    root = brent_root(lambda x: np.float64(x) - 0.3, 0.0, 1.0)
    assert type(root) is float and root == brentq(lambda x: x - 0.3, 0.0, 1.0)
    assert brent_root(lambda x: x - 2.0, 2.0, 5.0) == 2.0
    assert brent_root(lambda x: x - 5.0, 2.0, 5.0) == 5.0
    f = lambda x: math.cos(x) - x  # noqa: E731
    assert brent_root(f, 0.0, 1.0) == brentq(f, 0.0, 1.0)


def test_errors_name_the_values():
    with pytest.raises(ValueError, match=r"f\(a\) = 1.0 and f\(b\) = 4.0 must have different signs"):
        brent_root(lambda x: x * x, 1.0, 2.0)
    with pytest.raises(ValueError, match="xtol must be > 0"):
        brent_root(lambda x: x, -1.0, 1.0, xtol=0.0)
    with pytest.raises(ValueError, match="rtol must be >= 4 eps"):
        brent_root(lambda x: x, -1.0, 1.0, rtol=1e-17)
    with pytest.raises(RuntimeError, match="did not converge in 2 steps"):
        brent_root(lambda x: math.atan(x - 0.3), -10.0, 10.0, maxiter=2)


def _scipy_brentq(f, a, b, xtol, rtol):
    return float(brentq(f, a, b, xtol=xtol, rtol=rtol))


def test_rest_state_solves_equal_scipy_brentq(monkeypatch):
    """The shaking table's null and air-release pressures and the rodless cylinder's centre
    pressure, on randomised parameter sets, are those scipy's brentq finds."""
    rng = np.random.default_rng(1)
    table_spec = load_randomization("shaking_table", ShakingTableParams)
    rodless_spec = load_randomization("rodless_cylinder", RodlessCylinderParams)
    draws = [table_spec.sample(rng, ShakingTableParams.preset(name)) for name in ("modified_ifas", "ifas") * 15]
    rodless_draws = [rodless_spec.sample(rng, RodlessCylinderParams()) for _ in range(30)]
    ours = ([table.null_pressure(p) for p in draws], [table_bounds.air_release_pressure(p) for p in draws],
            [rodless.centre_pressure(p) for p in rodless_draws])
    monkeypatch.setattr(table, "brent_root", _scipy_brentq)
    monkeypatch.setattr(table_bounds, "brent_root", _scipy_brentq)
    monkeypatch.setattr(rodless, "brent_root", _scipy_brentq)
    theirs = ([table.null_pressure(p) for p in draws], [table_bounds.air_release_pressure(p) for p in draws],
              [rodless.centre_pressure(p) for p in rodless_draws])
    assert ours == theirs
    assert len(set(ours[1])) > 10 and min(ours[1]) > 0.0  # the air band lies inside the bracket
