r"""Load-sensing circuit: variable pump with the seed-000 flow compensator, one actuator.

Source: ``000_d7d5fd9bd6b165a2.txt`` sec. 2 and Fig. 1 (scheme of a load-sensing control):
an axial piston pump whose displacement is set by two control pistons -- piston 2 (small,
always at the delivery pressure p_S) holds maximum displacement, piston 1 (large) is fed by
the flow compensator FC and destrokes the pump; the FC spool compares p_S with the load
pressure p_LS plus its spring, "typically around 20 bar"; the main control valve CV is a
variable restrictor, so the actuator flow depends only on the CV area. The FC spool is the
one of :mod:`hydro_envs.plants.ls_compensator` with its original spring (method 2: 294 Hz,
c = 3.5 N s/m at 40 C scaling with the oil viscosity, 000 Fig. 14); the LS pilot line is the
RLC pipe of 000 eqs (1)-(3), (5)-(6) between the load port and the spring chamber.
000 sec. 2: an LS system "features poor behavior in damping high inertial loads ... a
possible risk is the instability that is also influenced by the viscous friction force of
the FC" -- the control problem of ``hydro_envs/LoadSensing-v0``.

State (SI, absolute pressures)::

    index  name   unit    meaning
    0      x      m       FC spool travel from its seat towards the spring (P -> X opens at x_lap)
    1      v      m/s     FC spool velocity
    2      p_s    Pa      pump delivery pressure
    3      p_x    Pa      pressure behind control piston 1 (the large one)
    4      y      m       control-piston travel towards zero displacement (0 = full displacement)
    5      vy     m/s     control-piston velocity
    6      p_l    Pa      actuator (load) chamber pressure
    7      xa     m       actuator position
    8      va     m/s     actuator velocity
    9      q_ls   m^3/s   LS pilot-line flow, load port -> FC spring chamber
    10     p_ls   Pa      FC spring-chamber pressure (end of the LS line)
    11     f_sol  N       electro-proportional force on the FC spool (adds to the spring)

Inputs: ``u[0]`` solenoid force command [N] (first-order lag ``tau_sol``), ``u[1]`` CV
flow area [m^2] (clipped to ``[0, cv_area_max]``).

Equations::

    m x'' = A (p_s - p_ls) - F0 - k x - f_sol - c(T) x' + F_flow + F_stop            000 eq (4)
    q_PX = K w clip(x - x_lap, 0, l_p) rsqrt(p_s - p_x); q_XT = K w clip(x_lap - x, 0, l_p) rsqrt(p_x - p_T)
    V_x(y)/beta p_x' = q_PX - q_XT - A1 y' - G_x (p_x - p_T)
    m_y y'' = A1 p_x - A2 p_s - F_b0 - k_b y - b_y y' + F_stop(y)        (control pistons)
    V_s/beta p_s' = eps(y) D w_p - G_p (p_s - p_T) + A2 y' - q_PX - A x' - q_CV - q_RV
    q_CV = C_d a_CV sqrt(2/rho) max(rsqrt(p_s - p_l), 0)                  (meter-in CV + load check)
    V_l(xa)/beta p_l' = q_CV - A_c va - q_ls
    M va' = A_c (p_l - p_T) - F_L - b_a va - F_c tanh(va/v_eps) + F_stop(xa)
    L q_ls' + (R(T) + R_d) q_ls = p_l - p_ls                                000 eq (5) + damping restrictor
    (V_line + V_sc - A x)/beta p_ls' = q_ls + A x'                          000 eq (6)
    tau f_sol' = u0 - f_sol

with ``eps(y) = clip(1 - y/y_max, 0, 1)``; the steady margin is
``p_s - p_ls = (F0 + k x_lap + f_sol)/A`` (20 bar at f_sol = 0). Every number not in 000 is
an assumption stated in the field's ``source`` (pump and valve sizes of a 28 cm^3/rev
LS pump, a 63 mm cylinder, hoses).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.friction import tanh_sign
from hydro_envs.laws.orifice import regularized_signed_sqrt
from hydro_envs.plants.load_sensing.params import (  # noqa: F401  (re-exported)
    D_A, D_C, D_KFF, D_KM, D_LLS, D_RLS, D_VLINE, I_A1, I_A2, I_AC, I_ACVMAX, I_ASS, I_BA,
    I_BETA, I_BY, I_C40, I_CD, I_DLS, I_DP, I_DPTR, I_DS, I_F0, I_FB0, I_FCA, I_FL, I_FSMAX,
    I_GP, I_GRV, I_GX, I_K, I_KAS, I_KB, I_KSS, I_KYS, I_LLS, I_LPORT, I_M, I_MS, I_MY,
    I_PFLOOR, I_PRV, I_PT, I_RD, I_RHO, I_STROKE, I_T, I_THETA, I_TSOL, I_VEPS, I_VG, I_VL0,
    I_VS, I_VSC, I_VX0, I_W, I_WP, I_XLAP, I_XMAX, I_YMAX, LoadSensingParams, N_FIELDS, N_PARAMS,
    PLANT, _ATM, _BAR, _DERIVED, derived,
)
from hydro_envs.sim.rk4 import rk4_advance
from hydro_envs.sim.stiffness import substeps_from_stiffness

__all__ = [
    "LoadSensingParams",
    "STATE_NAMES",
    "N_STATES",
    "load_sensing_rhs",
    "load_sensing_guard",
    "stiffness_modes",
    "derived",
    "margin",
    "standby_state",
    "settled_standby_state",
    "cv_area_for_velocity",
]

STATE_NAMES = ("x", "v", "p_s", "p_x", "y", "vy", "p_l", "xa", "va", "q_ls", "p_ls", "f_sol")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "m", "m/s", "Pa", "m", "m/s", "m^3/s", "Pa", "N")
N_STATES = 12
X, V, PS, PX, Y, VY, PL, XA, VA, QLS, PLS, FSOL = range(N_STATES)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {"p_s": PS, "p_l": PL, "p_ls": PLS, "xa": XA, "va": VA}
DERIVATIVE_OUTPUTS: dict[str, int] = {}
#: channels a grey-box fit uses by default
FIT_OUTPUTS = ("p_s", "p_l", "p_ls", "xa", "va")
#: standby settling before a record starts [s]: CV closed, no solenoid force (the
#: LoadSensing-v0 reset; the circuit is then near, not at, rest: the FC spool still moves)
STANDBY_SETTLE_TIME = 0.1
#: sub-interval of the settling integration [s] (the env's control period; the RK4 sub-steps
#: per sub-interval follow from :func:`stiffness_modes`)
STANDBY_SETTLE_STEP = 1e-3


@nb.njit(cache=True, error_model="numpy")
def load_sensing_rhs(y, u, p, dy):
    """Time derivative of the LS circuit state (module docstring equations)."""
    x = y[X]
    v = y[V]
    ps = y[PS]
    px = y[PX]
    yc = y[Y]
    vy = y[VY]
    pl = y[PL]
    xa = y[XA]
    va = y[VA]
    qls = y[QLS]
    pls = y[PLS]
    fsol = y[FSOL]
    beta = p[I_BETA]
    pt = p[I_PT]
    dptr = p[I_DPTR]
    floor = p[I_PFLOOR]
    area = p[D_A]
    km = p[D_KM]

    # ---- flow compensator metering (P -> X, X -> T) and flow force
    lport = p[I_LPORT]
    o_px = min(max(x - p[I_XLAP], 0.0), lport)
    o_xt = min(max(p[I_XLAP] - x, 0.0), lport)
    q_px = km * p[I_W] * o_px * regularized_signed_sqrt(ps - px, dptr)
    q_xt = km * p[I_W] * o_xt * regularized_signed_sqrt(px - pt, dptr)
    f_flow = p[D_KFF] * (-o_px * (ps - px) + o_xt * (px - pt))
    f_stop = end_stop_force(x, v, 0.0, p[I_XMAX], p[I_KSS], p[I_ASS])
    dy[X] = v
    dy[V] = (area * (ps - pls) - p[I_F0] - p[I_K] * x - fsol - p[D_C] * v + f_flow + f_stop) / p[I_MS]  # 000 (4)

    # ---- control pistons and swash plate
    vx = p[I_VX0] + p[I_A1] * yc
    dpx = beta / vx * (q_px - q_xt - p[I_A1] * vy - p[I_GX] * (px - pt))
    if px <= floor and dpx < 0.0:
        dpx = 0.0
    dy[PX] = dpx
    f_ystop = end_stop_force(yc, vy, 0.0, p[I_YMAX], p[I_KYS], 0.0)
    dy[Y] = vy
    dy[VY] = (p[I_A1] * px - p[I_A2] * ps - p[I_FB0] - p[I_KB] * yc - p[I_BY] * vy + f_ystop) / p[I_MY]

    # ---- pump delivery node
    eps = 1.0 - yc / p[I_YMAX]
    eps = min(max(eps, 0.0), 1.0)
    q_pump = eps * p[I_DP] * p[I_WP]
    a_cv = min(max(u[1], 0.0), p[I_ACVMAX])
    q_cv = km * a_cv * regularized_signed_sqrt(ps - pl, dptr)
    if q_cv < 0.0:
        q_cv = 0.0  # load-holding check valve
    q_rv = p[I_GRV] * max(ps - p[I_PRV], 0.0)
    dps = beta / p[I_VS] * (q_pump - p[I_GP] * (ps - pt) + p[I_A2] * vy - q_px - area * v - q_cv - q_rv)
    if ps <= floor and dps < 0.0:
        dps = 0.0
    dy[PS] = dps

    # ---- actuator and load
    vl = p[I_VL0] + p[I_AC] * xa
    dpl = beta / vl * (q_cv - p[I_AC] * va - qls)
    if pl <= floor and dpl < 0.0:
        dpl = 0.0
    dy[PL] = dpl
    f_fric = p[I_BA] * va + p[I_FCA] * tanh_sign(va, p[I_VEPS])
    f_astop = end_stop_force(xa, va, 0.0, p[I_STROKE], p[I_KAS], 0.0)
    dy[XA] = va
    dy[VA] = (p[I_AC] * (pl - pt) - p[I_FL] - f_fric + f_astop) / p[I_M]

    # ---- LS pilot line, 000 eqs (5)-(6)
    dy[QLS] = (pl - pls - (p[D_RLS] + p[I_RD]) * qls) / p[D_LLS]
    vls = p[D_VLINE] + p[I_VSC] - area * x
    dpls = beta / vls * (qls + area * v)
    if pls <= floor and dpls < 0.0:
        dpls = 0.0
    dy[PLS] = dpls

    # ---- solenoid
    dy[FSOL] = (u[0] - fsol) / p[I_TSOL]


@nb.njit(cache=True, error_model="numpy")
def load_sensing_guard(y, p):
    """Clamp the four pressures at the cavitation floor; return the number of clamps."""
    n = 0
    floor = p[I_PFLOOR]
    for i in (PS, PX, PL, PLS):
        if y[i] < floor:
            y[i] = floor
            n += 1
    return n


# ---------------------------------------------------------------------------- analysis
def margin(params: LoadSensingParams, f_sol: float = 0.0) -> float:
    """Steady LS margin ``p_s - p_ls = (F0 + k x_lap + f_sol)/A`` [Pa] (000 sec. 2: ~20 bar),
    neglecting the flow force of the tiny steady opening."""
    return (params.spring_preload + params.spring_stiffness * params.metering_lap + f_sol) / derived(params)["spool_area"]


def cv_area_for_velocity(params: LoadSensingParams, velocity: float, dp: float | None = None) -> float:
    """CV area that passes ``A_c * velocity`` at the drop ``dp`` (default: the nominal margin),
    the operator's lever of a load-sensing valve (orifice law)."""
    dp = margin(params) if dp is None else dp
    q = params.piston_area * max(velocity, 0.0)
    return min(q / (params.discharge_coefficient * math.sqrt(2.0 * dp / params.oil_density)), params.cv_area_max)


