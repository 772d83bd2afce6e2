"""The sub-step bound's numerics: RK4's stable region in every left-half-plane direction."""

from __future__ import annotations

import math

import numpy as np

from hydro_envs.sim.stiffness import DEFAULT_SAFETY, RK4_REAL_STABILITY_LIMIT, rk4_amplification


def test_the_bound_is_stable_in_every_left_half_plane_direction():
    """|h lambda| <= 0.8 * 2.785 keeps |R| <= 1 at every angle from the imaginary axis to the
    negative real axis, although the region's radius dips below 2.785 (to about 2.62 near 122
    degrees): the safety factor is needed for oscillatory modes, not only for margin."""
    bound = DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT
    angles = np.linspace(0.5 * math.pi, math.pi, 181)
    radii = np.linspace(1e-3, bound, 400)
    z = radii[None, :] * np.exp(1j * angles[:, None])
    assert np.abs(rk4_amplification(z)).max() <= 1.0 + 1e-12
    dip = 2.65 * np.exp(1j * math.radians(122.0))
    assert abs(rk4_amplification(dip)) > 1.0 and 2.65 < RK4_REAL_STABILITY_LIMIT


def test_second_order_pole_magnitude_is_the_fastest_root():
    from hydro_envs.sim.stiffness import second_order_pole_magnitude

    for zeta in (0.05, 0.7, 1.0, 1.5, 5.0):
        roots = np.roots([1.0, 2.0 * zeta * 300.0, 300.0**2])
        assert math.isclose(second_order_pole_magnitude(300.0, zeta), np.max(np.abs(roots)), rel_tol=1e-6)
