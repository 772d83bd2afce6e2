r"""Valve-controlled double-rod servo cylinder (seed 002, Moog D765 servo-valve).

Source: ``002_af30b681d6ccfd6c.txt`` -- "Neural Network-based Friction Identification in
Hydraulic Actuators": state-space model eq (8), friction eq (1), Table 1 parameters.

State (SI, pressures absolute)::

    index  name  unit   meaning
    0      x     m      piston position, 0 at the chamber-1 end, stroke at the other
    1      v     m/s    piston velocity
    2      p1    Pa     chamber-1 pressure
    3      p2    Pa     chamber-2 pressure
    4      xv    m      valve spool position
    5      vv    m/s    valve spool velocity
    6      z     m      bristle (pre-sliding) deflection of the seals (LuGre state)

Input: ``u`` [V], servo-valve command, +-10 V for full spool stroke (Table 1: k_v = 0.0279
mm/V, x_vm = 0.279 mm).

Equations (numbers of 002)::

    x'  = v                                                          (8.1)
    m v' = A (p1 - p2) - F_f - F_L + F_stop(x, v)                     (7), (8.2)
    p1' = beta / (A x + V1) * (Q1 - A v)                              (5), (8.3)
    p2' = beta / (A (L - x) + V2) * (Q2 + A v)                        (6), (8.4)
    xv'' = -w_v^2 xv - 2 zeta_v w_v xv' + k_v w_v^2 u                 (2), (8.5-6)
    F_f = sigma0 z + sigma1(v) z' + d v,   z' = v - sigma0 |v| z / g(v)  (LuGre)
    g(v) = F_C + (F_S - F_C) exp(-|v|/v_S)                            (1)

Friction: the seal friction family of :mod:`hydro_envs.laws.seal_friction` (LuGre, n = 1)
with 002 eq (1) as its steady state: at constant v, ``F_f = g(v) sign(v) + d v`` exactly, the
paper's sliding branch with the discontinuous sign; at v = 0 the seals hold the piston on their
bristle spring up to the breakaway force F_S (eq (1)'s stick branch ``min(|u|, F_S)``), with the
pre-sliding displacement ``F_S / sigma0``. No regularisation velocity enters the model.

Valve flows (critically lapped, matched, symmetric; Q2 counted *into* chamber 2)::

    Q1 = C_v w sqrt(2/rho) [ xv+ sqrt(p_s - p1) - xv- sqrt(p1 - p_R) ]     (3)
    Q2 = C_v w sqrt(2/rho) [ xv- sqrt(p_s - p2) - xv+ sqrt(p2 - p_R) ]     (4)

with ``xv+ = max(xv, 0)``, ``xv- = max(-xv, 0)``, the spool opening limited to +-x_vm.

Effects outside the seed model (all 0 by default, i.e. exactly 002 eq (8); added by the
diagnosis workflow, :mod:`identification.diagnosis`, when measured data call for them)::

    valve_overlap x_lap:   every edge opens by max(+-xv - x_lap, 0) (all four edges evaluated)
    internal_leakage C_il: Q1 -= C_il (p1 - p2), Q2 += C_il (p1 - p2)       (as 003 eqs (4)-(5))
    external_leakage C_el: Q_i -= C_el (p_i - p_R)                          (as 003 eqs (4)-(5))
    friction_asymmetry a, friction_pressure_coefficient c_p: both Stribeck levels of (1) become
        (1 + a sign(v)) (F + c_p |p1 - p2|)
    supply_line_resistance R_s: the P edge sees p_s - R_s Q_P instead of p_s (supply droop with
        the drawn flow, hydro_envs.laws.orifice.supply_pressure_at_flow; with an underlapped
        spool near null, where both P edges are open, from the wider edge's flow)

Port reliefs (not in 002, always on): each chamber drains to tank through a relief valve,
``Q_i -= q_relief(p_i - p_R)`` (:func:`hydro_envs.laws.relief.pressure_relief_flow`, cracking
at ``relief_pressure``, rated ``relief_flow`` at ``relief_pressure + relief_override``; the
settings are assumed). Closed below cracking (16 MPa gauge), so the seed's model is unchanged
wherever the chambers stay below it; a piston braked by its closing valve would otherwise
compress the outlet chamber far above the supply.

Decisions on the extracted text (see ``docs/references.md``):

* eq (5) prints the chamber volume as ``A x_p - V1``; physically it is ``A x_p + V1`` (the
  line volume adds to the swept volume). We use ``+``.
* eqs (3)-(4) in compact form ``sqrt((Ps-PR)/2 + sgn(xv)((Ps-PR)/2 - P1))`` equal the
  edge-by-edge form above only for ``P_R = 0``; with absolute pressures we write the edges
  out. The root is regularised (laminar below ``orifice_transition_pressure``) so reverse
  flow (p1 > p_s while braking) is allowed and the Jacobian stays finite at zero pressure drop.
* Table 1's "0.65 cm^3" for zeta_v is a stray unit: zeta_v = 0.65.
* Table 1 gives no Stribeck parameters (the friction figures are missing from the text); the
  defaults below are assumed, of the size of the fitting errors E = 2.5-3.1 N of sec. 5.

Guards (``docs/references.md``, numerics notes): chamber pressures never integrate below a cavitation floor
(derivative clipped at the floor here, state clamped after each sub-step by the integrator),
chamber volumes never below ``min_chamber_volume``, and end stops at 0 and L act through a
continuous Hunt-Crossley contact force (:mod:`hydro_envs.laws.contact`).
"""

