r"""Valve-controlled differential (single-rod) cylinder with a 4/3 proportional valve.

State (SI, pressures absolute)::

    index  name  unit   meaning
    0      x     m      piston position, 0 at the cap end (rod retracted), stroke at the rod end
    1      v     m/s    piston velocity (> 0 extends)
    2      p1    Pa     cap-side (piston) chamber pressure
    3      p2    Pa     rod-side (annulus) chamber pressure
    4      xv    1      spool position as a fraction of the nominal opening (+-1 at +-command_max)
    5      vv    1/s    spool velocity
    6      z     m      bristle (pre-sliding) deflection of the seals (LuGre state)

Input: ``u`` [V], valve command, +-command_max (10 V) for full opening.

Equations (textbook valve-controlled differential cylinder: Merritt, *Hydraulic Control
Systems*, 1967, ch. 5; Jelali & Kroll, *Hydraulic Servo-systems*, 2003, sec. 3.3-3.4)::

    A1 = pi/4 D^2,  A2 = pi/4 (D^2 - d^2)                              areas of bore D, rod d
    x'  = v
    m v' = A1 p1 - A2 p2 - (A1 - A2) p_amb - F_f - F_L + F_stop(x, v)   (ambient on the rod's end)
    p1' = beta / (A1 x + V01) (Q1 - A1 v)
    p2' = beta / (A2 (L - x) + V02) (Q2 + A2 v)
    xv'' = -w_v^2 xv - 2 zeta_v w_v xv' + w_v^2 u / u_max              (second-order spool)
    Q1 = K [ o(xv) r(p_s - p1) - o(-xv) r(p1 - p_T) ]                  (P->A, A->T edges)
    Q2 = K [ o(-xv) r(p_s - p2) - o(xv) r(p2 - p_T) ]                  (P->B, B->T edges)

with ``o(s) = max(s - lap, 0)`` each edge's opening (Hopsan laps,
:func:`~hydro_envs.laws.orifice.spool_edge_opening`; the spool limited to +-1), ``r`` the
regularised signed root (:func:`~hydro_envs.laws.orifice.regularized_signed_sqrt`) and
``K = Q_N / sqrt(dp_N / 2)`` one fully open edge's coefficient from the data sheet's rated flow
at the rated valve drop (:func:`~hydro_envs.plants.differential_cylinder.params.edge_flow_coefficient`).
The spool's ``w_v`` follows from the data-sheet bandwidth and the damping
(:func:`~hydro_envs.plants.differential_cylinder.params.bandwidth_to_natural_frequency`).

Friction: the servo plant's seal law, :func:`hydro_envs.laws.seal_friction.seal_friction` (LuGre,
n = 1) with the exponential Stribeck level ``g(v) = F_C + (F_S - F_C) exp(-|v|/v_S)`` as its
steady state: it sticks at v = 0 up to F_S, no regularisation velocity.

Guards: chamber pressures never integrate below a cavitation floor (derivative clipped, state
clamped after each sub-step), chamber volumes never below ``min_chamber_volume``, end stops at
0 and L as a continuous Hunt-Crossley contact force (:mod:`hydro_envs.laws.contact`).
"""

from __future__ import annotations

import math

import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.orifice import regularized_signed_sqrt, spool_edge_opening
from hydro_envs.laws.seal_friction import (
    FADE_CUTOFF,
    bristle_stiffness_bound,
    seal_friction,
    stribeck_slope_ratio_bound,
)
from hydro_envs.laws.valve import second_order_valve_acceleration
from hydro_envs.libm import exp
from hydro_envs.plants.differential_cylinder.datasheet import load_rig
from hydro_envs.plants.differential_cylinder.params import (  # noqa: F401  (indices re-exported)
    I_A1, I_A2, I_FAMB, I_ASTOP, I_BETA, I_D, I_DFADE, I_DPTR, I_FC, I_FL, I_FS, I_KQ, I_KSTOP, I_L, I_LAP, I_M,
    I_PFLOOR, I_PS, I_PT, I_SIG0, I_SIG1, I_UMAX, I_V1, I_V2, I_VMIN, I_VS, I_WV, I_ZCAP, I_ZV, N_FIELDS,
    N_PARAMS, PLANT, DifferentialCylinderParams, edge_flow_coefficient,
)
from hydro_envs.sim.stiffness import second_order_pole_magnitude

