r"""Load-sensing pump flow compensator: pilot pipe + spool (seed 000).

Source: ``000_d7d5fd9bd6b165a2.txt`` -- "Experimental Methods for Measuring the Viscous
Friction Coefficient in Hydraulic Spool Valves": pipe RLC model eqs (1)-(3), (5)-(6), spool
eq (4), transfer functions eqs (11)-(17), numerical case Table 1, method 1 (sec. 3.3-3.4),
method 2 (sec. 4, eqs (18)-(19)), LVDT (sec. 5).

A spool of frontal area ``A`` (mass ``m`` = spool + seat + annular oil + 1/3 of the spring,
sec. 3.1/3.4) is pushed by the pressure ``p2`` of its pilot chamber against a spring (``k``,
preload ``F0``) whose chamber is at ``p_s`` (atmosphere in both methods) and is braked by
viscous friction ``c``. The pilot chamber is fed through a pipe from the inlet pressure
``p1`` (the rig's boundary: servovalve junction in method 1, gear-pump delivery in method 2).
Optionally the spool meters the inlet P to an outlet port X (method 2: ``P -> X``, and
``X -> T`` on the other side of the land), and X drains through a calibrated orifice.

State (SI, pressures absolute). The width depends on the number of pipe segments ``N``
(:func:`n_states`): ``5`` for ``N = 0`` and ``4 + 2 N`` otherwise (``N_STATES = 28`` holds
the 12-segment line of 000 sec. 3.4)::

    index        name    unit     meaning
    0            x       m        spool travel from its seat, towards the spring
    1            v       m/s      spool velocity
    2            p2      Pa       pilot-chamber pressure (end of the pipe)        (6)
    3            p_out   Pa       outlet port X pressure (method 2: p_I)
    4            tau     s        time since the rig last updated its input
    5 + 2(j-1)   q<j>    m^3/s    flow in pipe segment j = 1..N (towards the spool) (5)
    6 + 2(j-1)   pn<j>   Pa       pressure at the joint after segment j = 1..N-1

Input ``u`` (first-order hold of the rig's boundary pressure)::

    u[0]  p1 at the last update [Pa abs];  u[1]  its rate until the next update [Pa/s]
    p1(t) = u[0] + u[1] * tau

A rig sets ``tau = 0`` and ``u`` every sample, so RK4 sees the exact piecewise-linear
boundary signal (``u[1] = 0`` is a zero-order hold).

Equations (numbers of 000)::

    m x'' + c x' + k x + F0 = A (p2 - p_s) + F_flow + F_stop              (4)
    L_j q_j' + R_j q_j = p_{j-1} - p_j          p_0 = p1, p_N = p2          (5), (1), (2)
    C_j pn_j' = q_j - q_{j+1}                                               (6), (3)
    C_N(x) p2' = q_N - A x' - q_PX                                          (6)
    V_X / beta p_out' = q_PX - q_XT - q_orifice                             (method 2)

with ``L = rho l / a``, ``R = 128 mu l / (pi d^4)`` (eq (2)'s ``L`` is the length ``l``:
extraction defect), ``mu = rho nu(T)``, ``C = V / beta``. Lumped model (``N = 1``, the
paper's eqs (5)-(6)): all of the pipe volume, the pilot chamber and the spool displacement
volume sit at the spool, ``C_1 = (V_pipe + V_ch + A x) / beta``. Distributed model (``N >= 2``,
000 sec. 3.4 uses 12 internal nodes): pi sections, each joint carries ``V_pipe / N``, the
spool end ``V_pipe / (2N) + V_ch + A x``. ``N = 0``: no pipe, ``p2 = p1`` (method 2: sensors
"as close as possible to the component").

Viscous coefficient (000 sec. 3.4, Fig. 14: "c proportional to the viscosity")::

    c(T) = (c_40 + c_LVDT,40) * nu(T) / nu(40 C)      nu: ISO VG law, laws.viscosity

so c = 3.5 N s/m at 40 C, 5.75 at 30 C, 9.05 at 22 C for ISO VG 46 (paper: 3-4, 5-6, 7-9).
The pipe resistance R scales with nu(T) as well.

Method-2 metering (3-way land, critically lapped at ``x_lap``, rectangular ports of width
``w`` saturating after ``port_length``)::

    q_PX = C_d w clip(x - x_lap, 0, l_port) sqrt(2/rho) rsqrt(p2 - p_out)
    q_XT = C_d w clip(x_lap - x, 0, l_port) sqrt(2/rho) rsqrt(p_out - p_T)
    q_orifice = C_o (pi d_o^2 / 4) sqrt(2/rho) rsqrt(p_out - p_T)
    F_flow = 2 C_d cos(theta) w [ -open_PX (p2 - p_out) + open_XT (p_out - p_T) ]

(``rsqrt`` the regularised signed root of :mod:`hydro_envs.laws.orifice`; steady flow
force with jet angle ``theta = 69 deg``, always closing the open edge).

Decisions on the extracted text (``docs/references.md`` and below), each tested in
``tests/test_ls_compensator.py``:

* eq (2) ``128 mu L / (pi d^4)``: ``L`` is the pipe length.
* eq (17) is printed ``omega = sqrt(S/2) -+ sqrt(S^2/4 - a0)`` (S = omega_h^2 + omega_m^2 +
  A^2/(mC)), which is dimensionally inconsistent; the outer root spans both terms:
  ``omega_{1,2}^2 = S/2 -+ sqrt(S^2/4 - a0)`` -- the undamped eigenfrequencies, and the form
  that gives Table 1's 67 and 733 Hz.
* Table 1 gives combined quantities only. The physical defaults are backed out: the pipe
  bore and length from L and R with ISO VG 46 at 40 C (L/R = d^2/(32 nu)) and an assumed oil
  density; m and k from omega_m, xi_m and c = 3.5 N s/m (sec. 4); A from a2 (it comes out
  as a 7.00 mm spool); beta from C with an assumed 1 cm^3 pilot-chamber dead volume. C is
  evaluated at the method-1 operating point (p1 = 6 bar gauge mean, sec. 3.3; the spool then
  sits 2.45 mm off its seat and adds A x to the volume).
* The spring of method 1 was "deliberately reduced" (sec. 3.2); the original spring of
  method 2 follows from eq (19) (294 Hz with the same moving mass): 69.8 kN/m. The LVDT's
  moving mass follows from its 237 Hz (sec. 5): 11.0 g; its friction doubles c (3.5 -> 7).

Guards: pressures never integrate below a cavitation floor (derivative clipped at the
floor, state clamped after each sub-step), the spool travel is limited by continuous
Hunt-Crossley stops at its seat (x = 0) and at ``spool_stroke``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import njit_noalloc
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.orifice import regularized_signed_sqrt
from hydro_envs.plants.ls_compensator.params import (  # noqa: F401  (re-exported)
    D_A, D_C, D_KFF, D_KM, D_KO, D_L, D_M, D_R, D_VPIPE, I_ASTOP, I_BETA, I_C40, I_CD, I_CDO,
    I_CLVDT, I_DO, I_DP, I_DPTR, I_DS, I_F0, I_K, I_KSTOP, I_LP, I_LPORT, I_MLVDT, I_MS, I_MSPR,
    I_NSEG, I_PFLOOR, I_PMAX, I_PSPR, I_PT, I_RHO, I_STROKE, I_T, I_THETA, I_VCH, I_VG, I_VO,
    I_W, I_XLAP, LSCompensatorParams, LVDT_FRICTION_40C, LVDT_MASS, METHOD1_MEAN_GAUGE,
    N_FIELDS, N_PARAMS, N_SEG_MAX, ORIGINAL_SPRING_STIFFNESS, PLANT, TABLE_1, _ATM, _BAR,
    _DERIVED, derived,
)

__all__ = [
    "CONTRACT",
    "LSCompensatorParams",
    "STATE_NAMES",
    "N_STATES",
    "n_states",
    "ls_compensator_rhs",
    "ls_compensator_guard",
    "stiffness_modes",
    "derived",
    "operating_point",
    "lumped_coefficients",
    "f1_lumped",
    "f2_lumped",
    "f2_line",
    "linearize",
    "f2_state_space",
    "mechanical_resonance_hz",
    "method2_configuration",
    "lvdt_configuration",
    "TABLE_1",
]

STATE_NAMES = ("x", "v", "p2", "p_out", "tau") + tuple(
    name for j in range(1, N_SEG_MAX + 1) for name in ((f"q{j}", f"pn{j}") if j < N_SEG_MAX else (f"q{j}",))
)
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "s") + tuple(
    u for j in range(1, N_SEG_MAX + 1) for u in (("m^3/s", "Pa") if j < N_SEG_MAX else ("m^3/s",))
)
N_STATES = len(STATE_NAMES)  # 28
X, V, P2, PO, TAU = range(5)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {"x": X, "p2": P2, "p_out": PO}
DERIVATIVE_OUTPUTS: dict[str, int] = {}
Q0 = 5  # index of q1; q_j at Q0 + 2 (j - 1), pn_j at Q0 + 2 (j - 1) + 1
assert N_STATES == 4 + 2 * N_SEG_MAX


def n_states(params: LSCompensatorParams) -> int:
    """State width needed for ``params.pipe_segments`` (5 for no pipe, 4 + 2N otherwise)."""
    n = int(params.pipe_segments)
    return 5 if n == 0 else 4 + 2 * n


@njit_noalloc
def ls_compensator_rhs(y, u, p, dy):
    """Time derivative ``dy`` of ``y`` under the boundary ``p1 = u[0] + u[1] tau`` (000 eqs (4)-(6))."""
    ny = y.shape[0]
    for j in range(ny):
        dy[j] = 0.0
    x = y[X]
    v = y[V]
    po = y[PO]
    p1 = u[0] + u[1] * y[TAU]
    dy[TAU] = 1.0
    beta = p[I_BETA]
    area = p[I_DS] * p[I_DS] * (0.25 * math.pi)
    floor = p[I_PFLOOR]
    dptr = p[I_DPTR]
    nseg = int(p[I_NSEG])

    # ---- metering P -> X, X -> T and the calibrated orifice X -> T (method 2)
    if nseg == 0:
        pc = p1  # no pipe: the spool sees the inlet pressure directly
    else:
        pc = y[P2]
    q_px = 0.0
    f_flow = 0.0
    if p[I_W] > 0.0:
        lport = p[I_LPORT]
        o_px = min(max(x - p[I_XLAP], 0.0), lport)
        o_xt = min(max(p[I_XLAP] - x, 0.0), lport)
        km = p[D_KM]
        q_px = km * p[I_W] * o_px * regularized_signed_sqrt(pc - po, dptr)
        q_xt = km * p[I_W] * o_xt * regularized_signed_sqrt(po - p[I_PT], dptr)
        # steady flow force closes the open edge (jet angle theta)
        f_flow = p[D_KFF] * (-o_px * (pc - po) + o_xt * (po - p[I_PT]))
        q_o = p[D_KO] * regularized_signed_sqrt(po - p[I_PT], dptr)
        dpo = beta / p[I_VO] * (q_px - q_xt - q_o)
        if po <= floor and dpo < 0.0:
            dpo = 0.0
        dy[PO] = dpo
    # (ports closed, method 1: the outlet is plugged and p_out keeps its value, dy = 0)

    # ---- pipe: N RLC segments (5) with joint capacitances (6)
    if nseg == 0:
        dy[P2] = u[1]  # p2 follows p1 exactly
    else:
        ls = p[D_L] / nseg
        rs = p[D_R] / nseg
        vseg = p[D_VPIPE] / nseg
        p_up = p1
        for j in range(nseg):
            iq = Q0 + 2 * j
            if j < nseg - 1:
                p_dn = y[iq + 1]
            else:
                p_dn = pc
            dy[iq] = (p_up - p_dn - rs * y[iq]) / ls  # (5)
            if j < nseg - 1:
                dpn = beta / vseg * (y[iq] - y[iq + 2])  # (6), joint j+1
                if p_dn <= floor and dpn < 0.0:
                    dpn = 0.0
                dy[iq + 1] = dpn
            p_up = p_dn
        if nseg == 1:
            v_end = p[D_VPIPE] + p[I_VCH] + area * x  # lumped: all of C at the spool (6)
        else:
            v_end = 0.5 * vseg + p[I_VCH] + area * x
        q_end = y[Q0 + 2 * (nseg - 1)]
        dp2 = beta / v_end * (q_end - area * v - q_px)  # (6)
        if pc <= floor and dp2 < 0.0:
            dp2 = 0.0
        dy[P2] = dp2

    # ---- spool (4)
    f_stop = end_stop_force(x, v, 0.0, p[I_STROKE], p[I_KSTOP], p[I_ASTOP])
    force = (
        area * (pc - p[I_PSPR])
        - p[I_F0]
        - p[I_K] * x
        - p[D_C] * v
        + f_flow
        + f_stop
    )
    dy[X] = v
    dy[V] = force / p[D_M]


@njit_noalloc
def ls_compensator_guard(y, p):
    """Clamp pressures at the cavitation floor after a sub-step; return the number of clamps."""
    n = 0
    floor = p[I_PFLOOR]
    if y[P2] < floor:
        y[P2] = floor
        n += 1
    if y[PO] < floor:
        y[PO] = floor
        n += 1
    nseg = int(p[I_NSEG])
    for j in range(nseg - 1):
        i = Q0 + 2 * j + 1
        if y[i] < floor:
            y[i] = floor
            n += 1
    return n


# ---------------------------------------------------------------------------- analysis
def operating_point(params: LSCompensatorParams, p_inlet: float) -> float:
    """Static spool travel [m] at inlet pressure ``p_inlet`` [Pa abs], ports closed, no stops.

    From eq (4) at rest: ``k x + F0 = A (p - p_s)``. Clipped to the travel [0, stroke].
    """
    d = derived(params)
    x = (d["area"] * (p_inlet - params.spring_chamber_pressure) - params.spring_preload) / params.spring_stiffness
    return float(min(max(x, 0.0), params.spool_stroke))


def _capacitance(params: LSCompensatorParams, x: float) -> float:
    d = derived(params)
    return (d["pipe_volume"] + params.chamber_volume + d["area"] * x) / params.bulk_modulus


def lumped_coefficients(params: LSCompensatorParams, p_mean_gauge: float = METHOD1_MEAN_GAUGE) -> dict[str, float]:
    """Table-1 quantities of the lumped model at the operating point ``p_mean_gauge`` [Pa gauge].

    eqs (1)-(3) L, R, C; (7)-(10) omega_m, xi_m, omega_h, xi_h [rad/s, -]; (13)-(16) a3..a0;
    (17) omega_1, omega_2 [rad/s] (outer root over both terms, see module docstring). Also
    ``A2_mC`` = A^2/(mC) and the mean spool travel ``x_mean``.
    """
    d = derived(params)
    x_mean = operating_point(params, params.spring_chamber_pressure + p_mean_gauge)
    L, R, C = d["inductance"], d["resistance"], _capacitance(params, x_mean)
    m, c, k, A = d["mass"], d["viscous"], params.spring_stiffness, d["area"]
    wm = math.sqrt(k / m)  # (7)
    xm = c / (2.0 * math.sqrt(m * k))  # (8)
    wh = math.sqrt(1.0 / (L * C))  # (9)
    xh = 0.5 * R * math.sqrt(C / L)  # (10)
    g = A * A / (m * C)
    a3 = 2.0 * (xm * wm + xh * wh)  # (13)
    a2 = wm**2 + wh**2 + 4.0 * xm * xh * wm * wh + g  # (14)
    a1 = 2.0 * (xh * wh * wm**2 + xm * wm * wh**2 + xh * wh * g)  # (15)
    a0 = wm**2 * wh**2  # (16)
    s = wh**2 + wm**2 + g
    disc = math.sqrt(0.25 * s * s - a0)
    w1 = math.sqrt(0.5 * s - disc)  # (17), corrected form
    w2 = math.sqrt(0.5 * s + disc)
    return {
        "L": L, "R": R, "C": C, "a0": a0, "a1": a1, "a2": a2, "a3": a3,
        "omega_m": wm, "xi_m": xm, "omega_h": wh, "xi_h": xh, "omega_1": w1, "omega_2": w2,
        "A2_mC": g, "x_mean": x_mean,
    }


def f1_lumped(params: LSCompensatorParams, s: np.ndarray, p_mean_gauge: float = METHOD1_MEAN_GAUGE) -> np.ndarray:
    """``F1(s) = x / p2`` [m/Pa], 000 eq (11)."""
    co = lumped_coefficients(params, p_mean_gauge)
    d = derived(params)
    s = np.asarray(s, dtype=complex)
    wm, xm = co["omega_m"], co["xi_m"]
    return (d["area"] / d["mass"]) / (s * s + 2.0 * xm * wm * s + wm * wm)


def f2_lumped(params: LSCompensatorParams, s: np.ndarray, p_mean_gauge: float = METHOD1_MEAN_GAUGE) -> np.ndarray:
    """``F2(s) = p2 / p1``, 000 eq (12) with the coefficients of eqs (13)-(16)."""
    co = lumped_coefficients(params, p_mean_gauge)
    s = np.asarray(s, dtype=complex)
    wm, xm, wh = co["omega_m"], co["xi_m"], co["omega_h"]
    num = wh * wh * (s * s + 2.0 * xm * wm * s + wm * wm)
    den = s**4 + co["a3"] * s**3 + co["a2"] * s**2 + co["a1"] * s + co["a0"]
    return num / den


def f2_line(params: LSCompensatorParams, s: np.ndarray, p_mean_gauge: float = METHOD1_MEAN_GAUGE) -> np.ndarray:
    """Exact ``p2 / p1`` with the pipe as a distributed line (laminar friction) and the pilot
    chamber + spool as its load: the limit of ``pipe_segments -> infinity``."""
    from hydro_envs.laws.pipe import line_transfer_function

    d = derived(params)
    x_mean = operating_point(params, params.spring_chamber_pressure + p_mean_gauge)
    s = np.asarray(s, dtype=complex)
    m, c, k, A = d["mass"], d["viscous"], params.spring_stiffness, d["area"]
    c_ch = (params.chamber_volume + A * x_mean) / params.bulk_modulus
    y_load = s * c_ch + A * A * s / (m * s * s + c * s + k)
    return line_transfer_function(s, d["inductance"], d["resistance"], d["pipe_volume"] / params.bulk_modulus, y_load)


def linearize(params: LSCompensatorParams, p_inlet: float, *, rel_step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Numerical linearisation of :func:`ls_compensator_rhs` about the static equilibrium at
    inlet pressure ``p_inlet`` [Pa abs] (ports as parametrised, orifice included).

    Returns ``(A, B)`` over the states ``[x, v, p2, p_out, q1, pn1, ...]`` (tau dropped) and the
    input p1. Central differences with steps scaled to each state's magnitude.
    """
    ny = n_states(params)
    y0 = equilibrium_state(params, p_inlet)
    pa = params.to_array()
    keep = [i for i in range(ny) if i != TAU]
    scale = np.array([1e-6, 1e-4, 1e3, 1e3, 1.0] + [1e-6, 1e3] * N_SEG_MAX)[:ny]
    u0 = np.array([p_inlet, 0.0])
    f = np.empty(ny)

    def rhs(y, u):
        ls_compensator_rhs(np.ascontiguousarray(y), np.ascontiguousarray(u), pa, f)
        return f[keep].copy()

    A = np.empty((len(keep), len(keep)))
    for col, i in enumerate(keep):
        h = scale[i] * rel_step * 1e3
        yp, ym = y0.copy(), y0.copy()
        yp[i] += h
        ym[i] -= h
        A[:, col] = (rhs(yp, u0) - rhs(ym, u0)) / (2 * h)
    h = 1e3 * rel_step * 1e3
    B = (rhs(y0, u0 + [h, 0.0]) - rhs(y0, u0 - [h, 0.0])) / (2 * h)
    return A, B


