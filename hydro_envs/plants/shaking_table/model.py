r"""Servo-hydraulic uni-axial shaking table (seed 003, University of Bergamo rig).

Source: ``003_54985feb8193da53.txt`` -- "Nonlinear Model of a Servo-Hydraulic Shaking Table
with Dynamic Model of Effective Bulk Modulus": underlapped 4/3 valve eqs (1)-(4), valve
dynamics eq (5), chamber pressures with leakage eqs (6)-(9), piston eq (10), Stribeck friction
with tanh sign eqs (11)-(12), IFAS bulk modulus eq (13), modified IFAS eqs (15)-(19),
Tables 1-2. Hardware (sec. 2): Bosch-Rexroth CGH2 *double-rod* cylinder, bore 50 mm, rod
36 mm, stroke 260 mm (so ``A_a = A_b = A = pi/4 (50^2 - 36^2) mm^2 = 9.4562e-4 m^2``, Table 1);
4WS.2E proportional valve (20 l/min, about 150 Hz); 650 kg platform; 200 / 500 kg specimens;
linear potentiometer (Gefran PC-M-300) and accelerometer (ADXL05).

State (SI, pressures absolute)::

    index  name  unit   meaning
    0      x     m      table position, 0 at mid-stroke, +-stroke/2 at the mechanical ends
    1      v     m/s    table velocity
    2      pa    Pa     chamber-a pressure (chamber a grows with x)
    3      pb    Pa     chamber-b pressure
    4      xv    1      normalised spool position (+-1 = full stroke)
    5      vv    1/s    normalised spool velocity
    6      z     m      bristle (pre-sliding) deflection of the seals (LuGre state)

Input: ``u`` [V], valve command, +-10 V = full spool stroke.

Equations (numbers of 003)::

    Q_a = R [ sgt(xv,U) sqrt~(P_s - P_a) - sgt(-xv,U) sqrt~(P_a - P_T) ]            (1)
    Q_b = R [ sgt(-xv,U) sqrt~(P_s - P_b) - sgt(xv,U) sqrt~(P_b - P_T) ]            (2)
    sgt(xv, U) = max(xv + U, 0)                                                    (3)
    xv'' = w0^2 (k_u u - xv) - 2 zeta w0 xv'                                         (5)
    P_a' = E_a / V_a (Q_a - Q_ia - Q_ea - Q_ra - A v),  V_a = V_0 + A (L/2 + x)      (6)
    P_b' = E_b / V_b (Q_b - Q_ib - Q_eb - Q_rb + A v),  V_b = V_0 + A (L/2 - x)      (7)
    Q_ia = C_il (P_a - P_b) = -Q_ib,  Q_ea = C_el (P_a - P_T),  Q_eb = C_el (P_b - P_T) (8)-(9)
    Q_ra = q_relief(P_a - P_T), Q_rb = q_relief(P_b - P_T)   port reliefs to tank (not in 003)
    M v' = A (P_a - P_b) - F_fric + F_stop(x, v),  M = M_b + M_s                     (10)
    F_fric = sigma0 z + sigma1(v) z' + F_v v,  z' = v - sigma0 |v| z / g(v)           (LuGre)
    g(v) = F_C + (F_s - F_C) exp(-(v/v_s)^2)                                         (11)
    E = E_0 (constant) | E_IFAS(P) (13) | E_IFAS(P) h(P_a - P_b) (15)-(19)

Friction: the seal-friction family of :mod:`hydro_envs.laws.seal_friction` (LuGre, n = 1,
with its quasi-static limit above ``bristle_relaxation_cap``) with 003 eq (11) as its steady
state: at constant v, ``F_fric = g(v) sign(v) + F_v v`` exactly -- eq (11) with the sign, the
``beta -> infinity`` limit of eq (12). At v = 0 the seals hold the table on their bristle
spring up to the breakaway force F_s, with the pre-sliding displacement ``F_s / sigma0``; the
tanh of eq (12) (1/beta = 0.136 mm/s with beta read per mm/s, :class:`ShakingTableParams`)
enters no kernel.

``sqrt~`` is the signed root ``sign(dp) sqrt(|dp|)`` of eqs (1)-(2) and (4), regularised below
``orifice_transition_pressure`` (:func:`hydro_envs.laws.orifice.regularized_signed_sqrt`) so
the Jacobian stays finite at zero pressure drop. The bulk-modulus model is the *numeric*
parameter ``bulk_modulus_model`` (0 constant, 1 IFAS, 2 modified IFAS) so one compiled kernel
handles every variant and a batch may mix them.

Decisions on the extracted text (``docs/references.md`` and this module):

* **Spool scale.** Eq (5) has unit gain from u to the normalised spool xv, and the text's
  inputs are ``u = 0.3 sin(2 pi 2 t)`` while Table 3 writes ``3 sin(4 pi t)``: the text's u is
  the normalised command (a fraction of full stroke) and Table 3's is in volts, with the usual
  +-10 V = full stroke of a proportional valve. So ``xv_ss = k_u u`` with ``k_u = 0.1 1/V``.
  Consistency check: R = 1.28e-7 m^3/(s sqrt(Pa)) at xv = 1 passes 20.3 l/min at 70 bar per
  edge, the 4WS.2E's 20 l/min nominal flow (sec. 2); the spool opening is limited to +-1.
* **Leakage signs.** Eqs (8)-(9) print ``C_il (|P_a - P_b|)`` in both chambers, which would
  drain both chambers through the piston seal. Internal leakage flows from the high- to the
  low-pressure chamber: ``Q_ia = C_il (P_a - P_b) = -Q_ib``. External leakage drains to the
  tank/ambient pressure: ``Q_ea = C_el (P_a - P_T)`` (pressures here are absolute).
* **Table 2 units** are not printed. SI throughout: C_il, C_el in m^3/(s Pa), F in N, F_v in
  N s/m, v_s in m/s, beta in s/m, E_0 in Pa, mu in 1/Pa, P_Lt in Pa; P_0 is read in bar (36.85
  bar, 8.7 bar), see :mod:`hydro_envs.laws.bulk_modulus`.
* **Modified-IFAS shape.** Table 2's printed (lambda_1, lambda_2) = (1.08, 0.64) gives
  ``h(0) = 1.08 - 2 0.64 tanh(8.08) = -0.20 < 0``: a negative modulus at mid-stroke. We use
  the valid set of :mod:`hydro_envs.laws.bulk_modulus` (lambda_2 = 0.32, h(0) = 0.44, notch
  depth 0.64); every parameter set is checked by :func:`modified_ifas_shape_is_valid`.
* **Dead volume.** The paper's ``V_t / 2`` (eqs (6)-(7)) is ``V_0 + A L / 2`` here; the
  hose/port volume V_0 is not given. Assumed 40 cm^3 per side (about 0.5 m of 10 mm bore hose
  plus the valve and cylinder ports); randomised 25-60 cm^3.
* **Port reliefs.** 003 prints no relief valve, yet a 850 kg table braked by its closing valve
  compresses the outlet chamber far above the supply (562 bar = 2.8 P_s under random commands
  without one). Each chamber gets a port relief to tank, :func:`hydro_envs.laws.relief.pressure_relief_flow`
  (cracking at ``relief_pressure``, rated ``relief_flow`` at ``relief_pressure + relief_override``;
  settings assumed, :class:`ShakingTableParams`). Closed below cracking, it leaves every
  trajectory that stays below 230 bar as it was.
* **Reference pressure of IFAS.** Eq (13) uses the absolute pressure; the supply 206 bar of
  Table 1 is gauge, so ``P_s = 20.6 MPa + 0.1 MPa``.

Guards (``docs/references.md``, numerics notes): a cavitation pressure floor (derivative clipped at the floor,
state clamped after each sub-step), the IFAS law evaluated at ``max(P, floor)``, chamber
volumes never below ``min_chamber_volume``, and continuous Hunt-Crossley end stops at +-L/2
(the mechanical end-stroke (H) of the rig).
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import NOALLOC_OPTIONS, as_python, njit_noalloc
from hydro_envs.laws.bulk_modulus_fast import ifas_bulk_modulus_scaled, modified_ifas_shape_fast
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.seal_friction import seal_friction
from hydro_envs.libm import exp
from hydro_envs.laws.orifice import (
    regularized_signed_sqrt,
    regularized_signed_sqrt_slope_bound,
    underlap_orifice_opening,
)
from hydro_envs.laws.relief import pressure_relief_flow
from hydro_envs.laws.valve import second_order_valve_acceleration
from hydro_envs.plants.shaking_table.bounds import (  # noqa: F401  (re-exported)
    ACCURATE_H_LAMBDA, friction_bounds, friction_rate, local_mode_rates, stiffness_modes,
)
from hydro_envs.plants.shaking_table.params import (  # noqa: F401  (re-exported)
    BULK_MODULUS_MODELS, D_EMAX, D_IFAS_ALPHA_KAPPA, D_IFAS_INV_KAPPA, D_IFAS_INV_M, D_IFAS_LN_P0, D_IFAS_M_E0,
    D_IFAS_OIL_E0, D_INV_M, D_LOCAL, D_NOTCH_AMP, D_NOTCH_C2, D_NOTCH_FAR, D_NOTCH_ONE_C2, D_PAIR, D_DFADE, I_A,
    I_ALPHA, I_ASTOP, I_BETA, I_CEL, I_CIL, I_DPTR, I_E0, I_FC, I_FS, I_FV, I_KAPPA, I_KSTOP, I_KU, I_L, I_L1, I_L2,
    I_M, I_MB, I_MODEL, I_MS, I_MU, I_P0, I_PFLOOR, I_PLT, I_PS, I_PT, I_R, I_U, I_UMAX, I_V0, I_VMIN, I_VS, I_W0,
    I_ZETA, I_SIG0, I_SIG1, I_ZCAP, I_PRV, I_POV, I_QRV, D_GRV,
    N_PARAMS, PLANT, PRESETS, SPECIMENS, ShakingTableParams,
)
from hydro_envs.sim.rk4 import STABLE_H_LAMBDA, local_substeps, worst_case_substeps
from hydro_envs.sim.roots import brent_root

__all__ = [
    "CONTRACT",
    "PLANT",
    "ShakingTableParams",
    "PRESETS",
    "SPECIMENS",
    "STATE_NAMES",
    "BULK_MODULUS_MODELS",
    "shaking_table_rhs",
    "shaking_table_guard",
    "table_acceleration",
    "friction_level",
    "seal_force",
    "friction_bounds",
    "friction_rate",
    "valve_flows",
    "chamber_moduli",
    "stiffness_modes",
    "local_mode_rates",
    "local_mode_rate",
    "local_mode_substeps",
    "local_mode_refinement",
    "hydraulic_natural_frequency",
    "null_pressure",
    "rest_state",
    "no_load_velocity",
    "max_drive_force",
    "effective_bulk_modulus",
    "closed_valve_energy",
    "ifas_relative_volume",
]

STATE_NAMES = ("x", "v", "pa", "pb", "xv", "vv", "z")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "1", "1/s", "m")
N_STATES = 7
X, V, PA, PB, XV, VV, Z = range(N_STATES)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {"x": X, "pa": PA, "pb": PB}
DERIVATIVE_OUTPUTS: dict[str, int] = {"a": V}
#: channels a grey-box fit uses by default
FIT_OUTPUTS = ("x", "a")



# ---------------------------------------------------------------------------- kernels
@njit_noalloc
def _ifas(pr, p):
    """IFAS modulus (eq (13)) [Pa] at pressure ``pr`` from ``p``'s derived IFAS terms."""
    return ifas_bulk_modulus_scaled(pr, p[I_P0], p[I_PFLOOR], p[I_ALPHA], p[D_IFAS_M_E0], p[D_IFAS_INV_M],
                                    p[D_IFAS_INV_KAPPA], p[D_IFAS_LN_P0], p[D_IFAS_OIL_E0], p[D_IFAS_ALPHA_KAPPA])