__all__ = [
    "CONTRACT",
    "DifferentialCylinderParams", "STATE_NAMES", "differential_cylinder_rhs", "differential_cylinder_guard",
    "stiffness_modes", "friction_level", "hydraulic_natural_frequency", "minimum_natural_frequency",
    "no_load_velocity", "speed_ratio", "rest_state", "rest_state_from_measurement",
]

STATE_NAMES = ("x", "v", "p1", "p2", "xv", "vv", "z")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "1", "1/s", "m")
N_STATES = 7
X, V, P1, P2, XV, VV, Z = range(N_STATES)

#: sensor outputs (noise-free): measured channel -> the state index it reads
STATE_OUTPUTS: dict[str, int] = {"x": X, "p1": P1, "p2": P2}
DERIVATIVE_OUTPUTS: dict[str, int] = {}
#: channels a grey-box fit uses by default
FIT_OUTPUTS = ("x", "p1", "p2")


@njit_noalloc
def friction_level(v, p):
    """Steady-state friction level ``g(v) = F_C + (F_S - F_C) exp(-|v|/v_S)`` [N] (the servo
    plant's 002 eq (1)); 0 without dry friction."""
    g = p[I_FC]
    r = abs(v) / p[I_VS]
    if r < FADE_CUTOFF:
        g += (p[I_FS] - p[I_FC]) * exp(-r)
    return g


@njit_noalloc
def valve_flows(xv, p1, p2, p):
    """Flows ``Q1`` into the cap side and ``Q2`` into the rod side [m^3/s] of the 4/3 valve at
    spool position ``xv`` (fraction of the nominal opening, limited to +-1)."""
    xo = min(max(xv, -1.0), 1.0)
    lap = p[I_LAP]
    k = p[I_KQ]
    dptr = p[I_DPTR]
    o_pa = spool_edge_opening(xo, lap)  # P -> A and B -> T open with xv > 0
    o_pb = spool_edge_opening(-xo, lap)  # P -> B and A -> T open with xv < 0
    ps = p[I_PS]
    pt = p[I_PT]
    q1 = k * (o_pa * regularized_signed_sqrt(ps - p1, dptr) - o_pb * regularized_signed_sqrt(p1 - pt, dptr))
    q2 = k * (o_pb * regularized_signed_sqrt(ps - p2, dptr) - o_pa * regularized_signed_sqrt(p2 - pt, dptr))
    return q1, q2


@njit_noalloc
def differential_cylinder_rhs(y, u, p, dy):
    """Time derivative ``dy`` of state ``y`` under valve command ``u[0]`` [V] (module docstring)."""
    x = y[X]
    v = y[V]
    p1 = y[P1]
    p2 = y[P2]
    a1 = p[I_A1]
    a2 = p[I_A2]
    q1, q2 = valve_flows(y[XV], p1, p2, p)
    vol1 = max(a1 * x + p[I_V1], p[I_VMIN])
    vol2 = max(a2 * (p[I_L] - x) + p[I_V2], p[I_VMIN])
    dp1 = p[I_BETA] / vol1 * (q1 - a1 * v)
    dp2 = p[I_BETA] / vol2 * (q2 + a2 * v)
    # cavitation guard: a chamber at the floor cannot lose more pressure
    if p1 <= p[I_PFLOOR] and dp1 < 0.0:
        dp1 = 0.0
    if p2 <= p[I_PFLOOR] and dp2 < 0.0:
        dp2 = 0.0
    f_friction, dz = seal_friction(v, y[Z], friction_level(v, p), p[I_SIG0], p[I_SIG1], p[I_DFADE], p[I_D], 1,
                                   p[I_ZCAP])
    f_stop = end_stop_force(x, v, 0.0, p[I_L], p[I_KSTOP], p[I_ASTOP])
    dy[X] = v
    dy[V] = (a1 * p1 - a2 * p2 - p[I_FAMB] - f_friction - p[I_FL] + f_stop) / p[I_M]
    dy[P1] = dp1
    dy[P2] = dp2
    dy[XV] = y[VV]
    dy[VV] = second_order_valve_acceleration(y[XV], y[VV], u[0], 1.0 / p[I_UMAX], p[I_WV], p[I_ZV])
    dy[Z] = dz