from __future__ import annotations

import math

import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import as_python, njit_noalloc
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.seal_friction import (
    FADE_CUTOFF,
    bristle_stiffness_bound,
    seal_friction,
    stribeck_slope_ratio_bound,
)
from hydro_envs.sim.stiffness import second_order_pole_magnitude
from hydro_envs.laws.orifice import orifice_flow, spool_edge_opening, supply_pressure_at_flow
from hydro_envs.laws.relief import pressure_relief_conductance_bound, pressure_relief_flow
from hydro_envs.laws.valve import second_order_valve_acceleration
from hydro_envs.libm import exp
from hydro_envs.plants.servo_cylinder.params import (  # noqa: F401  (indices re-exported)
    I_A, I_ASTOP, I_CD, I_CEL, I_CIL, I_D, I_DPTR, I_FASYM, I_FC, I_FL, I_FPC, I_FS, I_KSTOP, I_KV, I_L,
    I_LAP, I_M, I_PFLOOR, I_PS, I_PT, I_RHO, I_RS, I_SIG0, I_SIG1, I_UMAX, I_V1, I_V2, I_VMIN, I_VS, I_W,
    I_WV, I_XVM, I_ZCAP, I_ZV, I_BETA, I_DFADE, I_PRV, I_POV, I_QRV, N_FIELDS, N_PARAMS, PLANT, ServoCylinderParams,
)

__all__ = [
    "CONTRACT",
    "ServoCylinderParams",
    "STATE_NAMES",
    "servo_cylinder_rhs",
    "servo_cylinder_guard",
    "stiffness_modes",
    "friction_level",
    "friction_bounds",
    "hydraulic_natural_frequency",
    "no_load_velocity",
    "closed_valve_energy",
]

STATE_NAMES = ("x", "v", "p1", "p2", "xv", "vv", "z")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "m", "m/s", "m")
N_STATES = 7
X, V, P1, P2, XV, VV, Z = range(N_STATES)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {"x": X, "p1": P1, "p2": P2}
DERIVATIVE_OUTPUTS: dict[str, int] = {}
#: channels a grey-box fit uses by default
FIT_OUTPUTS = ("x", "p1", "p2")