@nb.njit(cache=True, error_model="numpy", inline="always")
def chamber_moduli(pa, pb, p):
    """Effective bulk moduli (E_a, E_b) [Pa] of the two chambers under ``p``'s model."""
    model = p[I_MODEL]
    if model < 0.5:  # constant
        return p[I_E0], p[I_E0]
    ea = _ifas(pa, p)  # (13)/(17)
    eb = _ifas(pb, p)  # (13)/(18)
    if model > 1.5:  # modified IFAS (15)-(16), shape (19)
        h = modified_ifas_shape_fast(pa, pb, p[I_L1], p[I_MU], p[I_PLT], p[D_NOTCH_AMP], p[D_NOTCH_C2],
                                     p[D_NOTCH_ONE_C2], p[D_NOTCH_FAR])
        ea *= h
        eb *= h
    return ea, eb


@njit_noalloc
def _volumes(x, p):
    """Chamber volumes (V_a, V_b) [m^3] at piston position ``x`` in the kernels: those of
    :func:`chamber_volumes`, floored at the guard ``min_chamber_volume``."""
    half = 0.5 * p[I_L]
    return (max(p[I_V0] + p[I_A] * (half + x), p[I_VMIN]),  # V_t/2 + A x
            max(p[I_V0] + p[I_A] * (half - x), p[I_VMIN]))  # V_t/2 - A x