@njit_noalloc
def differential_cylinder_guard(y, p):
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
def chamber_volumes(params: DifferentialCylinderParams, x: float) -> tuple[float, float]:
    """Cap- and rod-side volumes [m^3] at position ``x``: ``A1 x + V01``, ``A2 (L - x) + V02``."""
    return (params.piston_area * x + params.line_volume_1,
            params.annulus_area * (params.stroke - x) + params.line_volume_2)


def hydraulic_natural_frequency(params: DifferentialCylinderParams, x: float) -> float:
    """Undamped hydraulic natural frequency [rad/s] at ``x``, valve closed:
    ``omega^2 = beta / m (A1^2 / V1 + A2^2 / V2)`` (Merritt 1967 sec. 5.3; Jelali & Kroll 2003
    eq (3.70)): the two oil springs in parallel on the mass."""
    v1, v2 = chamber_volumes(params, x)
    k = params.bulk_modulus * (params.piston_area**2 / v1 + params.annulus_area**2 / v2)
    return math.sqrt(k / params.mass)


def minimum_natural_frequency_position(params: DifferentialCylinderParams) -> float:
    """Position [m] of the minimum of :func:`hydraulic_natural_frequency`: ``d/dx = 0`` gives
    ``A1^3 / V1^2 = A2^3 / V2^2``, i.e. ``V2 = (A2/A1)^(3/2) V1`` (linear in x), clipped to the stroke."""
    a1, a2 = params.piston_area, params.annulus_area
    r = (a2 / a1) ** 1.5
    x = (a2 * params.stroke + params.line_volume_2 - r * params.line_volume_1) / (a2 + r * a1)
    return min(max(x, 0.0), params.stroke)


def minimum_natural_frequency(params: DifferentialCylinderParams) -> float:
    """The smallest hydraulic natural frequency over the stroke [rad/s]."""
    return hydraulic_natural_frequency(params, minimum_natural_frequency_position(params))


def no_load_velocity(params: DifferentialCylinderParams, direction: int = 1) -> float:
    """Steady piston speed [m/s] at full opening without load or friction, extending
    (``direction`` +1) or retracting (-1), from the orifice law with the force balance
    ``A1 p1 = A2 p2`` (pressures over tank, ``p_s`` for ``p_s - p_T``, ``alpha = A2/A1``; exact for a
    tank at ambient pressure, the ambient force on the rod's end then cancelling):

    * extend: ``p_s - p1 = (A1 v / K)^2``, ``p2 = (A2 v / K)^2`` -> ``v = K sqrt(p_s) / (A1 sqrt(1 + alpha^3))``
    * retract: ``p_s - p2 = (A2 v / K)^2``, ``p1 = (A1 v / K)^2`` -> ``v = K sqrt(p_s) / (A1 sqrt(alpha^2 + 1/alpha))``

    The ratio extend / retract is ``1 / sqrt(alpha)`` (:func:`speed_ratio`)."""
    k = edge_flow_coefficient(params.rated_flow, params.rated_pressure_drop) * (1.0 - params.valve_lap)
    alpha = params.area_ratio
    ps = params.supply_pressure - params.tank_pressure
    c = 1.0 + alpha**3 if direction > 0 else alpha**2 + 1.0 / alpha
    return k * math.sqrt(ps) / (params.piston_area * math.sqrt(c))


