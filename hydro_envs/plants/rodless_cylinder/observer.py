"""Chamber gas temperatures implied by a measured record (seed 004, ``004_f1423316a055addb.txt``).

A record of the rodless cylinder measures the slider position and both chamber pressures; the
gas masses, hence the temperatures ``T = p V / (m R)``, are not measured. With adiabatic
chambers (eq (11)) a compressed or expanded charge keeps its temperature until air is exchanged
through the valve, so a simulation started at ``T_s`` from a measured pressure carries the wrong
mass and drifts. On a record with a hidden 0.127 mm underlap the chambers ranged 283-299 K; a
correct model started at T_s left 1.5-58 um RMS of position residual per 0.7 s window, started
at the true temperatures 1.0-1.5 um (the 1 um encoder noise).

:func:`chamber_temperature_track` estimates them with the model's own mass balance: eqs (8)-(9)
with the valve flows (3)-(4) of :func:`~.model.rodless_cylinder_rhs` evaluated at the measured
pressures and the spool position of eq (28) driven by the recorded command (the second-order
spool, discretised exactly for a command held over each sample), integrated with Euler steps of
the sample time from ``T_s`` at the first sample (a record starting at rest). With the
parameters of that record's generator it recovered the temperatures within 0.3 K RMS.
The estimate depends on the valve parameters (an underlapped valve renews the gas at mid
position, a closed-centre one does not), so it is evaluated for the parameters being fitted.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.linalg import expm

from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.orifice import circular_orifice_area
from hydro_envs.plants.rodless_cylinder.model import _vented_chamber_flows, supply_port_flows
from hydro_envs.plants.rodless_cylinder.params import (
    D_AREA, D_KV, I_L, I_MFLOOR, I_R, I_RP, I_TS, I_UC, I_ULAP, I_VDA, I_VDB, I_VMIN, I_WV, I_XVM, I_ZV,
)

__all__ = ["chamber_temperature_track"]


@njit_noalloc
def _track(p, y, pa, pb, u, dt, ad, bd, ta, tb):
    n = y.shape[0]
    r_gas = p[I_R]
    area = p[D_AREA]
    xvm = p[I_XVM]
    vol_a = max(area * y[0] + p[I_VDA], p[I_VMIN])
    vol_b = max(area * (p[I_L] - y[0]) + p[I_VDB], p[I_VMIN])
    ma = pa[0] * vol_a / (r_gas * p[I_TS])
    mb = pb[0] * vol_b / (r_gas * p[I_TS])
    xv = p[D_KV] * (u[0] - p[I_UC])  # spool at rest for the first command
    vv = 0.0
    for k in range(n):
        vol_a = max(area * y[k] + p[I_VDA], p[I_VMIN])  # (15)
        vol_b = max(area * (p[I_L] - y[k]) + p[I_VDB], p[I_VMIN])
        ta[k] = pa[k] * vol_a / (max(ma, p[I_MFLOOR]) * r_gas)
        tb[k] = pb[k] * vol_b / (max(mb, p[I_MFLOOR]) * r_gas)
        xo = min(max(xv, -xvm), xvm)
        s_plus = circular_orifice_area(p[I_ULAP] + xo, p[I_RP])  # (2)
        s_minus = circular_orifice_area(p[I_ULAP] - xo, p[I_RP])
        _, m_pa, m_pb = supply_port_flows(p, s_plus, s_minus, pa[k], ta[k], pb[k], tb[k])  # (3) at the port
        dma, _ = _vented_chamber_flows(p, m_pa, s_minus, pa[k], ta[k])  # (3)-(4)
        dmb, _ = _vented_chamber_flows(p, m_pb, s_plus, pb[k], tb[k])
        ma = max(ma + dt * dma, p[I_MFLOOR])  # (8)-(9)
        mb = max(mb + dt * dmb, p[I_MFLOOR])
        du = u[k] - p[I_UC]  # (28): the spool over one sample of held command
        xv, vv = ad[0, 0] * xv + ad[0, 1] * vv + bd[0] * du, ad[1, 0] * xv + ad[1, 1] * vv + bd[1] * du


def _spool_zoh(p: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of the spool of eq (28) for a command held over ``dt``."""
    return _spool_zoh_of(float(p[I_WV]), float(p[I_ZV]), float(p[D_KV]), dt)


@functools.lru_cache(maxsize=64)
def _spool_zoh_of(w: float, z: float, kv: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    m = np.zeros((3, 3))
    m[0, 1] = 1.0
    m[1, 0], m[1, 1], m[1, 2] = -w * w, -2.0 * z * w, kv * w * w
    e = expm(m * dt)
    ad, bd = np.ascontiguousarray(e[:2, :2]), np.ascontiguousarray(e[:2, 2])
    ad.flags.writeable = bd.flags.writeable = False  # shared by every caller
    return ad, bd


def chamber_temperature_track(params_array: np.ndarray, y: np.ndarray, pa: np.ndarray, pb: np.ndarray,
                              u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Chamber temperatures [K] at every sample of a record (module docstring): packed
    parameters ``params_array`` (``RodlessCylinderParams.to_array()``), measured position
    ``y`` [m], pressures ``pa``, ``pb`` [Pa] (absolute) and valve command ``u`` [V], sample
    time ``dt`` [s]."""
    y, pa, pb, u = (np.ascontiguousarray(a, dtype=np.float64) for a in (y, pa, pb, u))
    ta = np.empty(y.size)
    tb = np.empty(y.size)
    p = np.ascontiguousarray(params_array, dtype=np.float64)
    ad, bd = _spool_zoh(p, float(dt))
    _track(p, y, pa, pb, u, float(dt), ad, bd, ta, tb)
    return ta, tb