@nb.njit(cache=True, error_model="numpy", inline="always")
def valve_flows(xv, pa, pb, p):
    """Valve flows (Q_a, Q_b) [m^3/s] into the chambers, 003 eqs (1)-(4)."""
    xo = min(max(xv, -1.0), 1.0)  # spool stroke limit (normalised)
    sa = underlap_orifice_opening(xo, p[I_U])  # sgt(xv, U)   (3)
    sb = underlap_orifice_opening(-xo, p[I_U])  # sgt(-xv, U)
    r = p[I_R]
    dptr = p[I_DPTR]
    ps = p[I_PS]
    pt = p[I_PT]
    qa = 0.0
    qb = 0.0
    if sa > 0.0:  # P -> a and b -> T
        qa += sa * regularized_signed_sqrt(ps - pa, dptr)
        qb -= sa * regularized_signed_sqrt(pb - pt, dptr)
    if sb > 0.0:  # P -> b and a -> T
        qb += sb * regularized_signed_sqrt(ps - pb, dptr)
        qa -= sb * regularized_signed_sqrt(pa - pt, dptr)
    return r * qa, r * qb


@njit_noalloc
def relief_flow(pr, p):
    """Flow [m^3/s] out of a chamber at pressure ``pr`` through its port relief to tank
    (:func:`~hydro_envs.laws.relief.pressure_relief_flow`; 0 below ``relief_pressure``)."""
    pt = p[I_PT]
    return pressure_relief_flow(pr - pt, p[I_PRV] - pt, p[I_POV], p[I_QRV])