def standby_state(params: LoadSensingParams, xa: float) -> np.ndarray:
    """Approximate rest state with the CV closed: load held at ``F_L / A_c``, the LS line at the
    load pressure, delivery at load + margin, the pump destroked to its leakage flow."""
    p = params
    y = np.zeros(N_STATES)
    pl = p.tank_pressure + p.load_force / p.piston_area
    dpm = margin(p)
    ps = pl + dpm
    eps = min(max(p.pump_leakage * (ps - p.tank_pressure) / (p.pump_displacement * p.pump_speed), 0.0), 1.0)
    yc = (1.0 - eps) * p.control_stroke
    px = (p.control_area_small * ps + p.bias_spring_preload + p.bias_spring_stiffness * yc) / p.control_area_large
    # the FC stays open by the amount that feeds piston 1's leak (a fraction of a bar of margin)
    d = derived(p)
    for _ in range(3):
        q_leak = p.control_leakage * (px - p.tank_pressure)
        opening = q_leak / (d["k_meter"] * p.metering_width * math.sqrt(max(ps - px, 1e3)))
        ps = pl + (p.spring_preload + p.spring_stiffness * (p.metering_lap + opening)) / d["spool_area"]
        px = (p.control_area_small * ps + p.bias_spring_preload + p.bias_spring_stiffness * yc) / p.control_area_large
    y[X] = p.metering_lap + opening
    y[PS] = ps
    y[PX] = px
    y[Y] = yc
    y[PL] = pl
    y[XA] = xa
    y[PLS] = pl
    return y


