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
    12     z      m       bristle (pre-sliding) deflection of the actuator's seals (LuGre state)

Inputs: ``u[0]`` solenoid force command [N] (first-order lag ``tau_sol``), ``u[1]`` CV
flow area [m^2] (clipped to ``[0, cv_area_max]``).

Equations::

    m x'' = A (p_s - p_ls) - F0 - k x - f_sol - c(T) x' + F_flow + F_stop            000 eq (4)
    q_PX = K w clip(x - x_lap, 0, l_p) rsqrt(p_s - p_x); q_XT = K w clip(x_lap - x, 0, l_p) rsqrt(p_x - p_T)
    V_x(y)/beta p_x' = q_PX - q_XT - A1 y' - G_x (p_x - p_T)
    m_y y'' = A1 p_x - A2 p_s - F_b0 - k_b y - b_y y' + F_stop(y)        (control pistons)
    V_s/beta p_s' = eps(y) D w_p - G_p (p_s - p_T) + A2 y' - q_PX - A x' - q_CV - q_RV
    q_RV = G_RV max(p_s - p_RV, 0)                                         (main relief, linear)
    q_CV = C_d a_CV sqrt(2/rho) max(rsqrt(p_s - p_l), 0)                  (meter-in CV + load check)
    V_l(xa)/beta p_l' = q_CV - A_c va - q_ls - q_PR(p_l - p_T)            (q_PR: port relief)
    M va' = A_c (p_l - p_T) - F_L - b_a va - F_s + F_stop(xa)
    F_s = sigma0 z + sigma1(va) z',  z' = va - sigma0 |va| z / F_c      (LuGre seals, level F_c)
    L q_ls' + (R(T) + R_d) q_ls = p_l - p_ls                                000 eq (5) + damping restrictor
    (V_line + V_sc - A x)/beta p_ls' = q_ls + A x'                          000 eq (6)
    tau f_sol' = u0 - f_sol

with ``eps(y) = clip(1 - y/y_max, 0, 1)`` and ``q_PR`` the load line's port (shock) relief
to tank (:func:`hydro_envs.laws.relief.pressure_relief_flow`, 000 Fig. 1 draws none: a load
falling back onto the closed line would otherwise compress it far above the main relief); the steady margin is
``p_s - p_ls = (F0 + k x_lap + f_sol)/A`` (20 bar at f_sol = 0). Every number not in 000 is
an assumption stated in the field's ``source`` (pump and valve sizes of a 28 cm^3/rev
LS pump, a 63 mm cylinder, hoses).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.seal_friction import seal_friction
from hydro_envs.laws.orifice import regularized_signed_sqrt, regularized_signed_sqrt_slope_bound
from hydro_envs.laws.relief import linear_relief_flow, pressure_relief_flow
from hydro_envs.plants.load_sensing import bounds as _bounds
from hydro_envs.plants.load_sensing.params import (  # noqa: F401  (re-exported)
    D_A, D_BETA_VS, D_C, D_DROPRATE, D_INV_LLS, D_INV_M, D_INV_MS, D_INV_MY, D_INV_TSOL, D_INV_YMAX, D_KFF, D_KM,
    D_LEAKRATE, D_LLS, D_LOCAL, D_RLS, D_VLINE, I_A1, I_A2, I_AC,
    I_ACVMAX, I_ASS, I_BA, I_BETA, I_BY, I_C40, I_CD, I_DLS, I_DP, I_DPTR, I_DS, I_F0, I_FB0, I_FCA, I_FL, I_FSMAX,
    I_GP, I_GRV, I_GX, I_K, I_KAS, I_KB, I_KSS, I_KYS, I_LLS, I_LPORT, I_M, I_MS, I_MY,
    I_PFLOOR, I_PRV, I_PT, I_RD, I_RHO, I_SIG0, I_SIG1, I_STROKE, I_T, I_THETA, I_TSOL, I_VG, I_VL0, I_ZCAP, D_FADE,
    I_VS, I_VSC, I_VX0, I_W, I_WP, I_XLAP, I_XMAX, I_YMAX, I_PRVL, I_POVL, I_QRVL, D_GRVL, LoadSensingParams, N_FIELDS, N_PARAMS,
    PLANT, _ATM, _BAR, _DERIVED, derived,
)
from hydro_envs.sim.rk4 import STABLE_H_LAMBDA, local_substeps, rk4_advance, worst_case_substeps
from hydro_envs.sim.stiffness import substeps_from_stiffness