def f2_state_space(params: LSCompensatorParams, s: np.ndarray, p_inlet: float) -> np.ndarray:
    """``p2 / p1`` of the linearised kernel right-hand side (any number of pipe segments)."""
    A, B = linearize(params, p_inlet)
    n = A.shape[0]
    out = np.empty(len(np.atleast_1d(s)), dtype=complex)
    for i, si in enumerate(np.atleast_1d(s)):
        out[i] = np.linalg.solve(si * np.eye(n) - A, B)[P2]
    return out


def equilibrium_state(params: LSCompensatorParams, p_inlet: float, p_out: float | None = None) -> np.ndarray:
    """Rest state at constant inlet pressure ``p_inlet`` [Pa abs] with the ports closed
    (method 1): spool at its static travel, every pipe pressure at ``p_inlet``, no flow.

    With metering ports (``metering_width > 0``) the outlet pressure and the spool travel
    solve the steady flow balance (see :func:`steady_metering_state`).
    """
    ny = n_states(params)
    y = np.zeros(ny)
    if params.metering_width > 0.0:
        x, po = steady_metering_state(params, p_inlet)
    else:
        x = operating_point(params, p_inlet)
        po = params.tank_pressure if p_out is None else p_out
    y[X] = x
    y[P2] = p_inlet
    y[PO] = po
    nseg = int(params.pipe_segments)
    for j in range(nseg - 1):
        y[Q0 + 2 * j + 1] = p_inlet
    return y