@njit_noalloc
def servo_cylinder_rhs(y, u, p, dy):
    """Time derivative ``dy`` of state ``y`` under command ``u[0]`` [V] (002 eq (8))."""
    x = y[X]
    v = y[V]
    p1 = y[P1]
    p2 = y[P2]
    xv = y[XV]
    vv = y[VV]
    ps = p[I_PS]
    pt = p[I_PT]
    area = p[I_A]

    # Spool opening limited by the spool stroke x_vm (Table 1).
    xo = min(max(xv, -p[I_XVM]), p[I_XVM])
    cd = p[I_CD]
    rho = p[I_RHO]
    dptr = p[I_DPTR]
    w = p[I_W]
    lap = p[I_LAP]
    r_s = p[I_RS]
    if lap == 0.0:
        # Critical lap (the seed's valve): only the two edges on the side the spool moved to
        # are open, so only they are evaluated: Q1 into chamber 1 (3), Q2 into chamber 2 (4).
        if xo >= 0.0:  # P -> 1 and 2 -> T open, area w * xo
            ps1 = supply_pressure_at_flow(ps, p1, cd, w * xo, rho, r_s)  # p_s itself for R_s = 0
            q1 = orifice_flow(cd, w * xo, ps1 - p1, rho, dptr)  # (3)
            q2 = -orifice_flow(cd, w * xo, p2 - pt, rho, dptr)  # (4)
        else:  # P -> 2 and 1 -> T open, area w * |xo|
            ps2 = supply_pressure_at_flow(ps, p2, cd, -w * xo, rho, r_s)
            q1 = -orifice_flow(cd, -w * xo, p1 - pt, rho, dptr)  # (3)
            q2 = orifice_flow(cd, -w * xo, ps2 - p2, rho, dptr)  # (4)
    else:
        # Lapped spool: each of the four edges opens by max(+-xo - lap, 0) (Hopsan laps).
        a_p1 = w * spool_edge_opening(xo, lap)  # P -> 1
        a_2t = w * spool_edge_opening(xo, lap)  # 2 -> T
        a_p2 = w * spool_edge_opening(-xo, lap)  # P -> 2
        a_1t = w * spool_edge_opening(-xo, lap)  # 1 -> T
        # the supply drop of the wider P edge (both are open only near null)
        if a_p1 >= a_p2:
            ps_v = supply_pressure_at_flow(ps, p1, cd, a_p1, rho, r_s)
        else:
            ps_v = supply_pressure_at_flow(ps, p2, cd, a_p2, rho, r_s)
        q1 = orifice_flow(cd, a_p1, ps_v - p1, rho, dptr) - orifice_flow(cd, a_1t, p1 - pt, rho, dptr)
        q2 = orifice_flow(cd, a_p2, ps_v - p2, rho, dptr) - orifice_flow(cd, a_2t, p2 - pt, rho, dptr)
    # Seal leaks (0 in the seed): cross-piston 1 -> 2 and each chamber to tank.
    q_il = p[I_CIL] * (p1 - p2)
    q1 -= q_il + p[I_CEL] * (p1 - pt)
    q2 += q_il - p[I_CEL] * (p2 - pt)
    # Port reliefs to tank (not in 002; closed below relief_pressure).
    crack = p[I_PRV] - pt
    q1 -= pressure_relief_flow(p1 - pt, crack, p[I_POV], p[I_QRV])
    q2 -= pressure_relief_flow(p2 - pt, crack, p[I_POV], p[I_QRV])

    vol1 = max(area * x + p[I_V1], p[I_VMIN])  # (5), "+ V1" (extraction defect fixed)
    vol2 = max(area * (p[I_L] - x) + p[I_V2], p[I_VMIN])  # (6)
    dp1 = p[I_BETA] / vol1 * (q1 - area * v)  # (5), (8.3)
    dp2 = p[I_BETA] / vol2 * (q2 + area * v)  # (6), (8.4)
    # Cavitation guard: a chamber at the floor cannot lose more pressure.
    if p1 <= p[I_PFLOOR] and dp1 < 0.0:
        dp1 = 0.0
    if p2 <= p[I_PFLOOR] and dp2 < 0.0:
        dp2 = 0.0

    # (1), (7): LuGre seals with eq (1) as steady state
    f_friction, dz = seal_friction(v, y[Z], friction_level(v, p1 - p2, p), p[I_SIG0], p[I_SIG1], p[I_DFADE],
                                   p[I_D], 1, p[I_ZCAP])
    f_stop = end_stop_force(x, v, 0.0, p[I_L], p[I_KSTOP], p[I_ASTOP])
    dy[X] = v  # (8.1)
    dy[V] = (area * (p1 - p2) - f_friction - p[I_FL] + f_stop) / p[I_M]  # (7), (8.2)
    dy[P1] = dp1
    dy[P2] = dp2
    dy[XV] = vv  # (8.5)
    dy[VV] = second_order_valve_acceleration(xv, vv, u[0], p[I_KV], p[I_WV], p[I_ZV])  # (2), (8.6)
    dy[Z] = dz