@njit_noalloc
def friction_level(v, p):
    """Steady-state friction level ``g(v) = F_C + (F_s - F_C) exp(-(v/v_s)^2)`` [N] of 003 eq (11)
    (without the sign; 0 without dry friction)."""
    r = v / p[I_VS]
    return p[I_FC] + (p[I_FS] - p[I_FC]) * exp(-r * r)


@nb.njit(cache=True, error_model="numpy", inline="always")
def seal_force(v, z, p):
    """``(F_fric, dz/dt)``: the seals' friction force [N] and bristle rate [m/s], the family law
    (:func:`~hydro_envs.laws.seal_friction.seal_friction`, LuGre n = 1) with 003 eq (11) as its
    steady state and F_v as its viscous term."""
    return seal_friction(v, z, friction_level(v, p), p[I_SIG0], p[I_SIG1], p[D_DFADE], p[I_FV], 1, p[I_ZCAP])


@nb.njit(cache=True, error_model="numpy", inline="always")
def _piston_force(x, v, z, pa, pb, p):
    """``(net force on the moving mass [N], dz/dt)``: A (P_a - P_b) - F_fric + F_stop (003 eq (10))."""
    half = 0.5 * p[I_L]
    f_fric, dz = seal_force(v, z, p)  # (11) as the LuGre steady state
    f_stop = end_stop_force(x, v, -half, half, p[I_KSTOP], p[I_ASTOP])
    return p[I_A] * (pa - pb) - f_fric + f_stop, dz


@njit_noalloc
def table_acceleration(y, p):
    """Table acceleration dv/dt [m/s^2] of state ``y`` -- what the accelerometer reads."""
    f, _ = _piston_force(y[X], y[V], y[Z], y[PA], y[PB], p)
    return f * p[D_INV_M]


@nb.njit(**NOALLOC_OPTIONS, inline="always")  # inlined into the step kernel: 4-5 % faster, +0.1 s to compile
def shaking_table_rhs(y, u, p, dy):
    """Time derivative ``dy`` of state ``y`` under command ``u[0]`` [V] (003 eqs (1)-(19); the
    seals' bristle state by the family law with eq (11) as its steady state)."""
    x = y[X]
    v = y[V]
    pa = y[PA]
    pb = y[PB]
    area = p[I_A]
    qa, qb = valve_flows(y[XV], pa, pb, p)  # (1)-(4)
    ea, eb = chamber_moduli(pa, pb, p)  # (13), (15)-(19)
    q_int = p[I_CIL] * (pa - pb)  # (8)-(9): internal leakage a -> b
    vol_a, vol_b = _volumes(x, p)  # V_t/2 +- A x
    dpa = ea / vol_a * (qa - q_int - p[I_CEL] * (pa - p[I_PT]) - relief_flow(pa, p) - area * v)  # (6)
    dpb = eb / vol_b * (qb + q_int - p[I_CEL] * (pb - p[I_PT]) - relief_flow(pb, p) + area * v)  # (7)
    if pa <= p[I_PFLOOR] and dpa < 0.0:  # cavitation guard
        dpa = 0.0
    if pb <= p[I_PFLOOR] and dpb < 0.0:
        dpb = 0.0
    f, dz = _piston_force(x, v, y[Z], pa, pb, p)
    dy[X] = v
    dy[V] = f * p[D_INV_M]  # (10)
    dy[PA] = dpa
    dy[PB] = dpb
    dy[XV] = y[VV]
    dy[VV] = second_order_valve_acceleration(y[XV], y[VV], u[0], p[I_KU], p[I_W0], p[I_ZETA])  # (5)
    dy[Z] = dz


@njit_noalloc
def shaking_table_guard(y, p):
    """Project the state back onto the physical set after a sub-step; return #clamps."""
    n = 0
    if y[PA] < p[I_PFLOOR]:
        y[PA] = p[I_PFLOOR]
        n += 1
    if y[PB] < p[I_PFLOOR]:
        y[PB] = p[I_PFLOOR]
        n += 1
    return n


@njit_noalloc
def _moduli_array(pa, pb, p, out):
    for k in range(pa.shape[0]):
        ea, eb = chamber_moduli(pa[k], pb[k], p)
        out[k, 0] = ea
        out[k, 1] = eb