__all__ = [
    "CONTRACT",
    "LoadSensingParams",
    "STATE_NAMES",
    "N_STATES",
    "load_sensing_rhs",
    "load_sensing_guard",
    "stiffness_modes",
    "local_mode_rates",
    "local_mode_rate",
    "local_mode_substeps",
    "local_mode_refinement",
    "derived",
    "margin",
    "standby_state",
    "settled_standby_state",
    "cv_area_for_velocity",
]

STATE_NAMES = ("x", "v", "p_s", "p_x", "y", "vy", "p_l", "xa", "va", "q_ls", "p_ls", "f_sol", "z")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "m", "m/s", "Pa", "m", "m/s", "m^3/s", "Pa", "N", "m")
N_STATES = 13
X, V, PS, PX, Y, VY, PL, XA, VA, QLS, PLS, FSOL, Z = range(N_STATES)

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


@njit_noalloc
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
    dy[V] = (area * (ps - pls) - p[I_F0] - p[I_K] * x - fsol - p[D_C] * v + f_flow + f_stop) * p[D_INV_MS]  # (4)

    # ---- control pistons and swash plate
    vx = p[I_VX0] + p[I_A1] * yc
    dpx = beta / vx * (q_px - q_xt - p[I_A1] * vy - p[I_GX] * (px - pt))
    if px <= floor and dpx < 0.0:
        dpx = 0.0
    dy[PX] = dpx
    f_ystop = end_stop_force(yc, vy, 0.0, p[I_YMAX], p[I_KYS], 0.0)
    dy[Y] = vy
    dy[VY] = (p[I_A1] * px - p[I_A2] * ps - p[I_FB0] - p[I_KB] * yc - p[I_BY] * vy + f_ystop) * p[D_INV_MY]

    # ---- pump delivery node
    eps = 1.0 - yc * p[D_INV_YMAX]
    eps = min(max(eps, 0.0), 1.0)
    q_pump = eps * p[I_DP] * p[I_WP]
    a_cv = min(max(u[1], 0.0), p[I_ACVMAX])
    q_cv = km * a_cv * regularized_signed_sqrt(ps - pl, dptr)
    if q_cv < 0.0:
        q_cv = 0.0  # load-holding check valve
    q_rv = linear_relief_flow(ps - pt, p[I_PRV] - pt, p[I_GRV])  # main relief to tank
    dps = p[D_BETA_VS] * (q_pump - p[I_GP] * (ps - pt) + p[I_A2] * vy - q_px - area * v - q_cv - q_rv)
    if ps <= floor and dps < 0.0:
        dps = 0.0
    dy[PS] = dps

    # ---- actuator and load
    vl = p[I_VL0] + p[I_AC] * xa
    q_pr = pressure_relief_flow(pl - pt, p[I_PRVL] - pt, p[I_POVL], p[I_QRVL])  # port relief to tank
    dpl = beta / vl * (q_cv - p[I_AC] * va - qls - q_pr)
    if pl <= floor and dpl < 0.0:
        dpl = 0.0
    dy[PL] = dpl
    f_fric, dz = seal_friction(va, y[Z], p[I_FCA], p[I_SIG0], p[I_SIG1], p[D_FADE], p[I_BA], 1, p[I_ZCAP])
    f_astop = end_stop_force(xa, va, 0.0, p[I_STROKE], p[I_KAS], 0.0)
    dy[XA] = va
    dy[VA] = (p[I_AC] * (pl - pt) - p[I_FL] - f_fric + f_astop) * p[D_INV_M]

    # ---- LS pilot line, 000 eqs (5)-(6)
    dy[QLS] = (pl - pls - (p[D_RLS] + p[I_RD]) * qls) * p[D_INV_LLS]
    vls = p[D_VLINE] + p[I_VSC] - area * x
    dpls = beta / vls * (qls + area * v)
    if pls <= floor and dpls < 0.0:
        dpls = 0.0
    dy[PLS] = dpls

    # ---- solenoid
    dy[FSOL] = (u[0] - fsol) * p[D_INV_TSOL]
    dy[Z] = dz


@njit_noalloc
def load_sensing_guard(y, p):
    """Clamp the four pressures at the cavitation floor; return the number of clamps."""
    n = 0
    floor = p[I_PFLOOR]
    for i in (PS, PX, PL, PLS):
        if y[i] < floor:
            y[i] = floor
            n += 1
    return n


