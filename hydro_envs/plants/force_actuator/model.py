r"""High-bandwidth force actuator: jet-pipe valve on the piston, U-shaped force sensor (seed 001).

Source: ``001_3253c61f41166c3e.txt`` -- "System Identification and Modelling of a High
Performance Hydraulic Actuator" (ASI actuator): block diagram fig. 2 (hysteresis -> G(z) ->
static force characteristic -> D(z) -> sensor), eqs (1)-(8), Tables 1-2.

Signal chain (eq numbers of 001)::

    i [A] --(coil, fast pole of G)--> i_c --(hysteresis, sec. 3.3)--> x~_v
          --(slow pole + zero of G, eq (7))--> x_v --(static force F~, sec. 3.1)--> F~
          --(fluid dynamics, eq (8))--> F
    F - 0.4 F_d(x_v, v_f) - F_f + F_stop = m x_s'' + b_s x_s' + k_s x_s            (2), (5), (1)
    F_s = k_s x_s                                                                 (3)

State (SI; forces in N; valve quantities normalised, see below)::

    index  name   unit  meaning
    0      ic     1     coil current / rated current (first pole of G)
    1-6    h1..h6 1     play-operator memories of the hysteresis (updated by the guard)
    7      gw     1     slow valve stage (second pole of G)
    8      fa     N     transport-delay state 1 (first-order all-pass)
    9-10   fb,fc  N     transport-delay states 2-3 (second-order all-pass)
    11-16  r1..r6 N     fluid resonances (three second-order sections, eq (8) poles)
    17     xs     m     sensor deflection x_s (eq (2))
    18     vs     m/s   sensor deflection rate
    19     xp     m     piston position (absolute; frozen while piston_locked = 1)
    20     vp     m/s   piston velocity (absolute)
    21     z      m     bristle (pre-sliding) deflection of the seals (eq (1) as the seal-friction
                        family's Dahl case, friction force sigma0 z; see below)
    22     vf     m/s   band-limited piston velocity (40 Hz pole, sec. 4.4)
    23     fm     N     measured force: F_s through the feedback conditioning filter
    24     fmd    N/s   its rate (second state of the filter)

The piston extension (relative position of piston and cylinder) is ``q = xp + xs`` and the
relative velocity ``v_p = vp + vs``: with the piston locked to the mount (``piston_locked =
1``, the paper's blocked-force set-up) ``v_p = x_s'`` and eq (2) is exactly the paper's model;
with the piston free it carries ``piston_mass + load_mass`` against an optional load spring,
and the hydraulic force acts on it with the opposite sign of its reaction on the cylinder.
End stops at ``q = 0`` and ``q = stroke`` (76 mm) are Hunt-Crossley contacts on the extension.

Input: ``u[0]`` = valve current [A] (zero-order held over the control period).

Decisions (each one documented where it is made):

* **Valve G(z), eq (7)**: the continuous ``G(s) = K (s + c) / ((s + a)(s + b))`` whose
  zero-order-hold discretisation at T = 0.2 ms *is* eq (7) (poles ``s = ln(z)/T``; residues
  ``r_s = r_z ln(z) / (z - 1)``: exact ZOH inverse, tested). Its zero at ``z = 0`` needs the
  continuous zero ``c = 11 352 1/s``. The fast pole (``a = 3519 1/s``, 560 Hz) is placed
  *before* the hysteresis (coil current build-up) and the slow pole (``b = 120.4 1/s``,
  19.2 Hz, "severe damping applied on the valve pipe tip by the fluid", sec. 3.6) after it.
  Sec. 3.3 admits that the real hysteresis sits inside the valve dynamics; with the fast pole
  in front, the hysteresis input is continuous and monotone within every control period, so
  the play operators update exactly. The linear part is still exactly ``G(s)``.
* **Hysteresis (sec. 3.3)**: Prandtl-Ishlinskii (Preisach-class) model of
  :mod:`hydro_envs.laws.hysteresis` with 6 plays: major-loop full width ``hysteresis_width``
  (fraction of rated current), branch slope ``hysteresis_reversal_slope`` after a reversal;
  nested minor loops (tested). Fig. 5 (the measured major loop) is missing from the text:
  width 5 % is assumed, and reversal slope 0.9 (small minor loops keep 90 % of the major-loop
  gain) because sec. 4.7 measures the fastest closed loop at the smallest amplitude.
* **Static force characteristic (sec. 3.1)**: the jet-pipe valve as four matched orifices
  with areas ``(1 +- xi)`` (a fully open-centre valve; sec. 3.1's square-root orifice law, no
  leakage). With the piston blocked, flow continuity gives
  ``p1 = p_s (1+xi)^2 / (2 (1+xi^2))``, ``p2 = p_s (1-xi)^2 / (2 (1+xi^2))`` (gauge) and
  ``F~ = A1 p1 - A2 p2``: saturation ``+A1 p_s = 1340 N`` and ``-A2 p_s`` ("each saturation
  force corresponds to the area on each side of the piston multiplied by the supply
  pressure"), positive bias ``(A1 - A2) p_s / 2`` at ``xi = 0`` (single-rod piston) and
  discharge coefficients cancel out. The valve offset ``valve_offset`` (negative, sec. 3.1)
  is added to ``x_v`` so that zero current gives zero force.
* **Fluid dynamics D(z), eq (8)**: D(z) has two poles at ``z = 0`` placed "to make D(z)
  causal" and non-minimum-phase zeros; an exact ZOH inverse does not exist (it gives a
  continuous model with gains of 10-300 in the band). Below 500 Hz D(z) is a unit gain with
  the phase of a pure delay of ~0.7 ms. We use ``D(s) = Pade_3(tau) * prod_i w_i^2 / (s^2 +
  2 z_i w_i s + w_i^2)``: the three resonances are eq (8)'s poles mapped by ``s = ln(z)/T``
  (exact), and a third-order Pade transport delay ``tau = 0.745 ms`` fitted so that the ZOH
  discretisation matches eq (8) in phase (tested: poles to 1e-9, phase within 3 deg and
  magnitude within 18 % up to 500 Hz, 5 % up to 250 Hz). The paper itself asks whether its
  clustered non-minimum-phase zeros belong to "distributed-parameter components" (sec. 6): a
  transport delay is one. DC gain 1 (eq (8) gives 1.005 from rounded coefficients), so the
  blocked force saturates at exactly ``A p_s``.
* **Sensor (eqs (2)-(4), Table 1)**: ``m = 0.560 kg`` (eq (2): actuator mass minus piston
  mass), ``k_s = 37 592 N/cm`` (impulse test, "the value used in the model"), ``b_s = 4.25
  N/cm/s``. Then ``k_s/m = 6 712 857 1/s^2`` and ``b_s/m = 758.9 1/s``: eq (4) exactly
  (its 178.6 = 100/m, output in cm). Table 1 quotes ``omega_n = sqrt(k_s/m_a)`` with
  ``m_a = 0.612 kg`` instead: 2478 vs 2591 rad/s, zeta 0.140 vs 0.146 (both reported).
* **Units of the paper's simulator**: N, cm, s (eq (4) is in cm; Table 1 in N/cm, N/cm/s).
  Hence eq (5)'s linear term ``40 v_p`` is 40 N/(cm/s) = 4000 N s/m, and eq (1)'s
  ``gamma = 100`` is 100 1/(N cm), i.e. a pre-sliding stiffness ``gamma F_c^2`` of 6.76e6 N/m.
* **Friction (eq (1), Table 2)**: the seal-friction family of
  :mod:`hydro_envs.laws.seal_friction` with exponent n = 2 and no micro- or viscous damping
  (``sigma1 = sigma2 = 0``): 001 eq (1), ``dF/dt = gamma (F - F_c sgn v)^2 v``, written for the
  bristle deflection ``z`` (``F_f = sigma0 z``, ``dz/dt = v u|u|``, ``u = 1 - sigma0 z sgn(v) /
  g(v)``), with its Coulomb level replaced by the Stribeck curve
  ``g(v) = F_c + (F_s(dir) - F_c) exp(-(v/v_s)^2)`` (:func:`stiction_level`), ``F_s = 99 N``
  when the piston is pushed in (retracting, v_p < 0) and ``54 N`` when pulled out (Table 2).
  Steady sliding gives eq (1)'s Coulomb friction ``F_c = 26 N`` with the discontinuous sign;
  from rest the seals hold on their pre-sliding spring ``sigma0`` and break away at the
  direction's static level: a slow force ramp on the free piston breaks it away at +99 N
  (pushing) and -54 N (pulling), Table 2 (tested by simulation,
  :func:`hydro_envs.plants.force_actuator.experiments.breakaway_force`). ``sigma0 = 1e6 N/m``
  (pre-sliding ``F_c/sigma0 = 26 um``, inside the 10-100 um of elastomer seals) instead of
  eq (1)'s 6.76e6 N/m: eq (1) is "only intended for improving the numerical integration"
  (sec. 3.4), and 6.76e6 N/m would need RK4 steps of ~10 us. The bristles' relaxation
  ``2 sigma0 |v| |u| / g`` is stiff at speed only: the kernels resolve it by the local sub-step
  refinement (:func:`dahl_friction_substeps`, as the rodless cylinder's seals; no quasi-static
  ``rate_cap``); the pre-sliding oscillation at rest is the family's bound
  (:func:`~hydro_envs.laws.seal_friction.bristle_block_rate_bound`, ``friction`` mode). The
  guard projects ``|z|`` onto the largest static level over sigma0. Without dry friction
  (``F_c`` = both static levels = 0, :meth:`hydro_envs.spec.PlantSpec.without_dry_friction`)
  the family leaves no friction at all (eq (5)'s damping stays). Option ``friction_model = 1``:
  the static curve ``g(v) tanh(v / v_eps)`` with no pre-sliding state (``z`` stays 0) -- the
  moving-piston diagnosis rig uses it (its base model is smooth Coulomb + viscous friction, as
  every other diagnosis base model).
* **Hydraulic damping (eq (5), sec. 4.4)**: ``F_d = A(tanh(s(|v|+d)) - tanh(s d)) sgn(v)
  + c_lin v`` on the band-limited velocity ``v_f`` (first-order pole at 40 Hz), times the
  output gain 0.4. Fig. 6 (the fitted family A, s, d) is missing: assumed
  ``A = A_sat phi``, knee velocity ``-d = v_max phi``, ``s = kappa / (-d)`` with
  ``phi = 0.1 + 0.9 min(|xi|, 1)``: negligible below the knee, steep at the valve's
  flow-limited speed, tapering off past it (the shape sec. 4.4 describes), with
  ``0.4 A_sat (1 + tanh kappa)`` above the blocked force so a free piston's speed saturates.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from hydro_envs.contract import PlantModel
from hydro_envs.jit import as_python, njit_noalloc
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.elementary import tanh_one_exp
from hydro_envs.laws.filters import lfilter_from_rest
from hydro_envs.laws.friction import tanh_sign
from hydro_envs.laws.seal_friction import bristle_block_rate_bound, seal_friction, stribeck_slope_ratio_bound
from hydro_envs.laws.hysteresis import pi_memories, play_operator
from hydro_envs.libm import exp
from hydro_envs.sim.rk4 import STABLE_H_LAMBDA, local_substeps
from hydro_envs.plants.force_actuator.params import (  # noqa: F401  (re-exported)
    ForceActuatorParams, I_A1, I_AR, I_ASTOP, I_BS, I_DA, I_DG, I_DK, I_DLIN, I_DV, I_FC, I_FLOAD,
    I_FMOD, I_FSE, I_FSR, I_HR, I_HW, I_IMAX, I_IR, I_KL, I_KS, I_KSTOP, I_L, I_LOCK, I_M, I_ML,
    I_MP, I_PS, I_SIG, I_VEPS, I_VS, I_WC, I_XOFF, N_PARAMS, N_PLAY, PLANT, null_valve_offset, I_FFILT, I_TDEL,
    D_PLAY0, D_PLAYW, D_TANHK,
)

__all__ = [
    "CONTRACT",
    "ForceActuatorParams",
    "STATE_NAMES",
    "force_actuator_rhs",
    "force_actuator_guard",
    "stiffness_modes",
    "dahl_relaxation_bound",
    "friction_force",
    "friction_rest_bound",
    "dahl_friction_shallow",
    "dahl_friction_refinement",
    "dahl_friction_substeps",
    "static_force",
    "null_valve_offset",
    "valve_zoh_tf",
    "fluid_continuous_tf",
    "seed_valve_tf",
    "seed_fluid_tf",
    "sensor_natural_frequency",
    "rest_state",
    "measured_force",
    "valve_memory_track",
]

STATE_NAMES = (
    ("ic",) + tuple(f"h{k + 1}" for k in range(N_PLAY)) + ("gw", "fa", "fb", "fc")
    + tuple(f"r{k + 1}" for k in range(6)) + ("xs", "vs", "xp", "vp", "z", "vf", "fm", "fmd")
)
STATE_UNITS = ("1",) * (N_PLAY + 2) + ("N",) * 9 + ("m", "m/s", "m", "m/s", "m", "m/s", "N", "N/s")
N_STATES = len(STATE_NAMES)
IC = 0
H0 = 1
GW = H0 + N_PLAY
FA, FB, FC = GW + 1, GW + 2, GW + 3
R0 = FC + 1
XS, VS, XP, VP, Z, VF, FM, FMD = range(R0 + 6, R0 + 14)

#: sensor outputs (noise-free): measured channel -> the state index it reads, and measured
#: channel -> the state index whose time derivative it reads
STATE_OUTPUTS: dict[str, int] = {}
DERIVATIVE_OUTPUTS: dict[str, int] = {}
#: channels a grey-box fit uses by default (``f`` is a computed output, see computed_outputs)
FIT_OUTPUTS = ("f",)


def computed_outputs(states, params_rows):
    """Outputs that are functions of the state: the measured force ``f`` [N] (001 eq (3),
    ``k_s x_s``, through the feedback conditioning filter when it is on; see
    :func:`measured_force`) of trajectories ``states (c, T, n_states)`` with kernel parameter
    rows ``(c, n_params)``."""
    sensed = params_rows[:, I_KS, None] * states[:, :, XS]
    return {"f": np.where(params_rows[:, I_FFILT, None] > 0.0, states[:, :, FM], sensed)}


assert N_STATES == FMD + 1 == 25

# ----------------------------------------------------------------------------- seed data
SEED_T = 2e-4  # 001 sec. 4.5: sampling frequency 5000 Hz
#: eq (7): G(z) = 0.01203 z / ((z - 0.9762)(z - 0.4947))
SEED_G_GAIN = 0.01203
SEED_G_POLES = (0.9762, 0.4947)
#: eq (8): D(z) = -0.67 (z - 2.03)(z^2 - 1.71z + 2.16)(z^2 + 0.14z + 1.39)(z^2 + 2.24z + 1.30)
#:               / (z^2 (z^2 + 1.546z + 0.671)(z^2 + 0.036z + 0.657)(z^2 + 0.631z + 0.469))
SEED_D_GAIN = -0.67
SEED_D_NUM_FACTORS = ((1.0, -2.03), (1.0, -1.71, 2.16), (1.0, 0.14, 1.39), (1.0, 2.24, 1.30))
SEED_D_DEN_FACTORS = ((1.0, 0.0, 0.0), (1.0, 1.546, 0.671), (1.0, 0.036, 0.657), (1.0, 0.631, 0.469))
#: transport delay of the continuous fluid model, fitted to eq (8)'s phase (see module doc)
FLUID_DELAY = 0.745e-3


def seed_valve_tf() -> tuple[np.ndarray, np.ndarray]:
    """Eq (7) as (numerator, denominator) polynomials in z (descending powers)."""
    return np.array([SEED_G_GAIN, 0.0]), np.poly(SEED_G_POLES)


def seed_fluid_tf() -> tuple[np.ndarray, np.ndarray]:
    """Eq (8) as (numerator, denominator) polynomials in z (descending powers)."""
    num = np.array([SEED_D_GAIN])
    for f in SEED_D_NUM_FACTORS:
        num = np.polymul(num, f)
    den = np.array([1.0])
    for f in SEED_D_DEN_FACTORS:
        den = np.polymul(den, f)
    return num, den


def _valve_continuous() -> tuple[float, float, float, float]:
    """Exact ZOH inverse of eq (7): ``G(s) = K (s + c) / ((s + a)(s + b))`` -> (K, a, b, c).

    For distinct poles, ``G(z) = sum r_z / (z - z_p)`` is the ZOH image of
    ``sum r_s / (s - s_p)`` with ``s_p = ln(z_p) / T`` and ``r_s = r_z s_p / (z_p - 1)``.
    """
    zf, zs = SEED_G_POLES[1], SEED_G_POLES[0]  # fast 0.4947, slow 0.9762
    # partial fractions of 0.01203 z / ((z - zs)(z - zf))
    r_slow = SEED_G_GAIN * zs / (zs - zf)
    r_fast = SEED_G_GAIN * zf / (zf - zs)
    s_slow = math.log(zs) / SEED_T
    s_fast = math.log(zf) / SEED_T
    c_slow = r_slow * s_slow / (zs - 1.0)
    c_fast = r_fast * s_fast / (zf - 1.0)
    # c_slow/(s - s_slow) + c_fast/(s - s_fast) = K (s + c) / ((s - s_slow)(s - s_fast))
    k = c_slow + c_fast
    c = -(c_slow * s_fast + c_fast * s_slow) / k
    return k, -s_fast, -s_slow, c


VALVE_K, VALVE_A, VALVE_B, VALVE_C = _valve_continuous()


def valve_zoh_tf() -> tuple[np.ndarray, np.ndarray]:
    """Continuous valve model G(s) as (numerator, denominator) in s."""
    return np.array([VALVE_K, VALVE_K * VALVE_C]), np.polymul([1.0, VALVE_A], [1.0, VALVE_B])


def _fluid_continuous():
    """Resonances (omega, zeta) from eq (8)'s poles, and the Pade-3 delay sections."""
    _, den = seed_fluid_tf()
    poles_z = np.roots(den)
    poles_z = poles_z[np.abs(poles_z) > 1e-6]  # drop the two poles at z = 0
    poles_s = np.log(poles_z.astype(complex)) / SEED_T
    upper = sorted((p for p in poles_s if p.imag > 0), key=lambda p: abs(p))
    res = tuple((float(abs(p)), float(-p.real / abs(p))) for p in upper)
    # Pade (3,3) of exp(-s tau): den = 1 + s tau/2 + (s tau)^2/10 + (s tau)^3/120
    tau = FLUID_DELAY
    pd = np.roots([tau**3 / 120.0, tau**2 / 10.0, tau / 2.0, 1.0])
    real = float(-pd[np.argmin(np.abs(pd.imag))].real)
    cpx = pd[np.argmax(pd.imag)]
    return res, real, (float(abs(cpx)), float(-cpx.real / abs(cpx)))