# ------------------------------------------------------- local refinement (look-ahead kernels)
@njit_noalloc
def local_mode_rate(y, p):
    """Upper estimate [1/s] of the orifice modes at state ``y`` (:func:`.bounds.local_mode_rates`
    with the openings, drops and volumes of ``y`` and the largest modulus ``D_EMAX``): per
    chamber ``E_max / V (R (sgt_in root'(P_s - P) + sgt_out root'(P - P_T)) + 2 C_il + C_el)``
    (eqs (1)-(3), (6)-(9)), with the root's slope bounded by
    :func:`~hydro_envs.laws.orifice.regularized_signed_sqrt_slope_bound`, plus the port relief's
    largest slope ``D_GRV`` on a chamber above ``relief_pressure``; the larger of the two
    chambers'."""
    xo = min(max(y[XV], -1.0), 1.0)
    sa = underlap_orifice_opening(xo, p[I_U])  # sgt(xv, U), eq (3)
    sb = underlap_orifice_opening(-xo, p[I_U])
    dptr = p[I_DPTR]
    ps = p[I_PS]
    pt = p[I_PT]
    leak = 2.0 * p[I_CIL] + p[I_CEL]
    ga = p[I_R] * (sa * regularized_signed_sqrt_slope_bound(ps - y[PA], dptr)
                   + sb * regularized_signed_sqrt_slope_bound(y[PA] - pt, dptr)) + leak
    gb = p[I_R] * (sb * regularized_signed_sqrt_slope_bound(ps - y[PB], dptr)
                   + sa * regularized_signed_sqrt_slope_bound(y[PB] - pt, dptr)) + leak
    if y[PA] > p[I_PRV]:
        ga += p[D_GRV]
    if y[PB] > p[I_PRV]:
        gb += p[D_GRV]
    vol_a, vol_b = _volumes(y[X], p)
    return p[D_EMAX] * max(ga / vol_a, gb / vol_b)


#: most fine steps per sub-step :func:`air_band_substeps` asks for
AIR_BAND_MAX_SUBSTEPS = 64


@nb.njit(cache=True, error_model="numpy", inline="always")
def air_band_substeps(y0, x, p):
    """Fine steps per sub-step that keep RK4 accurate (``h |lambda| <=``
    :data:`~.bounds.ACCURATE_H_LAMBDA`) on a chamber in the air band of IFAS (eq (13), below
    ``D_PAIR``): there the air term dominates, ``E ~ P^((kappa+1)/kappa)``, so a chamber emptying
    or refilling is a mode of its own pressure with ``lambda = (1 + 1/kappa) (dP/dt) / P`` (the
    pressure falls towards cavitation, or climbs back, by orders of magnitude within a
    millisecond). ``dP/dt`` is that of the sub-step's start, from its Euler prediction
    ``x = y0 + h dy/dt``: ``h |lambda| = (1 + 1/kappa) |x_P - y0_P| / y0_P``. At most
    :data:`AIR_BAND_MAX_SUBSTEPS`; 1 with no chamber in the band at either state."""
    band = p[D_PAIR]
    g = 0.0
    for i in (PA, PB):
        if y0[i] < band or x[i] < band:
            g = max(g, abs(x[i] - y0[i]) / max(y0[i], p[I_PFLOOR]))
    g *= 1.0 + 1.0 / p[I_KAPPA]
    return min(AIR_BAND_MAX_SUBSTEPS, max(1, int(math.ceil(g / ACCURATE_H_LAMBDA))))


@njit_noalloc
def _smallest_metering_drop(y, p):
    """Smallest magnitude [Pa] of the drops across the metering edges at ``y``: ``P_s - P`` and
    ``P - P_T`` of both chambers."""
    ps = p[I_PS]
    pt = p[I_PT]
    return min(min(abs(ps - y[PA]), abs(y[PA] - pt)), min(abs(ps - y[PB]), abs(y[PB] - pt)))


@njit_noalloc
def _crossed(a0, a1, level):
    """Whether ``a0`` and ``a1`` lie on different sides of ``level``."""
    return (a0 - level) * (a1 - level) < 0.0


#: relative slack of :func:`_orifice_modes_surely_stable` against rounding in the rates it bounds
SHORT_CUT_SLACK = 1e-6


@nb.njit(cache=True, error_model="numpy", inline="always")
def _orifice_modes_surely_stable(y0, x, p, h):
    """Whether :func:`local_mode_rate` at ``y0`` and at ``x`` is certainly within the stable
    ``h |lambda|``, from a bound that needs no root: every chamber's rate is at most
    ``E_max / V_min (R (1 + U) / sqrt(dp_min) + 2 C_il + C_el)`` with ``dp_min`` the smallest
    metering drop (``P_s - P``, ``P - P_T`` of either chamber at either state; the root's slope is
    below ``|dp|^(-1/2)``), ``V_min`` the smaller chamber volume of the two states and
    ``sgt(x_v, U) + sgt(-x_v, U) <= 1 + U`` (eq (3) on the clipped stroke). Stable if
    ``dp_min room^2 >= (R (1 + U))^2`` with ``room = STABLE_H_LAMBDA V_min / (h E_max) - leak``
    (the leak counting the relief's ``D_GRV`` where a chamber is above ``relief_pressure``)."""
    va0, vb0 = _volumes(y0[X], p)
    va1, vb1 = _volumes(x[X], p)
    vol = min(min(va0, vb0), min(va1, vb1))
    leak = 2.0 * p[I_CIL] + p[I_CEL]
    if max(max(y0[PA], y0[PB]), max(x[PA], x[PB])) > p[I_PRV]:
        leak += p[D_GRV]
    room = STABLE_H_LAMBDA * vol / (h * p[D_EMAX]) - leak
    c = p[I_R] * (1.0 + p[I_U])
    dp_min = min(_smallest_metering_drop(y0, p), _smallest_metering_drop(x, p))
    return room > 0.0 and dp_min * room * room >= (1.0 + SHORT_CUT_SLACK) * c * c