@njit_noalloc
def friction_level(v, dp, p):
    """Steady-state friction level ``g(v)`` [N] of 002 eq (1) at velocity ``v`` and pressure
    difference ``dp = p1 - p2``: ``(1 + a sign(v)) (F_C + c_p |dp| + (F_S - F_C) exp(-|v|/v_S))``
    (asymmetry ``a`` and pressure coefficient ``c_p`` 0 in the seed; 0 without dry friction)."""
    s = 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)
    level = 1.0 + p[I_FASYM] * s
    g = p[I_FC] + p[I_FPC] * abs(dp)
    r = abs(v) / p[I_VS]
    if r < FADE_CUTOFF:  # the Stribeck dip; beyond, below the rounding of g
        g += (p[I_FS] - p[I_FC]) * exp(-r)
    return level * g


@njit_noalloc
def servo_cylinder_guard(y, p):
    """Project the state back onto the physical set after a sub-step; return #clamps."""
    n = 0
    if y[P1] < p[I_PFLOOR]:
        y[P1] = p[I_PFLOOR]
        n += 1
    if y[P2] < p[I_PFLOOR]:
        y[P2] = p[I_PFLOOR]
        n += 1
    return n


# ---------------------------------------------------------------------------- analysis
def relief_bounds(P: np.ndarray) -> tuple[tuple[int, int], np.ndarray]:
    """``((P1, P2), (n, 2) [Pa])``: each chamber's port-relief full-flow pressure
    ``relief_pressure + relief_override`` per row of the kernel parameter array ``P``, or the
    supply if higher (a relief set below it passes the valve's flow from the supply, more than
    its rating; inf without relief): the bound the soak test (:mod:`hydro_envs.soak`) holds the
    chambers to."""
    full = np.where(P[:, I_QRV] > 0.0, np.maximum(P[:, I_PRV] + P[:, I_POV], P[:, I_PS]), np.inf)
    return (P1, P2), np.stack([full, full], axis=1)


def hydraulic_natural_frequency(params: ServoCylinderParams, x: float) -> float:
    """Undamped hydraulic natural frequency [rad/s] at position ``x`` with the valve closed.

    ``omega_h^2 = beta A^2 (1/V1 + 1/V2) / m`` (two oil springs in parallel on the mass).
    """
    vol1 = params.piston_area * x + params.line_volume_1
    vol2 = params.piston_area * (params.stroke - x) + params.line_volume_2
    k_oil = params.bulk_modulus * params.piston_area**2 * (1.0 / vol1 + 1.0 / vol2)
    return math.sqrt(k_oil / params.mass)