FLUID_RESONANCES, DELAY_REAL_POLE, (DELAY_OMEGA, DELAY_ZETA) = _fluid_continuous()
(W1, Z1), (W2, Z2), (W3, Z3) = FLUID_RESONANCES


def fluid_continuous_tf() -> tuple[np.ndarray, np.ndarray]:
    """Continuous fluid model D(s) (unit DC gain) as (numerator, denominator) in s."""
    p1 = DELAY_REAL_POLE
    wa, za = DELAY_OMEGA, DELAY_ZETA
    num = np.polymul([-1.0, p1], [1.0, -2 * za * wa, wa * wa])
    den = np.polymul([1.0, p1], [1.0, 2 * za * wa, wa * wa])
    for w, z in FLUID_RESONANCES:
        num = np.polymul(num, [w * w])
        den = np.polymul(den, [1.0, 2 * z * w, w * w])
    return num, den


def fluid_state_space() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C, D) of the kernel's fluid realisation (states fa, fb, fc, r1..r6; input F~)."""
    a = np.zeros((9, 9))
    b = np.zeros(9)
    p1, wa, za = DELAY_REAL_POLE, DELAY_OMEGA, DELAY_ZETA
    # o1 = 2 fa - u ; o2 = o1 - 4 za fc
    a[0, 0], b[0] = -p1, p1
    o1 = np.zeros(9)
    o1[0] = 2.0
    o1_u = -1.0
    a[1, 2] = wa
    a[2] = wa * o1
    a[2, 1] -= wa
    a[2, 2] -= 2 * za * wa
    b[2] = wa * o1_u
    o2 = o1.copy()
    o2[2] -= 4 * za
    o2_u = o1_u
    inp, inp_u = o2, o2_u
    for j, (w, z) in enumerate(FLUID_RESONANCES):
        r = 3 + 2 * j
        a[r, r + 1] = w
        a[r + 1] = w * inp
        a[r + 1, r] -= w
        a[r + 1, r + 1] -= 2 * z * w
        b[r + 1] = w * inp_u
        inp = np.zeros(9)
        inp[r] = 1.0
        inp_u = 0.0
    c = inp[None, :]
    return a, b[:, None], c, np.array([[inp_u]])