#: half-width of the modified-IFAS notch edges the kernels refine across, in units of ``1/mu``
#: (``tanh`` is within 0.5 % of +-1 beyond it)
NOTCH_EDGE_WIDTHS = 3.0


#: most fine steps per sub-step :func:`notch_substeps` asks for
NOTCH_MAX_SUBSTEPS = 64


@nb.njit(cache=True, error_model="numpy", inline="always")
def notch_substeps(y0, x, p):
    """Fine steps per sub-step that keep RK4 accurate (``h |lambda| <=``
    :data:`~.bounds.ACCURATE_H_LAMBDA`) while the load pressure ``P_L = P_a - P_b`` sweeps an
    edge of the modified-IFAS notch (eq (19), ``+-P_Lt`` within :data:`NOTCH_EDGE_WIDTHS` ``/ mu``),
    0 where its path from ``y0`` to the Euler prediction ``x`` meets neither edge.

    Both moduli carry the factor ``h(P_L)`` (eqs (15)-(16)): ``P_a' = h f_a``, ``P_b' = h f_b``
    with ``f = E_i F / V``. Their Jacobian gains the rank-one block ``h' [f_a, f_b]^T [1, -1]``,
    whose eigenvalue is ``lambda = h' (f_a - f_b) = (h'/h) dP_L/dt``: the load pressure is a mode
    of its own, as fast as it sweeps the notch times the notch's relative slope. Bounds over the
    sub-step's path: ``|h'| = lambda_2 mu |sech^2(a + k) - sech^2(a - k)| <= lambda_2 mu
    sech^2(|a| - k)`` (eq (19), ``a = mu P_L``, ``k = mu |P_Lt|``; ``|a - k| <= a + k`` for
    ``a >= 0``), largest at the path's point nearest an edge, and ``h`` rises with ``|P_L|`` (the bracket is
    ``2 sinh(2k) / (cosh(2a) + cosh(2k))``, falling in ``|a|``), so it is smallest at the path's
    point nearest ``P_L = 0``. So ``h |lambda| <= lambda_2 mu sech^2(d_edge) |x_L - y0_L| / h(P_L,near)``
    (``d_edge`` the path's least distance from an edge in units of ``1/mu``).
    At most :data:`NOTCH_MAX_SUBSTEPS`, at least 1 on an edge."""
    l0 = y0[PA] - y0[PB]
    l1 = x[PA] - x[PB]
    lo = min(l0, l1)
    hi = max(l0, l1)
    w = NOTCH_EDGE_WIDTHS / p[I_MU]
    c = abs(p[I_PLT])
    if not ((hi > c - w and lo < c + w) or (hi > -c - w and lo < -c + w)):
        return 0
    near = 0.0 if lo < 0.0 < hi else min(abs(lo), abs(hi))  # |P_L| on the path spans [near, far]
    far = max(abs(lo), abs(hi))
    edge = 0.0 if near <= c <= far else p[I_MU] * min(abs(near - c), abs(far - c))
    r = exp(-2.0 * edge)
    h_near = modified_ifas_shape_fast(near, 0.0, p[I_L1], p[I_MU], p[I_PLT], p[D_NOTCH_AMP], p[D_NOTCH_C2],
                                      p[D_NOTCH_ONE_C2], p[D_NOTCH_FAR])
    g = abs(p[I_L2]) * p[I_MU] * 4.0 * r / ((1.0 + r) * (1.0 + r)) * (hi - lo) / h_near  # sech^2(edge) = 4r/(1+r)^2
    return min(NOTCH_MAX_SUBSTEPS, max(1, int(math.ceil(g / ACCURATE_H_LAMBDA))))