def speed_ratio(params: DifferentialCylinderParams) -> float:
    """Extend / retract no-load speed ratio at full opening, ``1 / sqrt(alpha)`` for the
    symmetric orifice law (:func:`no_load_velocity`)."""
    return 1.0 / math.sqrt(params.area_ratio)


def _friction_rate(params: DifferentialCylinderParams) -> float:
    g_max = max(params.static_friction, params.coulomb_friction)
    ratio = stribeck_slope_ratio_bound(params.coulomb_friction, params.static_friction, "exponential")
    v_d = float(params.to_array()[I_DFADE])
    v_max = 2.0 * no_load_velocity(params, 1)
    return bristle_stiffness_bound(params.coulomb_friction, g_max, ratio, params.bristle_stiffness,
                                   params.bristle_damping, v_d, params.viscous_friction, params.mass, 1,
                                   params.bristle_relaxation_cap, v_max)


def stiffness_modes(params: DifferentialCylinderParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of every fast mode (each the
    worst case over the state space): the spool poles; the oil spring on the mass at the stroke
    ends; the laminar slope of the regularised root at zero drop into the smaller dead volume,
    ``beta / V0_min K (1 + 2 underlap) / sqrt(dp_tr)`` (the open edge and the opposite underlapped
    one); the LuGre seals over all speeds
    (:func:`~hydro_envs.laws.seal_friction.bristle_stiffness_bound`); the end-stop contact at the
    full thrust ``A1 (p_s - p_floor)``."""
    a1 = params.piston_area
    k = edge_flow_coefficient(params.rated_flow, params.rated_pressure_drop)
    underlap = max(-params.valve_lap, 0.0)
    g_lam = k * (1.0 - params.valve_lap + 2.0 * underlap) / math.sqrt(params.orifice_transition_pressure)
    w_v = bandwidth_to_omega(params)
    f_max = a1 * (params.supply_pressure - params.pressure_floor)
    return {
        "valve": second_order_pole_magnitude(w_v, params.valve_damping),
        "hydraulic": max(hydraulic_natural_frequency(params, 0.0), hydraulic_natural_frequency(params, params.stroke)),
        "orifice": params.bulk_modulus / min(params.line_volume_1, params.line_volume_2) * g_lam,
        "friction": _friction_rate(params),
        "end_stop": math.sqrt(params.stop_stiffness / params.mass) + params.stop_damping * f_max / params.mass,
    }


def bandwidth_to_omega(params: DifferentialCylinderParams) -> float:
    """The spool's natural frequency [rad/s] (the derived kernel column)."""
    return float(params.to_array()[I_WV])


def rest_state(params: DifferentialCylinderParams, x: float | None = None) -> np.ndarray:
    """At rest at ``x`` (mid-stroke by default), valve at null, the rod side at the valve's null
    pressure ``(p_s + p_T)/2`` and the cap side at the pressure that balances it, the load and the
    ambient pressure on the rod's end, ``p1 = (A2 p2 + (A1 - A2) p_amb + F_L) / A1`` (floored at the
    cavitation floor)."""
    y = np.zeros(N_STATES)
    y[X] = 0.5 * params.stroke if x is None else x
    y[P2] = 0.5 * (params.supply_pressure + params.tank_pressure)
    a1, a2 = params.piston_area, params.annulus_area
    y[P1] = max((a2 * y[P2] + (a1 - a2) * params.ambient_pressure + params.load_force) / a1, params.pressure_floor)
    return y


def rest_state_from_measurement(params: DifferentialCylinderParams, first: dict) -> np.ndarray:
    """State at a record's first sample: at rest at the measured position and pressures (the
    :func:`rest_state` where not measured)."""
    y = rest_state(params, first.get("x"))
    y[P1] = first.get("p1", y[P1])
    y[P2] = first.get("p2", y[P2])
    return y


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    fit_outputs=FIT_OUTPUTS, rest_state=rest_state, rest_state_from_measurement=rest_state_from_measurement,
    load_params=load_rig,
)