_PHI0 = 0.1  # damping family floor at the valve null (module doc)


@njit_noalloc
def static_force(xi, ps, a1, a2):
    """Blocked (zero-flow) piston force [N] at normalised jet position ``xi`` (001 sec. 3.1).

    Four matched orifices with areas ``(1 +- xi)``: ``F = p_s (A1 (1+xi)^2 - A2 (1-xi)^2) /
    (2 (1 + xi^2))`` for ``|xi| <= 1``, saturated at ``A1 p_s`` and ``-A2 p_s`` beyond.
    """
    if xi > 1.0:
        xi = 1.0
    elif xi < -1.0:
        xi = -1.0
    return ps * (a1 * (1.0 + xi) ** 2 - a2 * (1.0 - xi) ** 2) / (2.0 * (1.0 + xi * xi))


@njit_noalloc
def hydraulic_damping(xi, v, a_sat, v_max, kappa, c_lin):
    """Hydraulic damping force of 001 eq (5) [N] (before the 0.4 output gain).

    ``F_d = A (tanh(s(|v| + d)) - tanh(s d)) sgn(v) + c_lin v`` with the assumed family
    ``A = a_sat phi``, ``d = -v_max phi``, ``s = kappa / (v_max phi)``,
    ``phi = 0.1 + 0.9 min(|xi|, 1)``. Continuous (zero) at v = 0.
    """
    return hydraulic_damping_knee(xi, v, a_sat, v_max, kappa, tanh_one_exp(kappa), c_lin)