# ------------------------------------------------------- local refinement (look-ahead kernels)


@nb.njit(cache=True, error_model="numpy", inline="always")
def _on_spool_stop(y, p):
    """Whether the FC spool at state ``y`` is in contact with its seat or its spring-side stop."""
    return y[X] < 0.0 or y[X] > p[I_XMAX]


@nb.njit(cache=True, error_model="numpy", inline="always")
def _drop_crossed(y0, y, p):
    """Whether the drop across an FC metering edge (P -> X, X -> T) or the CV changed sign
    between ``y0`` and ``y``: the orifice law is steepest at zero drop."""
    pt = p[I_PT]
    return ((y0[PS] - y0[PX]) * (y[PS] - y[PX]) < 0.0 or (y0[PX] - pt) * (y[PX] - pt) < 0.0
            or (y0[PS] - y0[PL]) * (y[PS] - y[PL]) < 0.0)


@nb.njit(cache=True, error_model="numpy", inline="always")
def _smallest_drop(y, p):
    """Smallest magnitude [Pa] of the drops across the FC metering edges and the CV at ``y``."""
    return min(abs(y[PS] - y[PX]), min(abs(y[PX] - p[I_PT]), abs(y[PS] - y[PL])))


@nb.njit(cache=True, error_model="numpy", inline="always")
def local_mode_rate(y, p):
    """Upper estimate [1/s] of the locally refined orifice modes at state ``y``
    (:func:`.bounds.local_mode_rates` with the drops and openings of ``y``): the FC metering
    edges and the leak into the control chamber, the CV (at full area: the input is not known
    here), the FC port, the pump leak and the relief into the delivery volume, the CV into the
    load line; the largest of the three."""
    beta = p[I_BETA]
    dptr = p[I_DPTR]
    ps = y[PS]
    px = y[PX]
    pl = y[PL]
    kw = p[D_KM] * p[I_W]
    g_px = (kw * min(max(y[X] - p[I_XLAP], 0.0), p[I_LPORT])
            * regularized_signed_sqrt_slope_bound(ps - px, dptr))
    g_xt = (kw * min(max(p[I_XLAP] - y[X], 0.0), p[I_LPORT])
            * regularized_signed_sqrt_slope_bound(px - p[I_PT], dptr))
    g_cv = p[D_KM] * p[I_ACVMAX] * regularized_signed_sqrt_slope_bound(ps - pl, dptr) if ps > pl else 0.0
    control = beta / max(p[I_VX0] + p[I_A1] * y[Y], p[I_VX0]) * (g_px + g_xt + p[I_GX])
    delivery = p[D_BETA_VS] * (g_cv + g_px + p[I_GP] + p[I_GRV])
    if pl > p[I_PRVL]:  # the port relief open: its steepest slope
        g_cv += p[D_GRVL]
    load = beta / max(p[I_VL0] + p[I_AC] * y[XA], 0.5 * p[I_VL0]) * g_cv
    return max(control, max(delivery, load))


@njit_noalloc
def local_mode_substeps(y0, x, p, h, m):
    """RK4 steps of ``h / n`` that take a sub-step of ``h`` from ``y0`` (Euler prediction of its
    end ``x``) stably in the locally refined modes (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`):
    ``m`` (the worst case, :func:`local_mode_refinement`) with the FC spool on a stop at either
    state or a drop across the FC port or the CV changing sign between them, else the count for
    the larger :func:`local_mode_rate` of the two (:func:`hydro_envs.sim.rk4.local_substeps`)."""
    if _on_spool_stop(y0, p) or _on_spool_stop(x, p) or _drop_crossed(y0, x, p):
        return m
    prvl = p[I_PRVL]
    if (y0[PL] - prvl) * (x[PL] - prvl) < 0.0 or (y0[PL] - prvl - p[I_POVL]) * (x[PL] - prvl - p[I_POVL]) < 0.0:
        return m  # the port relief's kinks (cracking, full opening)
    if max(y0[PL], x[PL]) <= prvl:  # the port relief closed (open: its rate, not the short cut's bound)
        # short cut, same answer: with every drop at least dp_min the rate is at most C / sqrt(dp_min)
        # + G (.bounds.orifice_rate_coefficients), stable if dp_min (stable / h - G)^2 >= C^2
        room = STABLE_H_LAMBDA / h - p[D_LEAKRATE]
        dp_min = min(_smallest_drop(y0, p), _smallest_drop(x, p))
        if room > 0.0 and dp_min * room * room >= p[D_DROPRATE] * p[D_DROPRATE]:
            return 1
    # the rates, written once: numba compiles every inlined copy apart
    return local_substeps(h * max(local_mode_rate(y0, p), local_mode_rate(x, p)), STABLE_H_LAMBDA, m)