@njit_noalloc
def local_mode_substeps(y0, x, p, h, m):
    """RK4 steps of ``h / n`` that take a sub-step of ``h`` from ``y0`` (Euler prediction of its
    end ``x``) in the locally refined modes (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`):
    ``m`` (the worst case, :func:`local_mode_refinement`) or more where a chamber lies below the
    air-release pressure (``D_PAIR``, eq (13)) at either state (as many as
    :func:`air_band_substeps` gives for its emptying or refilling), ``m`` where a chamber
    pressure crosses the supply or the tank pressure (an orifice's zero drop) or a relief's kink, the spool crosses
    a kink of the metering openings (eq (3) at ``x_v = +-U``, the stroke limit at ``+-1``: the
    flow's slope jumps there, and RK4 across such a point loses its order), at least ``m`` and as
    many as :func:`notch_substeps` gives for the load pressure's own mode where it meets an edge
    of the modified-IFAS notch (eq (19), ``+-P_Lt`` within :data:`NOTCH_EDGE_WIDTHS` ``/ mu``; with
    ``m`` alone, a table at 0.3 m/s sweeping a 0.69 bar edge, ``h |lambda|`` up to 4, missed
    Radau by 1.6e-3 of the stroke used), or the table reverses (the LuGre seals' rate
    ``v - sigma0 |v| z / g`` has a kink at v = 0, across which RK4 loses its order); else the count for the larger :func:`local_mode_rate`
    of the two (:func:`hydro_envs.sim.rk4.local_substeps`), 1 without the rates where
    :func:`_orifice_modes_surely_stable` says so."""
    ps = p[I_PS]
    pt = p[I_PT]
    a0, a1, b0, b1 = y0[PA], x[PA], y0[PB], x[PB]
    n_notch = notch_substeps(y0, x, p) if p[I_MODEL] > 1.5 else 0  # the load pressure meets a notch edge
    if min(min(a0, b0), min(a1, b1)) < p[D_PAIR]:
        return max(max(m, n_notch), air_band_substeps(y0, x, p))
    if n_notch > 0:
        return max(m, n_notch)
    if _crossed(a0, a1, ps) or _crossed(b0, b1, ps) or _crossed(a0, a1, pt) or _crossed(b0, b1, pt):
        return m
    prv = p[I_PRV]
    pfull = prv + p[I_POV]
    if _crossed(a0, a1, prv) or _crossed(b0, b1, prv) or _crossed(a0, a1, pfull) or _crossed(b0, b1, pfull):
        return m  # the relief's kinks: cracking and full opening
    s0 = y0[XV]
    s1 = x[XV]
    u_lap = p[I_U]
    if (_crossed(s0, s1, -u_lap) or _crossed(s0, s1, u_lap) or _crossed(s0, s1, 1.0)
            or _crossed(s0, s1, -1.0)):  # a kink of the openings: eq (3) at +-U, the stroke limit
        return m
    if _crossed(y0[V], x[V], 0.0) and p[I_FS] > 0.0:  # a reversal: the seals' |v| kink (LuGre)
        return m
    if _orifice_modes_surely_stable(y0, x, p, h):  # short cut, same answer as the rates
        return 1
    return local_substeps(h * max(local_mode_rate(y0, p), local_mode_rate(x, p)), STABLE_H_LAMBDA, m)


@nb.njit(cache=True, error_model="numpy", inline="always")
def local_mode_refinement(p, h):
    """Fine sub-steps per sub-step of ``h`` seconds that keep the orifice modes stable at their
    worst case (``D_LOCAL``, :func:`.bounds.local_mode_rates`), and at least 2: the look-ahead
    refines the underlap's kinks, the notch edges and the air band for accuracy also where the
    orifice modes would be stable at ``h`` (with 1 it would not look at them)."""
    return max(2, worst_case_substeps(h * p[D_LOCAL]))


# ---------------------------------------------------------------------------- analysis
def relief_bounds(P: np.ndarray) -> tuple[tuple[int, int], np.ndarray]:
    """``((PA, PB), (n, 2) [Pa])``: each chamber's port-relief full-flow pressure (cracking +
    override; the supply if higher; inf without relief) per row of ``P`` (:mod:`hydro_envs.soak`)."""
    full = np.where(P[:, I_QRV] > 0.0, np.maximum(P[:, I_PRV] + P[:, I_POV], P[:, I_PS]), np.inf)
    return (PA, PB), np.stack([full, full], axis=1)


def effective_bulk_modulus(params: ShakingTableParams, pa, pb) -> np.ndarray:
    """Chamber moduli ``(..., 2)`` [Pa] (E_a, E_b) at pressures ``pa``, ``pb`` (broadcast)."""
    pa, pb = np.broadcast_arrays(np.asarray(pa, dtype=float), np.asarray(pb, dtype=float))
    shape = pa.shape
    out = np.empty((pa.size, 2))
    _moduli_array(np.ascontiguousarray(pa.ravel()), np.ascontiguousarray(pb.ravel()), params.to_array(), out)
    return out.reshape(shape + (2,))


def null_pressure(params: ShakingTableParams) -> float:
    """Chamber pressure [Pa] at rest with the spool centred (P_a = P_b).

    Through the underlap both edges of each chamber are open by U; with no motion the supply
    inflow equals the tank outflow plus the external leak (internal leakage is zero at
    P_a = P_b): ``R U (sqrt~(P_s - P) - sqrt~(P - P_T)) = C_el (P - P_T)`` (eqs (1), (8)).
    The external leak lowers it below (P_s + P_T)/2 (by about 2 MPa with Table 2's C_el).
    """
    p = params.to_array()

    flows = as_python(valve_flows)  # the same arithmetic; a compiled copy would cost an env's reset 0.3 s

    def residual(pr: float) -> float:
        qa, _ = flows(0.0, pr, pr, p)
        return qa - params.external_leakage * (pr - params.tank_pressure)

    lo, hi = params.tank_pressure, params.supply_pressure
    if params.flow_coefficient == 0.0 or params.underlap == 0.0:
        return 0.5 * (lo + hi) if params.external_leakage == 0.0 else lo
    return brent_root(residual, lo, hi, xtol=1e-6, rtol=1e-14)


def rest_state(params: ShakingTableParams, x: float = 0.0, v: float = 0.0) -> np.ndarray:
    """State at position ``x`` (velocity ``v``), spool centred, chambers at the null pressure."""
    y = np.zeros(N_STATES)
    y[X] = x
    y[V] = v
    y[PA] = y[PB] = null_pressure(params)
    return y