@njit_noalloc
def hydraulic_damping_knee(xi, v, a_sat, v_max, kappa, tanh_kappa, c_lin):
    """:func:`hydraulic_damping` with ``tanh(kappa)`` given (a parameter-only term, the
    ``D_TANHK`` column of the kernel parameter row)."""
    a = abs(xi)
    if a > 1.0:
        a = 1.0
    phi = _PHI0 + (1.0 - _PHI0) * a
    vk = v_max * phi
    av = abs(v)
    f = a_sat * phi * (tanh_one_exp(kappa * (av / vk - 1.0)) + tanh_kappa)
    if v < 0.0:
        f = -f
    return f + c_lin * v


@njit_noalloc
def stiction_level(v, f_c, fs_retract, fs_extend, v_s):
    """Friction level g(v) [N]: Stribeck curve from the direction's static level to F_c."""
    fs = fs_extend if v > 0.0 else fs_retract
    r = v / v_s
    return f_c + (fs - f_c) * exp(-r * r)


@njit_noalloc
def friction_force(vrel, z, p):
    """``(F_f, dz/dt)``: seal friction [N] and bristle rate [m/s] at relative velocity ``vrel``
    and bristle deflection ``z`` (001 eq (1), Table 2): the seal-friction family
    (:func:`~hydro_envs.laws.seal_friction.seal_friction`) with n = 2, ``sigma1 = sigma2 = 0``
    and the level :func:`stiction_level`; ``friction_model = 1``: the static curve
    ``g(v) tanh(v / v_eps)``, no bristle state (rate 0)."""
    g = stiction_level(vrel, p[I_FC], p[I_FSR], p[I_FSE], p[I_VS])
    if p[I_FMOD] > 0.5:
        return g * tanh_sign(vrel, p[I_VEPS]), 0.0
    return seal_friction(vrel, z, g, p[I_SIG], 0.0, 0.0, 0.0, 2, 0.0)