def steady_metering_state(params: LSCompensatorParams, p_inlet: float) -> tuple[float, float]:
    """Steady spool travel and outlet pressure with metering (method 2), by bisection on x.

    Force balance ``A (p - p_s) - F0 - k x + F_flow(x, p_out) = 0`` with ``p_out`` from the
    flow balance ``q_PX(x, p, p_out) = q_XT + q_orifice(p_out)``.
    """
    from scipy.optimize import brentq

    d = derived(params)
    km, ko, w = d["k_meter"], d["k_orifice"], params.metering_width
    pt, dptr = params.tank_pressure, params.orifice_transition_pressure

    def rs(dp):
        return dp / math.sqrt(math.sqrt(dp * dp + dptr * dptr)) if dp != 0.0 else 0.0

    def p_out_of(x):
        o_px = min(max(x - params.metering_lap, 0.0), params.port_length)
        o_xt = min(max(params.metering_lap - x, 0.0), params.port_length)

        def bal(po):
            return km * w * o_px * rs(p_inlet - po) - km * w * o_xt * rs(po - pt) - ko * rs(po - pt)

        if bal(pt) <= 0.0:
            return pt
        return brentq(bal, pt, p_inlet, xtol=1e-9, rtol=1e-14)

    def force(x):
        po = p_out_of(x)
        o_px = min(max(x - params.metering_lap, 0.0), params.port_length)
        o_xt = min(max(params.metering_lap - x, 0.0), params.port_length)
        f_flow = d["k_flow_force"] * (-o_px * (p_inlet - po) + o_xt * (po - pt))
        return d["area"] * (p_inlet - params.spring_chamber_pressure) - params.spring_preload - params.spring_stiffness * x + f_flow

    lo, hi = 0.0, params.spool_stroke
    if force(lo) <= 0.0:
        return lo, p_out_of(lo)
    if force(hi) >= 0.0:
        return hi, p_out_of(hi)
    x = brentq(force, lo, hi, xtol=1e-13, rtol=1e-14)
    return x, p_out_of(x)