def stiffness_modes(params: LoadSensingParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] (worst case over states).

    * ``spool``: FC spool on spring + flow-force stiffness at the relief pressure, plus c/m;
      ``spool_stop``: seat contact sqrt(k/m) + alpha F_max/m with F_max = A p_relief + k x_max.
    * ``control_chamber``: laminar slopes of the fully open FC port and the leak into V_x0;
      ``control_piston``: oil spring beta A1^2/V_x0 on m_y, plus b_y/m_y and the stop spring.
    * ``delivery``: laminar slopes of the open CV and FC port, leak and relief into V_s.
    * ``load``: laminar CV slope into V_l0, oil spring of the load, friction slope on M.
    * ``ls_line``: RLC line with the spool's displacement (eq (17)-type bound) + R/L.
    * ``solenoid``: 1/tau.
    """
    p = params
    d = derived(p)
    A, m = d["spool_area"], p.spool_mass
    beta = p.bulk_modulus
    g_lam = 1.0 / math.sqrt(p.orifice_transition_pressure)
    dp_max = p.relief_pressure
    k_spool = p.spring_stiffness + d["k_flow_force"] * dp_max
    f_max = A * dp_max + p.spring_stiffness * p.spool_stroke
    g_port = d["k_meter"] * p.metering_width * p.port_length * g_lam
    g_cv = d["k_meter"] * p.cv_area_max * g_lam
    c_ls_min = (d["ls_line_volume"] + p.spring_chamber_volume - A * p.spool_stroke) / beta
    omega_ls2 = 1.0 / (d["ls_inductance"] * c_ls_min) + A * A / (m * c_ls_min) + k_spool / m
    return {
        "spool": math.sqrt(k_spool / m) + d["viscous"] / m,
        "spool_stop": math.sqrt(p.spool_stop_stiffness / m) + p.spool_stop_damping * f_max / m,
        "control_chamber": beta / p.control_volume * (g_port + p.control_leakage),
        "control_piston": math.sqrt(beta * p.control_area_large**2 / (p.control_volume * p.control_mass)
                                    + p.control_stop_stiffness / p.control_mass)
        + p.control_damping / p.control_mass,
        "delivery": beta / p.delivery_volume * (g_cv + g_port + p.pump_leakage + p.relief_gradient)
        + math.sqrt(beta * p.control_area_small**2 / (p.delivery_volume * p.control_mass)),
        "load": beta / p.line_volume * g_cv
        + math.sqrt(beta * p.piston_area**2 / (p.line_volume * p.load_mass) + p.actuator_stop_stiffness / p.load_mass)
        + (p.actuator_coulomb / p.friction_sign_velocity + p.actuator_viscous) / p.load_mass,
        "ls_line": math.sqrt(omega_ls2) + (d["ls_resistance"] + p.ls_damping_resistance) / d["ls_inductance"],
        "solenoid": 1.0 / p.solenoid_time_constant,
    }


def settled_standby_state(params: LoadSensingParams, xa: float) -> np.ndarray:
    """:func:`standby_state` integrated for ``STANDBY_SETTLE_TIME`` with the CV closed and no
    solenoid force (RK4, sub-steps from :func:`stiffness_modes` per ``STANDBY_SETTLE_STEP``),
    then the actuator put back at ``xa`` at rest: the state a LoadSensing-v0 episode starts in."""
    n_int = int(round(STANDBY_SETTLE_TIME / STANDBY_SETTLE_STEP))
    nsub = substeps_from_stiffness(stiffness_modes(params), STANDBY_SETTLE_STEP)[0] * n_int
    y = standby_state(params, xa)
    _settle(y, np.zeros(2), params.to_array(), STANDBY_SETTLE_TIME / nsub, nsub, np.zeros((5, N_STATES)))
    y[XA] = xa
    y[VA] = 0.0
    return y


@nb.njit(cache=True, error_model="numpy")
def _settle(y, u, p, h, n_sub, work):
    """``n_sub`` RK4 steps of ``h`` under constant input ``u`` (the kernels' sub-step loop)."""
    return rk4_advance(load_sensing_rhs, load_sensing_guard, y, u, p, h, n_sub, work)


def rest_state_from_measurement(params: LoadSensingParams, first: dict) -> np.ndarray:
    """State at a record's first sample: :func:`settled_standby_state` at the measured
    actuator position ``xa`` (5 cm if not measured). The pump, FC and LS-line states are not
    measured, so the record must start from that standby (as LoadSensing-v0 episodes do)."""
    return settled_standby_state(params, first.get("xa", 0.05))