@njit_noalloc
def valve_position(y, p):
    """Normalised valve position x_v from the coil current and the hysteresis memory."""
    ic = y[IC]
    w = p[D_PLAYW]  # (1 - w0) / n
    xt = p[I_HR] * ic
    for k in range(N_PLAY):
        xt += w * play_operator(y[H0 + k], ic, p[D_PLAY0 + k])  # threshold R (k + 1) / n
    # slow valve stage: (K/a)(s + c)/(s + b) -> x_v = (K/a)(x~ + (c - b) w)
    xv = VALVE_K / VALVE_A * (xt + (VALVE_C - VALVE_B) * y[GW])
    return xt, xv


@njit_noalloc
def measured_force(y, p):
    """The force the controller reads [N]: ``k_s x_s`` (eq (3)) through the feedback
    conditioning filter (state ``fm``) when ``feedback_filter_frequency`` > 0."""
    if p[I_FFILT] > 0.0:
        return y[FM]
    return p[I_KS] * y[XS]


@njit_noalloc
def force_actuator_rhs(y, u, p, dy):
    """Time derivative ``dy`` of state ``y`` under valve current ``u[0]`` [A] (001 fig. 2)."""
    # valve: coil (fast pole of G), hysteresis, slow stage (eq (7))
    dy[IC] = VALVE_A * (u[0] / p[I_IR] - y[IC])
    for k in range(N_PLAY):
        dy[H0 + k] = 0.0  # play memories: updated by the guard (projection)
    xt, xv = valve_position(y, p)
    dy[GW] = xt - VALVE_B * y[GW]
    xi = xv + p[I_XOFF]
    a2 = p[I_A1] - p[I_AR]
    f_static = static_force(xi, p[I_PS], p[I_A1], a2)  # sec. 3.1
    # fluid: Pade-3 transport delay then the three resonances of eq (8)
    dy[FA] = DELAY_REAL_POLE * (f_static - y[FA])
    o1 = 2.0 * y[FA] - f_static
    dy[FB] = DELAY_OMEGA * y[FC]
    dy[FC] = DELAY_OMEGA * (o1 - y[FB]) - 2.0 * DELAY_ZETA * DELAY_OMEGA * y[FC]
    o2 = o1 - 4.0 * DELAY_ZETA * y[FC]
    dy[R0] = W1 * y[R0 + 1]
    dy[R0 + 1] = W1 * (o2 - y[R0]) - 2.0 * Z1 * W1 * y[R0 + 1]
    dy[R0 + 2] = W2 * y[R0 + 3]
    dy[R0 + 3] = W2 * (y[R0] - y[R0 + 2]) - 2.0 * Z2 * W2 * y[R0 + 3]
    dy[R0 + 4] = W3 * y[R0 + 5]
    dy[R0 + 5] = W3 * (y[R0 + 2] - y[R0 + 4]) - 2.0 * Z3 * W3 * y[R0 + 5]
    f_fluid = y[R0 + 4]
    # mechanics: relative (piston vs cylinder) velocity drives friction and damping
    vrel = y[VP] + y[VS]
    q = y[XP] + y[XS]
    f_damp = p[I_DG] * hydraulic_damping_knee(xi, y[VF], p[I_DA], p[I_DV], p[I_DK], p[D_TANHK], p[I_DLIN])  # (5)
    f_stop = end_stop_force(q, vrel, 0.0, p[I_L], p[I_KSTOP], p[I_ASTOP])
    f_fric, dz = friction_force(vrel, y[Z], p)  # (1)
    f_h = f_fluid - f_damp - f_fric + f_stop
    dy[XS] = y[VS]
    dy[VS] = (f_h - p[I_BS] * y[VS] - p[I_KS] * y[XS]) / p[I_M]  # (2)
    if p[I_LOCK] > 0.5:
        dy[XP] = 0.0
        dy[VP] = 0.0
    else:
        dy[XP] = y[VP]
        dy[VP] = (f_h - p[I_KL] * (y[XP] - 0.5 * p[I_L]) + p[I_FLOAD]) / (p[I_MP] + p[I_ML])
    dy[Z] = dz
    dy[VF] = p[I_WC] * (vrel - y[VF])  # band-limited differentiation, 40 Hz
    # feedback conditioning: second-order Butterworth low-pass on F_s = k_s x_s (eq (3))
    wf = 2.0 * math.pi * p[I_FFILT]
    if wf > 0.0:
        dy[FM] = y[FMD]
        dy[FMD] = wf * wf * (p[I_KS] * y[XS] - y[FM]) - math.sqrt(2.0) * wf * y[FMD]
    else:
        dy[FM] = 0.0
        dy[FMD] = 0.0