def chamber_volumes(params: ShakingTableParams, x) -> tuple[Any, Any]:
    """(V_a, V_b) [m^3] at position ``x`` (003 eqs (6)-(7))."""
    half = 0.5 * params.stroke
    return (params.dead_volume + params.piston_area * (half + np.asarray(x)),
            params.dead_volume + params.piston_area * (half - np.asarray(x)))


def hydraulic_natural_frequency(
    params: ShakingTableParams, x: float = 0.0, pa: float | None = None, pb: float | None = None
) -> float:
    """Undamped hydraulic natural frequency [rad/s] of the linearisation at rest.

    Linearising eqs (6), (7), (10) about an equilibrium (v = 0, Q_a - Q_ia - Q_ea = 0) the
    terms with dE/dP multiply zero net flow, so the oil columns are two springs in parallel::

        omega_h^2 = A^2 (E_a / V_a + E_b / V_b) / M

    with E at the equilibrium pressures (default: the null pressure). The valve's
    pressure-flow slope, leakage and viscous friction add damping, not stiffness; the LuGre
    seals in stick add their bristle spring sigma0 (the oil column of the sliding table, or of
    the plant without dry friction, is this one).
    """
    if pa is None or pb is None:
        pa = pb = null_pressure(params)
    ea, eb = effective_bulk_modulus(params, pa, pb)
    va, vb = chamber_volumes(params, x)
    k = params.piston_area**2 * (ea / va + eb / vb)
    return math.sqrt(k / params.mass)


def no_load_velocity(params: ShakingTableParams) -> float:
    """Orifice-law table speed [m/s] at full spool opening, no load, no friction.

    With P_a - P_b = 0 each metering edge sees (P_s - P_T)/2:
    ``v = R (1 + U) sqrt((P_s - P_T)/2) / A`` (eqs (1)-(3), (6)-(7)); 0.43 m/s nominal.
    """
    return (params.flow_coefficient * (1.0 + params.underlap)
            * math.sqrt(0.5 * (params.supply_pressure - params.tank_pressure)) / params.piston_area)


def max_drive_force(params: ShakingTableParams) -> float:
    """Largest hydraulic force A (P_s - P_T) [N] (stalled, full opening)."""
    return params.piston_area * (params.supply_pressure - params.tank_pressure)


def ifas_relative_volume(params: ShakingTableParams, p) -> np.ndarray:
    """Volume of a fixed oil+air mass at pressure ``p`` relative to P_0 (IFAS eq (13) integrand).

    ``v(P) = (1 - alpha) (1 + m (P - P_0)/E_0)^(-1/m) + alpha (P_0/P)^(1/kappa)``; eq (13) is
    ``E = -v / (dv/dP)``, so in a sealed chamber ``V_chamber / v(P)`` (the trapped mass) is
    constant. For the constant model ``v = exp(-(P - P_0)/E_0)``.
    """
    p = np.maximum(np.asarray(p, dtype=float), params.pressure_floor)
    if params.bulk_modulus_model == 0.0:
        return np.exp(-(p - params.p0) / params.e0)
    m, e0, p0 = params.oil_exponent, params.e0, params.p0
    return ((1.0 - params.air_content) * (1.0 + m * (p - p0) / e0) ** (-1.0 / m)
            + params.air_content * (p0 / p) ** (1.0 / params.polytropic_exponent))


def closed_valve_energy(y: np.ndarray, params: ShakingTableParams, y0: np.ndarray) -> np.ndarray:
    """Kinetic energy plus oil energy stored since ``y0`` [J], constant modulus E_0.

    Sealed chamber at constant modulus: ``p(V) = p0 - E ln(V/V0)``; the stored energy from V0
    to V is ``-p0 (V - V0) + E (V ln(V/V0) - V + V0)``. With a sealed valve (R = 0), no leakage
    and no friction the sum over both chambers plus ``M v^2/2`` is conserved.
    """
    if params.bulk_modulus_model != 0.0:
        raise ValueError("closed_valve_energy is the closed form for bulk_modulus_model = 0 (constant)")
    y = np.atleast_2d(y)
    e = params.e0

    def chamber(vol, vol0, p0):
        return -p0 * (vol - vol0) + e * (vol * np.log(vol / vol0) - vol + vol0)

    va0, vb0 = chamber_volumes(params, y0[X])
    va, vb = chamber_volumes(params, y[:, X])
    return 0.5 * params.mass * y[:, V] ** 2 + chamber(va, va0, y0[PA]) + chamber(vb, vb0, y0[PB])


def rest_state_from_measurement(params: ShakingTableParams, first: dict) -> np.ndarray:
    """State at a record's first sample: :func:`rest_state` at the measured position (0 if not
    measured)."""
    return rest_state(params, first.get("x", 0.0))


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    fit_outputs=FIT_OUTPUTS, presets=tuple(PRESETS), rest_state=rest_state,
    rest_state_from_measurement=rest_state_from_measurement, relief_bounds=relief_bounds,
)