def mechanical_resonance_hz(params: LSCompensatorParams) -> float:
    """``omega_n = sqrt(k_tot / m_tot) / (2 pi)`` [Hz], 000 eq (19)."""
    return math.sqrt(params.spring_stiffness / derived(params)["mass"]) / (2.0 * math.pi)


def method2_configuration(params: LSCompensatorParams | None = None, *, lvdt: bool = False, **overrides) -> LSCompensatorParams:
    """The compensator as tested in method 2 (000 sec. 4): original spring, no pilot pipe,
    P -> X metering through 2 mm of port width, outlet through the calibrated orifice.

    ``lvdt=True`` adds the LVDT's moving mass and friction (000 sec. 5). The spring preload
    (the pressure setting) is chosen by the rig. ``overrides`` replace further fields.
    """
    base = params if params is not None else LSCompensatorParams()
    values = dict(
        spring_stiffness=ORIGINAL_SPRING_STIFFNESS,
        pipe_segments=0.0,
        metering_width=2.0e-3,
    )
    if lvdt:
        values.update(lvdt_mass=LVDT_MASS, lvdt_friction_40c=LVDT_FRICTION_40C)
    values.update(overrides)
    return dataclasses.replace(base, **values)


def lvdt_configuration(params: LSCompensatorParams | None = None) -> LSCompensatorParams:
    """Method-2 configuration with the LVDT fitted (000 sec. 5, Fig. 23-24)."""
    return method2_configuration(params, lvdt=True)


