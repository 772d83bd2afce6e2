"""Analyses of the shaking table that run the compiled model (validation and tests).

* :func:`modulus_minimum`: where and how deep the oil-spring modulus at mid-stroke is
  smallest, read from the compiled right-hand side (003 eqs (14)-(19));
* :func:`small_signal_frequency`: the natural frequency of the nonlinear plant from its
  response to a small tap.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hydro_envs.plants.shaking_table.model import (
    PA,
    PB,
    V,
    N_STATES,
    chamber_volumes,
    effective_bulk_modulus,
    null_pressure,
    rest_state,
    shaking_table_rhs,
)
from hydro_envs.plants.shaking_table.params import ShakingTableParams
from hydro_envs.plants.shaking_table.spec import SPEC
from hydro_envs.sim.simulate import simulate

__all__ = ["modulus_minimum", "small_signal_frequency"]


def _rhs_moduli(params: ShakingTableParams, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """(E_a, E_b) [Pa] recovered from the compiled right-hand side, not from the law itself.

    With the valve sealed (R = 0), no leakage and no port reliefs, eqs (6)-(7) at x = 0 with a small velocity
    give ``P_a' = -E_a A v / V_a`` and ``P_b' = E_b A v / V_b``. Each chamber is read while it
    is compressed (v < 0 for a, v > 0 for b), so the cavitation guard never masks it.
    """
    sealed = dataclasses.replace(params, flow_coefficient=0.0, internal_leakage=0.0, external_leakage=0.0,
                                 relief_flow=0.0)
    p = sealed.to_array()
    v = 1e-3
    va, vb = chamber_volumes(sealed, 0.0)
    out = np.empty((pa.size, 2))
    dy = np.empty(N_STATES)
    u = np.zeros(1)
    for k, (a_, b_) in enumerate(zip(pa.ravel(), pb.ravel())):
        shaking_table_rhs(np.array([0.0, -v, a_, b_, 0.0, 0.0, 0.0]), u, p, dy)
        out[k, 0] = dy[PA] * va / (sealed.piston_area * v)
        shaking_table_rhs(np.array([0.0, v, a_, b_, 0.0, 0.0, 0.0]), u, p, dy)
        out[k, 1] = dy[PB] * vb / (sealed.piston_area * v)
    return out


def modulus_minimum(params: ShakingTableParams, n_grid: int = 2001, span: float | None = None) -> dict[str, float]:
    """Where and how deep the oil-spring modulus at mid-stroke is smallest.

    Along the valve's load line ``P_a = P_m + dP/2``, ``P_b = P_m - dP/2`` (P_m the null
    pressure, both chambers kept inside [P_T, P_s]) the stiffness of the two oil columns at
    mid-stroke is ``A^2 (E_a + E_b) / V`` (V_a = V_b = V), so the effective modulus is
    ``E_eff = (E_a + E_b) / 2``. Returns the location ``dp_min`` [Pa] of its minimum (grid,
    then bounded refinement), the minimum ``e_min`` [Pa], the closed form
    ``h(0) E_IFAS(P_m)`` [Pa] of eqs (17)-(19) at dP = 0, and ``e_floor`` [Pa]: the smallest
    E_a or E_b over the whole square [p_floor, 1.2 P_s]^2 (positivity). ``span`` limits the
    load line to ``|dP| <= span``.

    For the nominal set the minimum over the whole load line is at dP = 0. A shallow notch
    (large lambda_1, small lambda_2) with much entrained air can put it at the far end of the
    line instead, where one chamber nears tank pressure and its air-softened modulus drops
    below the notch (seen at a corner of the randomisation ranges).
    """
    from scipy.optimize import minimize_scalar

    pm = null_pressure(params)
    half_span = 2.0 * min(pm - params.tank_pressure, params.supply_pressure - pm) * 0.999
    if span is not None:
        half_span = min(half_span, span)

    def e_eff(d):
        d = np.atleast_1d(np.asarray(d, dtype=float))
        e = _rhs_moduli(params, pm + 0.5 * d, pm - 0.5 * d)
        return 0.5 * (e[:, 0] + e[:, 1])

    grid = np.linspace(-half_span, half_span, n_grid)
    e = e_eff(grid)
    k = int(np.argmin(e))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, n_grid - 1)]
    res = minimize_scalar(lambda d: float(e_eff(d)[0]), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-3})
    square = np.linspace(params.pressure_floor, 1.2 * params.supply_pressure, 121)
    pa, pb = np.meshgrid(square, square)
    e_sq = _rhs_moduli(params, pa.ravel(), pb.ravel())
    ea, _ = effective_bulk_modulus(params, pm, pm)
    return {
        "dp_min": float(res.x),
        "e_min": float(res.fun),
        "e_closed_form": float(ea),
        "e_floor": float(e_sq.min()),
        "e_far": float(e.max()),
    }


def small_signal_frequency(params: ShakingTableParams, v_kick: float = 1e-3, seconds: float = 0.8,
                           dt: float = 1e-3, n_sub: int = 8) -> dict[str, float]:
    """Natural frequency [rad/s] of the nonlinear plant from its response to a small tap.

    The table rests at mid-stroke (spool centred, chambers at the null pressure) and gets a
    velocity ``v_kick``; the compiled kernel integrates the full nonlinear model (valve,
    underlap flows, leakage, viscous friction, modulus law) *without dry friction*
    (:meth:`~hydro_envs.spec.PlantSpec.without_dry_friction`): a 1 mm/s tap does not break the
    LuGre seals away, so with them the table would ring on its bristle spring sigma0 in
    parallel with the oil columns (about critically damped by the micro-damping), not at the
    oil-column frequency this measures. The velocity record is fitted by least
    squares with ``exp(-s t) (a cos(w t) + b sin(w t)) + c exp(-l t)`` (oil-column mode plus the
    slow valve/leakage mode), started from the FFT peak; the undamped frequency of the
    oscillatory pole is ``sqrt(w^2 + s^2)``.
    """
    from scipy.optimize import least_squares

    n = int(round(seconds / dt))
    params = ShakingTableParams.from_mapping(SPEC.without_dry_friction({}), base=params)
    v = simulate(SPEC, params, np.zeros((n, 1)), rest_state(params, 0.0, v_kick), dt, n_sub=n_sub)[:, V]
    t = dt * np.arange(n + 1)
    spec = np.abs(np.fft.rfft(v * np.hanning(v.size), 16 * v.size))
    freqs = 2.0 * np.pi * np.fft.rfftfreq(16 * v.size, dt)
    w0 = float(freqs[1 + int(np.argmax(spec[1:]))])

    def model(q):
        s, w, a, b, c, lam = q
        return np.exp(-s * t) * (a * np.cos(w * t) + b * np.sin(w * t)) + c * np.exp(-lam * t)

    q0 = np.array([5.0, w0, v_kick, 0.0, 0.0, 1.0])
    fit = least_squares(lambda q: (model(q) - v) / v_kick, q0, x_scale=[10.0, w0, v_kick, v_kick, v_kick, 1.0])
    s, w = fit.x[0], abs(fit.x[1])
    resid = float(np.sqrt(np.mean(fit.fun**2)))
    return {"omega_n": float(math.hypot(w, s)), "omega_d": float(w), "sigma": float(s),
            "fft_peak": w0, "fit_rms": resid}