@njit_noalloc
def force_actuator_guard(y, p):
    """After a sub-step: update the play memories (exact for the monotone coil current) and
    project the bristle deflection onto ``sigma0 |z| <= max static level``; return #clamps."""
    ic = y[IC]
    for k in range(N_PLAY):
        y[H0 + k] = play_operator(y[H0 + k], ic, p[D_PLAY0 + k])
    z_hi = max(p[I_FC], p[I_FSR], p[I_FSE]) / p[I_SIG]
    if y[Z] > z_hi:
        y[Z] = z_hi
        return 1
    if y[Z] < -z_hi:
        y[Z] = -z_hi
        return 1
    return 0


# ---------------------------------------------------------------------------- analysis
def sensor_natural_frequency(params: ForceActuatorParams, mass: float | None = None) -> tuple[float, float]:
    """(omega_n [rad/s], zeta) of the sensor mass-spring-damper (eq (2); Table 1 uses m_a)."""
    m = params.sensor_mass if mass is None else mass
    wn = math.sqrt(params.sensor_stiffness / m)
    return wn, params.sensor_damping / (2.0 * m * wn)


#: Largest relative piston velocity [m/s] the friction stiffness bound covers (locked piston:
#: closed-loop square waves of 800 N peak at 0.15 m/s; free piston: the damping-limited speed).
LOCKED_VELOCITY_BOUND = 0.3


def velocity_bound(params: ForceActuatorParams) -> float:
    """Relative-velocity bound [m/s] the friction's fine sub-steps are sized for."""
    return as_python(_velocity_bound_row)(params.to_array())


@nb.njit(cache=True, error_model="numpy", inline="always")
def _velocity_bound_row(p):
    """:func:`velocity_bound` of a parameter row (locked piston: LOCKED_VELOCITY_BOUND; free
    piston: the speed at which the hydraulic damping's linear part carries the full thrust,
    beyond its knee, in ``[LOCKED_VELOCITY_BOUND, 10]`` m/s)."""
    if p[I_LOCK] > 0.5:
        return LOCKED_VELOCITY_BOUND
    c = p[I_DG] * p[I_DLIN]
    v_free = p[I_DK] + (p[I_A1] * p[I_PS] / c if c > 0 else 10.0)
    return max(LOCKED_VELOCITY_BOUND, min(v_free, 10.0))