def stiffness_modes(params: LSCompensatorParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of every fast mode.

    * ``pipe_spool``: largest eigenvalue magnitude of the linear pipe + chamber + spool system
      (exact eigenvalues of its matrix) at the smallest end volume (spool on its seat), with the
      flow-force stiffness at the pressure ceiling added to the spring.
    * ``stop``: seat contact ``sqrt(k_stop/m)`` plus the Hunt-Crossley damping
      ``alpha F_max / m`` with ``F_max = A p_max + k x_max``.
    * ``outlet``: laminar slopes (at zero drop) of the fully open metering port and the
      calibrated orifice into the outlet volume, ``beta / V_X * sum(K a / sqrt(dp_tr))`` (only
      with metering ports; with the ports closed, method 1, the outlet is plugged and frozen).
    """
    d = derived(params)
    m, c, A = d["mass"], d["viscous"], d["area"]
    k_eff = params.spring_stiffness + d["k_flow_force"] * params.max_pressure
    nseg = int(params.pipe_segments)
    beta = params.bulk_modulus
    if nseg == 0:
        mat = np.array([[0.0, 1.0], [-k_eff / m, -c / m]])
    else:
        # states [x, v, q1, pn1, ..., q_N, p2]
        n = 2 + 2 * nseg
        mat = np.zeros((n, n))
        ls, rs = d["inductance"] / nseg, d["resistance"] / nseg
        vseg = d["pipe_volume"] / nseg
        v_end = (d["pipe_volume"] if nseg == 1 else 0.5 * vseg) + params.chamber_volume
        mat[0, 1] = 1.0
        mat[1, 1] = -c / m
        mat[1, 0] = -k_eff / m
        mat[1, n - 1] = A / m
        for j in range(nseg):
            iq = 2 + 2 * j
            ip_dn = iq + 1  # joint j+1, or p2 for the last segment (index n - 1)
            mat[iq, iq] = -rs / ls
            mat[iq, ip_dn] = -1.0 / ls
            if j > 0:
                mat[iq, iq - 1] = 1.0 / ls
            if j < nseg - 1:
                mat[ip_dn, iq] = beta / vseg
                mat[ip_dn, iq + 2] = -beta / vseg
        mat[n - 1, n - 2] = beta / v_end
        mat[n - 1, 1] = -beta / v_end * A
    lam_lin = float(np.max(np.abs(np.linalg.eigvals(mat))))
    f_max = A * params.max_pressure + params.spring_stiffness * params.spool_stroke
    g_lam = 1.0 / math.sqrt(params.orifice_transition_pressure)
    modes = {
        "pipe_spool": lam_lin,
        "stop": math.sqrt(params.stop_stiffness / m) + params.stop_damping * f_max / m,
    }
    if params.metering_width > 0.0:
        # one metering edge open at a time (P -> X or X -> T), plus the calibrated orifice
        g_out = (d["k_meter"] * params.metering_width * params.port_length + d["k_orifice"]) * g_lam
        modes["outlet"] = beta / params.outlet_volume * g_out
    return modes


def rest_state(params: LSCompensatorParams, p_inlet: float = _ATM + METHOD1_MEAN_GAUGE) -> np.ndarray:
    """:func:`equilibrium_state` at inlet pressure ``p_inlet`` [Pa abs], by default method 1's
    mean pressure (:data:`METHOD1_MEAN_GAUGE` above the atmosphere): the contract's rest."""
    return equilibrium_state(params, p_inlet)


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    n_states_for=n_states, rest_state=rest_state,
)