def friction_bounds(params: ServoCylinderParams) -> dict[str, float]:
    """Bounds of the LuGre friction over the state space: the smallest sliding level ``g_min``
    (Coulomb, lowered by the asymmetry), the largest level ``g_max`` (static, raised by the
    asymmetry and the seal pressure at the full supply drop), the bristle deflection bound
    ``z_max = g_max / sigma0`` (LuGre keeps ``|z|`` inside it), the bound of ``|v g'| / g``
    (:func:`~hydro_envs.laws.seal_friction.stribeck_slope_ratio_bound`) and the speed bound
    ``v_max`` = 2 x the no-load velocity (the env's velocity limit,
    :data:`hydro_envs.envs.base.VELOCITY_FACTOR`). ``g_max = 0``: no dry friction."""
    a = abs(params.friction_asymmetry)
    f_add = params.friction_pressure_coefficient * (params.supply_pressure - params.pressure_floor)
    g_min = (1.0 - a) * params.coulomb_friction
    g_max = (1.0 + a) * (max(params.static_friction, params.coulomb_friction) + f_add)
    ratio = stribeck_slope_ratio_bound(params.coulomb_friction, params.static_friction, "exponential")
    return {"g_min": g_min, "g_max": g_max, "z_max": g_max / params.bristle_stiffness, "slope_ratio": ratio,
            "v_max": 2.0 * no_load_velocity(params)}


def _friction_rate(params: ServoCylinderParams) -> float:
    b = friction_bounds(params)
    v_d = float(params.to_array()[I_DFADE])
    return bristle_stiffness_bound(b["g_min"], b["g_max"], b["slope_ratio"], params.bristle_stiffness,
                                   params.bristle_damping, v_d, params.viscous_friction,
                                   params.mass, 1, params.bristle_relaxation_cap, b["v_max"])


