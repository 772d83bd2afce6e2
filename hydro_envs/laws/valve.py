"""Servo/proportional valve spool dynamics (pure numba scalar kernels, SI units).

Sources (the seed papers, ``docs/references.md``):

* ``002_af30b681d6ccfd6c.txt`` eq (2) and the last two rows of eq (8): second-order spool
  lag, Table 1 (Moog D765: omega_v = 175 Hz, zeta_v = 0.65, k_v = 0.0279 mm/V, i.e.
  full stroke 0.279 mm at 10 V; the "cm^3" on zeta_v is an extraction defect).
* ``003_54985feb8193da53.txt`` eq (5): same model with unit gain on a normalised spool
  (Table 1: w_0 = 625 rad/s, zeta = 0.73).
* Hopsan: spool as a *saturated* second-order lag (docs/references.md) -> :func:`saturate`.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True, error_model="numpy")
def second_order_valve_acceleration(x_v, v_v, u, k_v, omega_v, zeta_v):
    """Spool acceleration of the second-order valve model.

    d^2 x_v/dt^2 = -omega_v^2 x_v - 2 zeta_v omega_v v_v + k_v omega_v^2 u

    (002 eq (8) last row; 002 eq (2) rearranged; 003 eq (5) with k_v = 1.)
    Static gain x_v = k_v u; natural frequency omega_v; damping ratio zeta_v.
    Units: x_v [m] (or normalised), v_v [m/s], u [V] (or normalised command),
    k_v [m/V], omega_v [rad/s] (002: 2 pi 175 = 1099.6 rad/s), zeta_v [-] -> [m/s^2].
    Stiffness: eigenvalues -zeta omega +- omega sqrt(zeta^2 - 1), |lambda| = omega_v
    (docs/references.md: 1100 1/s for 002, RK4 limit 2.4 ms).
    """
    return -omega_v * omega_v * x_v - 2.0 * zeta_v * omega_v * v_v + k_v * omega_v * omega_v * u


@numba.njit(cache=True, error_model="numpy")
def saturate(x, lo, hi):
    """Clip ``x`` to [lo, hi] (spool stroke limits, command limits).

    Units: any, consistent.  Source: Hopsan saturated spool (docs/references.md); 002 Table 1
    maximum spool displacement +-0.279 mm.
    """
    if x < lo:
        return lo
    if x > hi:
        return hi
    return x