@nb.njit(cache=True, error_model="numpy", inline="always")
def local_mode_refinement(p, h):
    """Fine sub-steps per sub-step of ``h`` seconds that keep the locally refined modes stable
    at their worst case (``D_LOCAL``, :func:`local_mode_rates`)."""
    return worst_case_substeps(h * p[D_LOCAL])


# ---------------------------------------------------------------------------- analysis
def relief_bounds(P: np.ndarray) -> tuple[tuple[int, ...], np.ndarray]:
    """``((PS, PX, PL, PLS), (n, 4) [Pa])``: the pressures the reliefs hold the chambers below,
    per row of the kernel parameter array ``P`` (the soak test, :mod:`hydro_envs.soak`): the
    delivery and the control chamber (fed from it) the main relief's at the pump's full flow,
    ``relief_pressure + D w_p / relief_gradient``; the load line and the LS line (fed from it) the
    port relief's full-flow pressure ``load_relief_pressure + load_relief_override``, or the main
    relief's if higher (the CV feeds the load line from the delivery). Inf without a relief."""
    with np.errstate(divide="ignore"):
        main = np.where(P[:, I_GRV] > 0.0, P[:, I_PRV] + P[:, I_DP] * P[:, I_WP] / P[:, I_GRV], np.inf)
    port = np.maximum(np.where(P[:, I_QRVL] > 0.0, P[:, I_PRVL] + P[:, I_POVL], np.inf), main)
    return (PS, PX, PL, PLS), np.stack([main, main, port, port], axis=1)


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
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of the modes that are stiff
    everywhere (:func:`.bounds.stiffness_modes`): they set the sub-step count. The modes stiff
    only locally (the FC spool on a stop, an orifice near zero drop) are left out and refined
    where they are stiff (:func:`local_mode_rates`, :func:`local_mode_substeps`)."""
    return _bounds.stiffness_modes(params, derived(params))


def local_mode_rates(params: LoadSensingParams) -> dict[str, float]:
    """Worst cases [1/s] of the locally refined modes (:func:`.bounds.local_mode_rates`); the
    largest is ``D_LOCAL`` of the kernel parameter array."""
    return _bounds.local_mode_rates(params, derived(params))


def settled_standby_state(params: LoadSensingParams, xa: float) -> np.ndarray:
    """:func:`standby_state` integrated for ``STANDBY_SETTLE_TIME`` with the CV closed and no
    solenoid force (RK4, uniform sub-steps per ``STANDBY_SETTLE_STEP`` from :func:`stiffness_modes`
    and the worst cases of :func:`local_mode_rates`),
    then the actuator put back at ``xa`` at rest: the state a LoadSensing-v0 episode starts in."""
    n_int = int(round(STANDBY_SETTLE_TIME / STANDBY_SETTLE_STEP))
    worst = {**stiffness_modes(params), **local_mode_rates(params)}
    nsub = substeps_from_stiffness(worst, STANDBY_SETTLE_STEP)[0] * n_int
    y = standby_state(params, xa)
    _settle(y, np.zeros(2), params.to_array(), STANDBY_SETTLE_TIME / nsub, nsub, np.zeros((5, N_STATES)))
    y[XA] = xa
    y[VA] = 0.0
    return y


@njit_noalloc
def _settle(y, u, p, h, n_sub, work):
    """``n_sub`` RK4 steps of ``h`` under constant input ``u`` (the kernels' sub-step loop)."""
    return rk4_advance(load_sensing_rhs, load_sensing_guard, y, u, p, h, n_sub, work)


def rest_state_from_measurement(params: LoadSensingParams, first: dict) -> np.ndarray:
    """State at a record's first sample: :func:`settled_standby_state` at the measured
    actuator position ``xa`` (5 cm if not measured). The pump, FC and LS-line states are not
    measured, so the record must start from that standby (as LoadSensing-v0 episodes do)."""
    return settled_standby_state(params, first.get("xa", 0.05))


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    fit_outputs=FIT_OUTPUTS, rest_state_from_measurement=rest_state_from_measurement, relief_bounds=relief_bounds,
)