def stiffness_modes(params: ForceActuatorParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of the modes that size the
    sub-steps.

    * ``fluid``: the fastest resonance of eq (8) (2.23 kHz), ``delay``: the Pade poles;
    * ``valve``: the fast pole of eq (7) (560 Hz);
    * ``sensor``: the sensor mass on k_s plus the friction pre-sliding spring and the
      band-limited damping's stiffness-like term, with b_s/m;
    * ``piston``: the free piston on the pre-sliding spring and stop (free piston only);
    * ``friction``: static curve (``friction_model = 1``): its largest slope ``g_max / v_eps``
      (at v = 0) acting on the relative velocity through the sensor mass and the free piston,
      ``g_max / v_eps (1/m + 1/m_p)``; no pre-sliding spring in ``sensor`` / ``piston``. The
      Dahl seals (``friction_model = 0``): the seal-friction family's bound of the (relative
      velocity, bristle) block at rest (:func:`friction_rest_bound`); none without dry friction.

    The Dahl state's relaxation (``friction_model = 0``), ``4 sigma0 |v| / F_c`` at the relative
    velocity v, is not among them: it is stiff only at speed, and the kernels take a sub-step as
    :func:`dahl_friction_substeps` finer ones where :func:`dahl_friction_shallow` fails at its
    start or at the Euler prediction of its end (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`).
    :func:`dahl_relaxation_bound` is its value at the velocity bound.
    """
    m = params.sensor_mass
    c_d = params.damping_gain * (
        params.damping_linear + params.damping_force_scale * params.damping_sharpness / params.damping_knee_velocity
    )
    # the damping acts through the 40 Hz filter: with v_f it forms the 2x2 block
    # [[0, -c_d/m], [w_c, -w_c]], |lambda| <= sqrt(w_c c_d / m) (+ w_c)
    static = params.friction_model > 0.5
    k_pre = 0.0 if static else params.friction_stiffness  # pre-sliding spring of the Dahl state
    k_eff = params.sensor_stiffness + k_pre + c_d * params.damping_filter_frequency
    g_max = max(params.coulomb_friction, params.stiction_retract, params.stiction_extend)
    mp = params.piston_mass + params.load_mass
    modes = {
        "fluid": max(w for w, _ in FLUID_RESONANCES),
        "delay": max(DELAY_REAL_POLE, DELAY_OMEGA),
        "valve": VALVE_A,
        "feedback_filter": 2.0 * math.pi * params.feedback_filter_frequency,
        "sensor": math.sqrt(k_eff / m) + params.sensor_damping / m + params.damping_filter_frequency,
    }
    if static:
        # its slope g_max / v_eps on the relative velocity, which both the sensor mass and (free)
        # the piston carry: |lambda| = slope (1/m + 1/m_p)
        modes["friction"] = g_max / params.friction_sign_velocity * (
            1.0 / m + (1.0 / mp if params.piston_locked < 0.5 else 0.0))
    elif g_max > 0.0:  # the family's bound of the (relative velocity, bristle) block at rest
        modes["friction"] = friction_rest_bound(params)
    if params.piston_locked < 0.5:
        f_max = params.max_thrust + abs(params.load_force)
        modes["piston"] = (
            math.sqrt((k_pre + params.load_stiffness + params.stop_stiffness) / mp)
            + params.stop_damping * f_max / mp
            + math.sqrt(c_d * params.damping_filter_frequency / mp)
        )
    return modes


def friction_rest_bound(params: ForceActuatorParams) -> float:
    """:func:`~hydro_envs.laws.seal_friction.bristle_block_rate_bound` [1/s] at rest (v = 0) at the
    deflection bound ``g_max / sigma0``, the lowest level ``F_c`` and the Gaussian curve's slope
    bound, for the relative mass the seals act on (locked: the sensor mass; free: the sensor
    mass and the piston with its load in series) with the sensor damping b_s: the oscillation of
    that mass on the bristles in pre-sliding (at speed the relaxation is the local refinement's,
    :func:`dahl_friction_substeps`). 0 without dry friction."""
    g_max = max(params.coulomb_friction, params.stiction_retract, params.stiction_extend)
    if not g_max > 0.0 or params.friction_model > 0.5:
        return 0.0
    m = params.sensor_mass
    if params.piston_locked < 0.5:
        mp = params.piston_mass + params.load_mass
        m = m * mp / (m + mp)
    ratio = stribeck_slope_ratio_bound(params.coulomb_friction, g_max, "gaussian")
    s0 = params.friction_stiffness
    return as_python(bristle_block_rate_bound)(0.0, g_max / s0, params.coulomb_friction, ratio, s0, 0.0, 0.0,
                                            params.sensor_damping, m, 2, 0.0)


def dahl_relaxation_bound(params: ForceActuatorParams) -> float:
    """Largest relaxation rate [1/s] of the bristle state, ``4 sigma0 v_b / F_c`` at the velocity
    bound v_b (:func:`velocity_bound`): ``-d(dz/dt)/dz = 2 sigma0 |v| |u| / g`` (the family's
    n = 2 rate) with ``|u| <= 2`` while ``sigma0 |z| <= g(v)`` and level ``g >= F_c``. Right after a breakaway ``|u|`` reaches
    ``1 + F_s/F_c``, but then ``|v|`` is of the order of the Stribeck velocity, far below v_b;
    the guard's projection is the safety net. 0 for the static curve or a frictionless set."""
    if params.friction_model > 0.5 or not params.coulomb_friction > 0.0:
        return 0.0
    return 4.0 * params.friction_stiffness * velocity_bound(params) / params.coulomb_friction


#: h lambda at which an RK4 sub-step is taken stable (the sub-step safety of hydro_envs.sim.stiffness)


@njit_noalloc
def dahl_friction_shallow(y0, y, p, h):
    """True where an RK4 sub-step of ``h`` seconds keeps the Dahl state stable at state ``y``:
    ``h 4 sigma0 |v| / F_c`` inside RK4's real-axis bound (with the sub-step safety) at the
    relative velocity v of ``y``, and v of the sign it had at the step's start ``y0`` (a
    reversal swings the state across its range and switches the stiction level). Always true
    for the static curve and a frictionless set (``stiffness_modes`` covers them)."""
    if p[I_FMOD] > 0.5 or not p[I_FC] > 0.0:
        return True
    v = y[VP] + y[VS]
    if (v > 0.0) != (y0[VP] + y0[VS] > 0.0):
        return False
    return h * 4.0 * p[I_SIG] * abs(v) / p[I_FC] <= STABLE_H_LAMBDA


@njit_noalloc
def dahl_friction_substeps(y0, x, p, h, m):
    """RK4 steps of ``h / n`` that take a sub-step of ``h`` from ``y0`` (Euler prediction of its
    end ``x``) with the Dahl state stable (:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`):
    1 where :func:`dahl_friction_shallow` holds at ``y0`` and ``x``; ``m`` (the count at the
    velocity bound, :func:`dahl_friction_refinement`) across a velocity reversal; else the count
    for the larger relaxation rate ``4 sigma0 |v| / F_c`` at the two
    (:func:`hydro_envs.sim.rk4.local_substeps`). 1 for the static curve and a frictionless set."""
    if p[I_FMOD] > 0.5 or not p[I_FC] > 0.0:
        return 1
    v0 = y0[VP] + y0[VS]
    v1 = x[VP] + x[VS]
    if (v1 > 0.0) != (v0 > 0.0):
        return m
    return local_substeps(h * 4.0 * p[I_SIG] * max(abs(v0), abs(v1)) / p[I_FC], STABLE_H_LAMBDA, m)


@njit_noalloc
def dahl_friction_refinement(p, h):
    """Sub-steps per step of ``h`` seconds that keep the Dahl state stable up to the velocity
    bound (:func:`dahl_relaxation_bound`); 1 for the static curve and a frictionless set."""
    m = 1
    if p[I_FMOD] > 0.5 or not p[I_FC] > 0.0:
        return m
    need = h * 4.0 * p[I_SIG] * _velocity_bound_row(p) / p[I_FC]  # h lambda at the velocity bound
    while m * STABLE_H_LAMBDA < need * (1.0 - 1e-12):  # the smallest m with h lambda / m stable
        m += 1
    return m


def valve_memory_track(current, dt, rated_current, width, reversal_slope):
    """Coil current (fraction of ``rated_current``) and the hysteresis play memories at every
    sample of a record, from a demagnetised valve at rest at its start.

    ``current[k]`` [A] is held over ``[t_k, t_k + dt)`` (zero-order hold, as the kernel's input);
    row ``k`` of the result is the state at ``t_k``, before ``current[k]`` acts. The coil pole
    of eq (7) is integrated exactly (a first-order recursion); within a hold the coil current
    moves monotonically, so updating the plays with its end value is exact (the guard's rule).
    Returns ``(ic (n,), h (n, N_PLAY))``; these states remember the whole input history
    (thresholds up to ``pi_threshold_scale(width, reversal_slope)`` of rated current), which a
    short simulation warm-up cannot rebuild.
    """
    decay = math.exp(-VALVE_A * dt)
    u = np.asarray(current, dtype=np.float64) / rated_current
    # coil current at the end of each hold (scipy.signal.lfilter's recursion, bit for bit)
    ic_end = lfilter_from_rest(np.array([1.0 - decay, 0.0]), np.array([1.0, -decay]), u)
    h_end = pi_memories(ic_end, width, reversal_slope, N_PLAY)
    ic = np.concatenate(([0.0], ic_end[:-1]))
    h = np.vstack((np.zeros((1, N_PLAY)), h_end[:-1]))
    return ic, h


def rest_state(params: ForceActuatorParams, x_piston: float | None = None) -> np.ndarray:
    """Equilibrium at zero current with demagnetised hysteresis: everything at zero, the
    piston at mid-stroke (001 sec. 4.5: identification "with the piston fixed at midstroke")."""
    y = np.zeros(N_STATES)
    y[XP] = 0.5 * params.stroke if x_piston is None else x_piston
    return y


def rest_state_from_measurement(params: ForceActuatorParams, first: dict) -> np.ndarray:
    """State at a record's first sample: :func:`rest_state` (zero current, demagnetised
    hysteresis, no force, piston at mid-stroke). The blocked-force record must start there: the
    internal valve and fluid states are not measured, so a first force reading is not used."""
    return rest_state(params)


#: the plant's typed contract (hydro_envs.contract.PlantModel): what the registry, sim, envs,
#: identification, diagnosis and the soak test read of this model
CONTRACT = PlantModel(
    state_names=STATE_NAMES, state_units=STATE_UNITS, stiffness_modes=stiffness_modes,
    state_outputs=STATE_OUTPUTS, derivative_outputs=DERIVATIVE_OUTPUTS,
    fit_outputs=FIT_OUTPUTS, computed_outputs=computed_outputs, rest_state=rest_state,
    rest_state_from_measurement=rest_state_from_measurement,
)