def stiffness_modes(params: ServoCylinderParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of every fast mode.

    The fixed RK4 sub-step must keep ``h * |lambda| <= 2.78`` for all of them
    (:func:`hydro_envs.sim.stiffness.rk4_substeps`). Each entry is the worst case over the
    state space (stroke end, full opening, zero pressure drop, zero velocity):

    * ``valve``: spool poles, ``omega_v`` (the fast real pole when over-damped,
      :func:`~hydro_envs.sim.stiffness.second_order_pole_magnitude`).
    * ``hydraulic``: oil spring on the mass, largest at the stroke end (smallest volume).
    * ``orifice``: laminar slope of the regularised root at zero drop, fully open, into the
      smallest chamber: ``beta / V_min * C_v w x_vm sqrt(2/rho) / sqrt(dp_tr)``.
    * ``friction``: the velocity-bristle block of the LuGre seals over all speeds
      (:func:`~hydro_envs.laws.seal_friction.bristle_stiffness_bound`): the piston's pre-sliding
      oscillation on its bristles at rest (about ``4.5 sqrt(sigma0 / m)`` with critical
      micro-damping) and the bristle relaxation at speed, capped at ``bristle_relaxation_cap``.
    * ``end_stop``: contact spring ``sqrt(k/m)`` plus its damping ``alpha * F_max / m`` at the
      penetration where the stop holds the full thrust and the load ``F_max = A (p_s - p_floor)
      + |F_L|`` (a load beyond what the port reliefs hold rests on the stop).
    * ``relief``: an open port relief into the smallest chamber at its steepest
      (:func:`~hydro_envs.laws.relief.pressure_relief_conductance_bound`), with the fully open
      supply edge at the drop ``p_s - p_relief`` it then sees (its zero-drop slope if the relief
      cracks below the supply) and the leaks.
    """
    a = params.piston_area
    vol_min = min(params.line_volume_1, params.line_volume_2)
    omega_h = max(
        hydraulic_natural_frequency(params, 0.0),
        hydraulic_natural_frequency(params, params.stroke),
    )
    underlap = max(-params.valve_overlap, 0.0)
    g_lam = (
        params.discharge_coefficient
        * params.area_gradient
        * (params.spool_stroke + 2.0 * underlap)  # open edge plus the opposite underlapped one
        * math.sqrt(2.0 / params.oil_density)
        / math.sqrt(params.orifice_transition_pressure)
    )
    g_leak = 2.0 * params.internal_leakage + params.external_leakage
    # full thrust: the valve's (up to the supply) plus the load, which the stop holds once the
    # port reliefs no longer do
    f_max = a * (params.supply_pressure - params.pressure_floor) + abs(params.load_force)
    drop = max(params.relief_pressure - params.supply_pressure, 0.0)
    g_relief = float(as_python(pressure_relief_conductance_bound)(
        params.relief_pressure - params.tank_pressure, params.relief_override, params.relief_flow))
    g_edge = g_lam * math.sqrt(params.orifice_transition_pressure) / math.sqrt(
        math.sqrt(drop * drop + params.orifice_transition_pressure**2))
    return {
        "relief": params.bulk_modulus / vol_min * (g_relief + g_edge + g_leak),
        "valve": second_order_pole_magnitude(params.valve_natural_frequency, params.valve_damping),
        "hydraulic": omega_h,
        "orifice": params.bulk_modulus / vol_min * (g_lam + g_leak),
        "friction": _friction_rate(params),
        "end_stop": math.sqrt(params.stop_stiffness / params.mass)
        + params.stop_damping * f_max / params.mass,
    }


def no_load_velocity(params: ServoCylinderParams) -> float:
    """Orifice-law piston speed [m/s] at full spool opening with no load and no friction.

    With p1 - p2 = 0 both metering edges see half the supply-to-tank drop:
    ``v = C_v w x_vm sqrt(2/rho) sqrt((p_s - p_R)/2) / A`` (from 002 eqs (3)-(5)).
    """
    q = (
        params.discharge_coefficient
        * params.area_gradient
        * params.spool_stroke
        * math.sqrt(2.0 / params.oil_density)
        * math.sqrt((params.supply_pressure - params.tank_pressure) / 2.0)
    )
    return q / params.piston_area


def closed_valve_energy(y: np.ndarray, params: ServoCylinderParams, y0: np.ndarray) -> np.ndarray:
    """Kinetic energy plus fluid energy stored since state ``y0`` [J] (rows of ``y`` are states).

    For a sealed chamber at constant bulk modulus, ``dp = -beta dV / V`` gives
    ``p(V) = p0 - beta ln(V/V0)`` and the energy stored by compressing it from V0 to V is
    ``-int p dV = -p0 (V - V0) + beta (V ln(V/V0) - V + V0)``. With the valve closed and no
    friction the sum over both chambers plus ``m v^2 / 2`` is conserved exactly.
    """
    y = np.atleast_2d(y)
    a = params.piston_area
    beta = params.bulk_modulus

    def chamber(vol, vol0, p0):
        return -p0 * (vol - vol0) + beta * (vol * np.log(vol / vol0) - vol + vol0)

    v10 = a * y0[X] + params.line_volume_1
    v20 = a * (params.stroke - y0[X]) + params.line_volume_2
    v1 = a * y[:, X] + params.line_volume_1
    v2 = a * (params.stroke - y[:, X]) + params.line_volume_2
    return (
        0.5 * params.mass * y[:, V] ** 2
        + chamber(v1, v10, y0[P1])
        + chamber(v2, v20, y0[P2])
    )


def rest_state_from_measurement(params: ServoCylinderParams, first: dict) -> np.ndarray:
    """State at a record's first sample: at rest at the measured position (mid-stroke if not
    measured), chamber pressures as measured or at the valve's null pressure ``(p_s + p_R)/2``."""
    y = np.zeros(N_STATES)
    y[X] = first.get("x", 0.5 * params.stroke)
    pm = 0.5 * (params.supply_pressure + params.tank_pressure)
    y[P1] = first.get("p1", pm)
    y[P2] = first.get("p2", pm)
    return y


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    fit_outputs=FIT_OUTPUTS, rest_state_from_measurement=rest_state_from_measurement,
    relief_bounds=relief_bounds,
)
