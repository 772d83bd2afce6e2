"""Seed-001 force actuator (plant) and ``hydro_envs/ForceActuator-v0`` (env), checked against
independent truths: eq (4) and Table 1, the orifice law solved independently, the ZOH
discretisation of eqs (7)-(8), a Radau reference, the numerical Jacobian, hysteresis loop
geometry, and the env's spaces, info, autoreset and randomisation (the contract every env
keeps: ``test_env_contract.py``)."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest
from scipy import signal
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import hydro_envs  # noqa: F401  (registers the env)
from hydro_envs.laws.hysteresis import pi_output, pi_threshold_scale, play_operator
from hydro_envs.params import ParameterError
from hydro_envs.plants.force_actuator import model as fa
from hydro_envs.plants.force_actuator import closed_loop
from hydro_envs.plants.force_actuator import experiments as fa_exp
from hydro_envs.plants.force_actuator import validation as fa_validation
from hydro_envs.plants.force_actuator.params import ForceActuatorParams
from hydro_envs.randomization import load_randomization
from hydro_envs import registry
from hydro_envs.sim.stiffness import substeps_from_stiffness
from env_helpers import action as _a
from env_helpers import rollout as _rollout

ENV_ID = "hydro_envs/ForceActuator-v0"
NOMINAL = ForceActuatorParams()
DT = 2e-4
T = fa.SEED_T


def simulate(p: ForceActuatorParams, currents, n_sub=None, y0=None, dt=DT) -> np.ndarray:
    """Fixed-step kernel rollout under per-step valve currents [A]; returns (n+1, 23) states."""
    n_sub = n_sub or substeps_from_stiffness(fa.stiffness_modes(p), dt)[0]
    Y = (fa.rest_state(p) if y0 is None else np.array(y0, float))[None, :].copy()
    P = p.to_array()[None, :]
    W = np.zeros((1, 5, fa.N_STATES))
    c = np.zeros(1, dtype=np.int64)
    out = np.empty((len(currents) + 1, fa.N_STATES))
    out[0] = Y[0]
    U = np.zeros((1, 1))
    for k, i in enumerate(currents):
        U[0, 0] = i
        registry.get("force_actuator").kernels.step_serial(Y, U, P, dt, np.array([n_sub]), W, c)
        out[k + 1] = Y[0]
    return out


def sensed(p, ys):
    return p.sensor_stiffness * ys[:, fa.XS]


@pytest.fixture(scope="module")
def spec():
    return load_randomization("force_actuator", ForceActuatorParams)


# ------------------------------------------------------------------------- parameters
def test_nominal_parameters_are_the_seed_values():
    p = NOMINAL
    assert p.sensor_mass == 0.560 and p.piston_mass == pytest.approx(0.612 - 0.560)
    assert p.sensor_stiffness == pytest.approx(37592e2) and p.sensor_damping == pytest.approx(4.25e2)
    assert p.max_thrust == pytest.approx(1340.0) and p.supply_pressure == pytest.approx(345e4)
    assert p.stroke == 0.076 and p.coulomb_friction == 26.0
    # the static levels are set where the seals break away at Table 2's 99 / 54 N (test below)
    assert (p.stiction_retract, p.stiction_extend) == (107.0, 57.6)
    assert p.damping_gain == 0.4 and p.damping_filter_frequency == pytest.approx(2 * np.pi * 40)
    # eq (4): k_s/m and b_s/m are its coefficients
    assert p.sensor_stiffness / p.sensor_mass == pytest.approx(6712857, rel=1e-4)
    assert p.sensor_damping / p.sensor_mass == pytest.approx(758.4, rel=2e-3)


@pytest.mark.parametrize("field,value", [("sensor_mass", 0.0), ("rod_area", 1.0), ("piston_locked", 0.5),
                                         ("hysteresis_reversal_slope", 1.0)])
def test_invalid_parameters_raise(field, value):
    with pytest.raises(ParameterError, match=field.split("_")[0]):
        ForceActuatorParams(**{field: value})
    with pytest.raises(ParameterError, match="stiction"):
        ForceActuatorParams(coulomb_friction=60.0)


# ------------------------------------------------------------------------- sensor (2)-(4)
def test_sensor_ring_down_matches_eq4_and_table1():
    wn, zeta = closed_loop.sensor_ring_down(NOMINAL)
    den = [1.0, 758.4, 6712857.0]  # eq (4)
    pole = np.roots(den)[0]
    assert wn == pytest.approx(abs(pole), rel=2e-3)
    assert zeta == pytest.approx(-pole.real / abs(pole), rel=5e-3)
    # Table 1 uses m_a = 0.612 kg: 2478 rad/s and zeta 0.14 -- both reproduced analytically
    wn_t1, zeta_t1 = fa.sensor_natural_frequency(NOMINAL, mass=0.612)
    assert wn_t1 == pytest.approx(2478, rel=1e-3) and zeta_t1 == pytest.approx(0.14, abs=1e-3)
    assert wn / wn_t1 == pytest.approx(math.sqrt(0.612 / 0.560), rel=3e-3)


# ------------------------------------------------------------------ static force (sec. 3.1)
def _orifice_blocked_force(xi, p, cd=0.61, rho=850.0, w=1e-3):
    """Independent truth: solve Q_in = Q_out with the square-root law for each chamber."""
    def chamber(a_in, a_out):
        if a_out <= 0:
            return p.supply_pressure
        if a_in <= 0:
            return 0.0
        f = lambda pc: cd * a_in * math.sqrt(2 * (p.supply_pressure - pc) / rho) - cd * a_out * math.sqrt(2 * pc / rho)
        return brentq(f, 0.0, p.supply_pressure)
    x = min(max(xi, -1.0), 1.0)
    p1 = chamber(w * (1 + x), w * (1 - x))
    p2 = chamber(w * (1 - x), w * (1 + x))
    return p.bore_area * p1 - (p.bore_area - p.rod_area) * p2


def test_static_force_is_the_orifice_law_with_bias_and_saturation():
    p = NOMINAL
    a2 = p.bore_area - p.rod_area
    for xi in np.linspace(-1.3, 1.3, 27):
        assert fa.static_force(xi, p.supply_pressure, p.bore_area, a2) == pytest.approx(
            _orifice_blocked_force(xi, p), rel=1e-9, abs=1e-6)
    assert fa.static_force(0.0, p.supply_pressure, p.bore_area, a2) == pytest.approx(
        p.rod_area * p.supply_pressure / 2)  # positive bias (fig. 3)
    assert fa.static_force(5.0, p.supply_pressure, p.bore_area, a2) == pytest.approx(1340.0)
    assert fa.static_force(-5.0, p.supply_pressure, p.bore_area, a2) == pytest.approx(p.min_thrust)
    assert fa.static_force(p.valve_offset, p.supply_pressure, p.bore_area, a2) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("frac", [-1.2, -0.5, -0.1, 0.0, 0.2, 0.6, 1.2])
def test_blocked_force_steady_state_follows_the_static_characteristic(frac):
    """Locked piston, current ramped up to a level and held (from below): F_s -> F~(x_v + offset)."""
    p = dataclasses.replace(NOMINAL, hysteresis_width=0.0, coulomb_friction=0.0, stiction_retract=0.0,
                            stiction_extend=0.0)
    i_end = frac * p.rated_current
    ramp = np.linspace(0.0, i_end, 200)
    ys = simulate(p, np.concatenate([ramp, np.full(1500, i_end)]))
    xi = fa.VALVE_K * fa.VALVE_C / (fa.VALVE_A * fa.VALVE_B) * frac + p.valve_offset
    want = _orifice_blocked_force(xi, p)
    assert sensed(p, ys)[-1] == pytest.approx(want, abs=0.05 + 1e-4 * abs(want))


def test_blocked_force_saturates_at_area_times_supply_pressure():
    # with the piston locked, the stuck seal carries part of the force: F_s + sigma0 z = A p_s
    s0 = NOMINAL.friction_stiffness
    ys = simulate(NOMINAL, np.full(1500, NOMINAL.current_max))
    assert sensed(NOMINAL, ys)[-1] + s0 * ys[-1, fa.Z] == pytest.approx(NOMINAL.max_thrust, rel=1e-4)
    assert 0 < s0 * ys[-1, fa.Z] <= NOMINAL.stiction_extend
    ys = simulate(NOMINAL, np.full(1500, -NOMINAL.current_max))
    assert sensed(NOMINAL, ys)[-1] + s0 * ys[-1, fa.Z] == pytest.approx(NOMINAL.min_thrust, rel=1e-4)
    assert -NOMINAL.stiction_retract <= s0 * ys[-1, fa.Z] < 0
    ys = simulate(NOMINAL, np.zeros(500))
    assert np.max(np.abs(sensed(NOMINAL, ys))) < 1e-6  # zero current -> zero force (offset)


# ------------------------------------------------------------------------- Dahl friction (1)
def _friction_rate(v, f, p=NOMINAL):
    """Rate of the seal friction force sigma0 dz/dt [N/s] at relative velocity v, friction f."""
    y = fa.rest_state(p)
    y[fa.VS] = v
    y[fa.Z] = f / p.friction_stiffness
    dy = np.empty(fa.N_STATES)
    registry.get("force_actuator").kernels.rhs(y, np.zeros(1), p.to_array(), dy)
    return p.friction_stiffness * dy[fa.Z]


def test_hydraulic_damping_is_zero_at_rest_and_odd_in_velocity():
    """001 eq (5) as modelled: no damping force without motion, and F_d(-v) = -F_d(v) exactly."""
    p = ForceActuatorParams()
    args = (p.damping_force_scale, p.damping_knee_velocity, p.damping_sharpness, p.damping_linear)
    for xi in (-1.2, -0.4, 0.0, 0.3, 1.0):
        assert fa.hydraulic_damping(xi, 0.0, *args) == 0.0
        for v in (1e-9, 1e-4, 0.01, 0.3, 3.0):
            f = fa.hydraulic_damping(xi, v, *args)
            assert f > 0.0 and fa.hydraulic_damping(xi, -v, *args) == -f


def test_dahl_steady_state_is_coulomb_when_sliding_and_stiction_near_rest():
    for v, level in ((0.1, 26.0), (-0.1, -26.0), (1e-5, NOMINAL.stiction_extend), (-1e-5, -NOMINAL.stiction_retract)):
        t_end = 5000 * level / (NOMINAL.friction_stiffness * abs(v))  # 5000 pre-sliding lengths
        sol = solve_ivp(lambda t, f: [_friction_rate(v, f[0])], (0, abs(t_end)), [0.0],
                        method="Radau", rtol=1e-10, atol=1e-9)
        assert sol.y[0, -1] == pytest.approx(level, rel=2e-3)
    # the rate vanishes at the steady state and at v = 0 (force held), eq (1)
    assert _friction_rate(0.1, 26.0) == pytest.approx(0.0, abs=1e-6)
    assert _friction_rate(0.0, 13.0) == 0.0


@pytest.mark.parametrize("direction,table2", [(1, 99.0), (-1, -54.0)])
def test_slow_force_ramp_breaks_the_seals_away_at_table_2(direction, table2):
    """001 sec. 4.3 / Table 2 by simulation: the free piston, a push (+) or pull (-) on the rod ramped
    at 5 N/s from 0; the peak seal friction (the force at the breaking point) is 99 N pushing and
    54 N pulling. Before it the piston creeps within its pre-sliding range; after it, it slides."""
    f_break, f_applied = fa_exp.breakaway_force(NOMINAL, direction, rate=5.0)
    assert f_break == pytest.approx(table2, abs=0.5)
    assert abs(f_applied) >= abs(f_break) and abs(f_applied) < abs(f_break) + 5.0
    # a slower ramp breaks away closer to the static level, never above it (no stick above g(0))
    f_slow, _ = fa_exp.breakaway_force(NOMINAL, direction, rate=2.0)
    level = NOMINAL.stiction_retract if direction > 0 else NOMINAL.stiction_extend
    assert abs(table2) < abs(f_slow) < level


def test_friction_stays_bounded_under_random_currents():
    rng = np.random.default_rng(3)
    cur = np.repeat(rng.uniform(-1, 1, 60), 50) * NOMINAL.current_max
    ys = simulate(NOMINAL, cur)
    ff = NOMINAL.friction_stiffness * ys[:, fa.Z]
    assert np.all(np.abs(ff) <= NOMINAL.stiction_retract + 1e-9)
    assert np.ptp(ff) > 50  # friction really moved between the directions


# ------------------------------------------------------------------------- hysteresis (3.3)
def _pi_trace(u_path, width, slope, n=fa.N_PLAY):
    mem = np.zeros(n)
    big_r = width * n / ((1 - slope) * (n + 1))
    out = []
    for u in u_path:
        out.append(pi_output(u, mem, width, slope))
        for k in range(n):
            mem[k] = play_operator(mem[k], u, big_r * (k + 1) / n)
    return np.array(out)


def _loop_width(u, y):
    """Horizontal width of a closed loop at y = its mid level (ascending vs descending)."""
    mid = 0.5 * (y.max() + y.min())
    du = np.diff(u)
    asc = [u[j] + (mid - y[j]) * (u[j + 1] - u[j]) / (y[j + 1] - y[j])
           for j in range(len(u) - 1) if du[j] > 0 and (y[j] - mid) * (y[j + 1] - mid) <= 0 and y[j + 1] != y[j]]
    desc = [u[j] + (mid - y[j]) * (u[j + 1] - u[j]) / (y[j + 1] - y[j])
            for j in range(len(u) - 1) if du[j] < 0 and (y[j] - mid) * (y[j + 1] - mid) <= 0 and y[j + 1] != y[j]]
    return float(np.mean(asc) - np.mean(desc))


def test_major_loop_width_equals_configured_width():
    for width, slope in ((0.05, 0.6), (0.1, 0.3), (0.02, 0.0)):
        u = 1.2 * np.sin(np.linspace(0, 6 * np.pi, 6001))
        y = _pi_trace(u, width, slope)
        last = slice(2000, None)
        assert _loop_width(u[last], y[last]) == pytest.approx(width, rel=1e-3)
        # far from the reversals the branches are the identity shifted by half the width
        assert np.max(np.abs(np.abs(y[last] - u[last]) - width / 2)[np.abs(u[last]) < 0.5]) < 1e-9


def test_decreasing_amplitude_gives_nested_minor_loops_that_shrink():
    amps = [1.0, 0.12, 0.08, 0.05, 0.03]
    width, slope = 0.05, 0.6
    u = np.concatenate([a * np.sin(np.linspace(0, 4 * np.pi, 4001)) for a in amps])
    y = _pi_trace(u, width, slope)
    widths, ranges = [], []
    for j in range(len(amps)):
        seg = slice(j * 4001 + 2000, (j + 1) * 4001)
        widths.append(_loop_width(u[seg], y[seg]))
        ranges.append((y[seg].min(), y[seg].max()))
    assert widths[0] == pytest.approx(width, rel=1e-3)
    assert all(w1 > w2 for w1, w2 in zip(widths, widths[1:]))  # shrinking
    assert widths[-1] >= 0
    # each minor loop lies inside the previous loop's output range (nested)
    for (lo0, hi0), (lo1, hi1) in zip(ranges, ranges[1:]):
        assert lo0 - 1e-12 <= lo1 and hi1 <= hi0 + 1e-12


@pytest.mark.parametrize("width", [NOMINAL.hysteresis_width, 0.07])
def test_plant_hysteresis_has_the_configured_major_loop(width):
    """Quasi-static current triangle through the kernel: x~_v(i) loop of the configured width,
    nominal and at the randomisation's widest (the loop closes within the driver range)."""
    p = dataclasses.replace(NOMINAL, hysteresis_width=width)
    assert width <= {e.name: e for e in load_randomization("force_actuator").entries}["hysteresis_width"].high
    n = 3000
    tri = p.current_max * np.concatenate([np.linspace(0, 1, n // 4), np.linspace(1, -1, n // 2), np.linspace(-1, 1, n // 2)])
    ys = simulate(p, tri)
    xt = np.array([fa.valve_position(y, p.to_array())[0] for y in ys[1:]])
    u = ys[1:, fa.IC]
    seg = slice(n // 4, None)
    assert _loop_width(u[seg], xt[seg]) == pytest.approx(p.hysteresis_width, rel=0.02)


def test_valve_memory_track_equals_the_kernel_s_coil_and_plays():
    """The diagnosis' record-long valve memory (coil current, play memories) equals the plant
    kernel's states at every sample under the same held currents; a track that forgot the
    history (plays reset halfway) differs by a sizeable part of the largest threshold."""
    rng = np.random.default_rng(4)
    p = NOMINAL
    t = DT * np.arange(3000)
    amp = np.where(t < t[1500], 0.8, 0.1)  # large swings, then small ones that keep their memory
    cur = p.rated_current * (amp * np.sin(2 * np.pi * 7.0 * t) + 0.02 * rng.standard_normal(t.size))
    ys = simulate(p, cur)
    ic, h = fa.valve_memory_track(cur, DT, p.rated_current, p.hysteresis_width, p.hysteresis_reversal_slope)
    # the kernel integrates the coil pole by RK4: at the nominal 2 sub-steps per sample h a = 0.35,
    # and R(-0.35) - exp(-0.35) = 4e-5 per sub-step of the step the coil current takes
    n_sub = substeps_from_stiffness(fa.stiffness_modes(p), DT)[0]
    ha = DT / n_sub * fa.VALVE_A
    rk4_error = abs((1 - ha + ha**2 / 2 - ha**3 / 6 + ha**4 / 24) - np.exp(-ha))
    assert n_sub == 2 and rk4_error == pytest.approx(4.0e-5, rel=0.1)
    np.testing.assert_allclose(ic, ys[:-1, fa.IC], rtol=0, atol=rk4_error)
    np.testing.assert_allclose(h, ys[:-1, fa.H0:fa.H0 + fa.N_PLAY], rtol=0, atol=rk4_error)
    _, h_late = fa.valve_memory_track(cur[1500:], DT, p.rated_current, p.hysteresis_width,
                                      p.hysteresis_reversal_slope)
    big_r = pi_threshold_scale(p.hysteresis_width, p.hysteresis_reversal_slope, fa.N_PLAY)
    assert np.abs(h_late[-1] - h[-1]).max() > 0.1 * big_r


# ------------------------------------------------------------------ ZOH of eqs (7)-(8)
def _zoh(num, den):
    a, b, c, d = signal.tf2ss(num, den)
    ad, bd, cd, dd, _ = signal.cont2discrete((a, b, c, d), T, method="zoh")
    return ad, bd, cd, dd


def test_valve_continuous_model_zoh_reproduces_eq7_exactly():
    numd, dend = signal.cont2discrete(fa.valve_zoh_tf(), T, method="zoh")[:2]
    num_seed, den_seed = fa.seed_valve_tf()
    np.testing.assert_allclose(dend, den_seed, atol=1e-12)
    np.testing.assert_allclose(np.trim_zeros(numd.ravel(), "f"), np.trim_zeros(num_seed, "b")[:1].tolist() + [0.0],
                               atol=1e-12)
    assert fa.VALVE_A == pytest.approx(-math.log(0.4947) / T) and fa.VALVE_B == pytest.approx(-math.log(0.9762) / T)


def test_fluid_continuous_model_zoh_reproduces_eq8_poles_gain_and_band():
    num_c, den_c = fa.fluid_continuous_tf()
    a, b, c, d = fa.fluid_state_space()  # the kernel's realisation
    # same system as the transfer function
    w = 2 * np.pi * np.array([10.0, 300.0, 3000.0])
    h_ss = [(c @ np.linalg.solve(1j * x * np.eye(9) - a, b))[0, 0] + d[0, 0] for x in w]
    np.testing.assert_allclose(h_ss, signal.freqs(num_c, den_c, w)[1], rtol=1e-8)
    ad, bd, cd, dd, _ = signal.cont2discrete((a, b, c, d), T, method="zoh")
    poles = np.linalg.eigvals(ad)
    num_s, den_s = fa.seed_fluid_tf()
    seed_poles = np.roots(den_s)
    for z in seed_poles[np.abs(seed_poles) > 1e-6]:  # the six poles of eq (8)
        assert np.min(np.abs(poles - z)) < 1e-9
    # DC gain: 1 (eq (8) gives 1.005 from rounded coefficients)
    assert abs(np.polyval(num_c, 0) / np.polyval(den_c, 0)) == pytest.approx(1.0)
    assert np.polyval(num_s, 1) / np.polyval(den_s, 1) == pytest.approx(1.0, abs=6e-3)
    f = np.linspace(1, 500, 200)
    z = np.exp(2j * np.pi * f * T)
    hz = np.array([(cd @ np.linalg.solve(zz * np.eye(ad.shape[0]) - ad, bd))[0, 0] + dd[0, 0] for zz in z])
    hs = np.polyval(num_s, z) / np.polyval(den_s, z)
    phase = np.abs(np.angle(hz / hs, deg=True))
    mag = np.abs(np.abs(hz) / np.abs(hs) - 1)
    assert phase.max() < 3.0
    assert mag.max() < 0.18 and mag[f <= 250].max() < 0.05


# ------------------------------------------------------------------ Radau reference
def _radau_rollout(p, currents, y0, dt=DT):
    """Radau (rtol 1e-10) per control period; the guard's play update at the period's end is
    exact (the coil current is monotone within a period)."""
    pa = p.to_array()
    y = y0.copy()
    out = [y.copy()]
    for i in currents:
        u = np.array([i])

        def f(_t, s):
            dy = np.empty_like(s)
            registry.get("force_actuator").kernels.rhs(np.ascontiguousarray(s), u, pa, dy)
            return dy

        sol = solve_ivp(f, (0, dt), y, method="Radau", rtol=1e-10, atol=1e-12)
        y = sol.y[:, -1].copy()
        registry.get("force_actuator").kernels.guard(y, pa)
        out.append(y.copy())
    return np.array(out)


def test_fixed_step_kernel_matches_radau():
    p = NOMINAL
    rng = np.random.default_rng(5)
    cur = np.repeat(rng.uniform(-0.7, 0.7, 8), 25) * p.current_max
    y0 = fa.rest_state(p)
    fixed = simulate(p, cur)
    ref = _radau_rollout(p, cur, y0)
    f_fixed, f_ref = sensed(p, fixed), sensed(p, ref)
    assert np.ptp(f_ref) > 300  # a real test: hundreds of N of force swing
    err = np.sqrt(np.mean((f_fixed - f_ref) ** 2)) / np.ptp(f_ref)
    assert err < 2e-3, err
    assert np.max(np.abs(fixed[:, fa.Z] - ref[:, fa.Z])) * p.friction_stiffness < 1.0  # friction within 1 N


# ------------------------------------------------------------------ stiffness bound
def _jacobian(y, u, pa):
    J = np.empty((fa.N_STATES, fa.N_STATES))
    scale = np.maximum(np.abs(y), 1.0) * 1e-7
    scale[[fa.XS, fa.XP]] = 1e-10
    for j in range(fa.N_STATES):
        yp, ym = y.copy(), y.copy()
        yp[j] += scale[j]
        ym[j] -= scale[j]
        fp, fm = np.empty(fa.N_STATES), np.empty(fa.N_STATES)
        registry.get("force_actuator").kernels.rhs(yp, u, pa, fp)
        registry.get("force_actuator").kernels.rhs(ym, u, pa, fm)
        J[:, j] = (fp - fm) / (2 * scale[j])
    return J


def test_stiffness_bound_covers_the_numerical_jacobian(spec):
    """Every Jacobian eigenvalue is within the sub-step modes or, for the Dahl state, within the
    local bound ``4 sigma0 |v| / F_c`` that the kernels' refinement checks at the state."""
    rng = np.random.default_rng(0)
    sets = [NOMINAL, spec.corner(False), spec.corner(True), dataclasses.replace(NOMINAL, piston_locked=0.0),
            # static friction curve on a free piston with a load (the moving-piston diagnosis rig)
            dataclasses.replace(NOMINAL, piston_locked=0.0, load_mass=5.0, load_stiffness=5e4, friction_model=1.0),
            dataclasses.replace(NOMINAL, friction_model=1.0)]
    for p in sets:
        modes = max(fa.stiffness_modes(p).values())
        vb = fa.velocity_bound(p)
        pa = p.to_array()
        tightest = 0.0
        for v in (0.0, 1e-4, 0.3 * vb, -vb):
            local = 4.0 * p.friction_stiffness * abs(v) / p.coulomb_friction if p.friction_model == 0.0 else 0.0
            bound = max(modes, local)
            # friction inside its level g(v) (|u| <= 2, the domain the bound covers)
            g = fa.stiction_level(v, p.coulomb_friction, p.stiction_retract, p.stiction_extend,
                                  p.stribeck_velocity)
            for ff in (0.0, 0.7 * g, -0.99 * g):
                for ic in (0.0, 0.5, 1.2):
                    y = fa.rest_state(p)
                    y[fa.VS] = v
                    y[fa.VF] = v * rng.uniform(0, 1)
                    y[fa.Z] = ff / p.friction_stiffness
                    y[fa.IC] = ic
                    lam = np.abs(np.linalg.eigvals(_jacobian(y, np.array([ic * p.rated_current]), pa))).max()
                    assert lam <= bound * 1.02, (v, ff, ic, lam, bound)
                    tightest = max(tightest, lam / bound)
        assert tightest >= 0.3
        if p.friction_model == 0.0:  # at the velocity bound the local bound is the refinement's
            assert 4.0 * p.friction_stiffness * vb / p.coulomb_friction == pytest.approx(fa.dahl_relaxation_bound(p))
    n_sub, h, mode = substeps_from_stiffness(fa.stiffness_modes(NOMINAL), DT)
    # the family's pre-sliding bound at rest (static level 107 N) now edges past the fluid
    # resonance; the nominal plant still takes 2 sub-steps
    assert (n_sub, mode) == (2, "friction")
    assert fa.stiffness_modes(NOMINAL)["friction"] < 1.1 * fa.stiffness_modes(NOMINAL)["fluid"]
    # the refinement's sub-steps: stable for the Dahl state at the velocity bound
    m = fa.dahl_friction_refinement(NOMINAL.to_array(), h)
    assert m == 3 and h / m * fa.dahl_relaxation_bound(NOMINAL) <= 0.8 * 2.7853


def test_dahl_refinement_tests_speed_and_reversals():
    """The kernels' local test: true at rest and at low speed, false above the stable speed of a
    coarse sub-step and across a velocity reversal; always true for the static curve."""
    pa = NOMINAL.to_array()
    h = DT / 2
    y0 = fa.rest_state(NOMINAL)
    v_stable = 0.8 * 2.7853 * NOMINAL.coulomb_friction / (4.0 * NOMINAL.friction_stiffness * h)
    y = y0.copy()
    assert fa.dahl_friction_shallow(y0, y, pa, h)
    y0[fa.VS] = y[fa.VS] = 0.9 * v_stable
    assert fa.dahl_friction_shallow(y0, y, pa, h)
    y0[fa.VS] = y[fa.VS] = 1.1 * v_stable
    assert not fa.dahl_friction_shallow(y0, y, pa, h)
    y0[fa.VS], y[fa.VS] = 1e-4, -1e-4
    assert not fa.dahl_friction_shallow(y0, y, pa, h)
    static = dataclasses.replace(NOMINAL, friction_model=1.0).to_array()
    assert fa.dahl_friction_shallow(y0, y, static, h) and fa.dahl_friction_refinement(static, h) == 1


def test_dahl_substeps_follow_the_local_speed():
    """The kernels' fine-step count: 1 where the test holds; above the stable speed the count
    that takes the faster of start and Euler prediction stably with the 1.5x margin; the
    velocity bound's count across a reversal and wherever the local count would exceed it."""
    pa = NOMINAL.to_array()
    h = DT / 2
    m = fa.dahl_friction_refinement(pa, h)
    v_stable = 0.8 * 2.7853 * NOMINAL.coulomb_friction / (4.0 * NOMINAL.friction_stiffness * h)
    y0 = fa.rest_state(NOMINAL)
    x = y0.copy()
    assert fa.dahl_friction_substeps(y0, x, pa, h, m) == 1
    y0[fa.VS], x[fa.VS] = 0.9 * v_stable, 0.95 * v_stable
    assert fa.dahl_friction_substeps(y0, x, pa, h, m) == 1
    y0[fa.VS], x[fa.VS] = 1.1 * v_stable, 1.2 * v_stable
    n = fa.dahl_friction_substeps(y0, x, pa, h, m)
    assert n == 2 < m  # ceil(1.5 x 1.2)
    assert 1.5 * 1.2 * v_stable / n <= v_stable
    y0[fa.VS], x[fa.VS] = 1e-4, -1e-4
    assert fa.dahl_friction_substeps(y0, x, pa, h, m) == m
    y0[fa.VS], x[fa.VS] = 5.0 * v_stable, 5.0 * v_stable
    assert fa.dahl_friction_substeps(y0, x, pa, h, m) == m
    static = dataclasses.replace(NOMINAL, friction_model=1.0).to_array()
    assert fa.dahl_friction_substeps(y0, x, static, h, 1) == 1


def test_refined_substeps_match_uniform_fine_substeps():
    """Coarse sub-steps with local refinement against uniform sub-steps 8x finer, under a
    closed-loop-like current with reversals of the sensor mass: the sensor force agrees within
    1e-4 of its range; the fine run is itself within 1e-6 of the range of 16x finer."""
    rng = np.random.default_rng(7)
    p = NOMINAL
    t = DT * np.arange(4000)
    cur = p.rated_current * (0.5 * np.sign(np.sin(2 * np.pi * 30.0 * t)) + 0.05 * rng.standard_normal(t.size))
    n = substeps_from_stiffness(fa.stiffness_modes(p), DT)[0]
    coarse, fine, finer = (sensed(p, simulate(p, cur, n_sub=k * n)) for k in (1, 8, 16))
    span = np.ptp(finer)
    assert np.abs(fine - finer).max() < 1e-6 * span
    assert np.sqrt(np.mean((coarse - fine) ** 2)) < 1e-4 * span
    assert np.abs(coarse - fine).max() < 1e-3 * span


def test_parallel_and_serial_kernels_are_bit_identical(spec):
    rng = np.random.default_rng(1)
    params = [spec.sample(rng) for _ in range(16)]
    P = np.stack([q.to_array() for q in params])
    nsub = np.array([substeps_from_stiffness(fa.stiffness_modes(q), DT)[0] for q in params], dtype=np.int64)
    out = []
    for kernel in (registry.get("force_actuator").kernels.step_serial, registry.get("force_actuator").kernels.step_parallel):
        Y = np.stack([fa.rest_state(q) for q in params])
        W = np.zeros((16, 5, fa.N_STATES))
        c = np.zeros(16, dtype=np.int64)
        r = np.random.default_rng(2)
        for _ in range(300):
            kernel(Y, r.uniform(-0.03, 0.03, (16, 1)), P, DT, nsub, W, c)
        out.append(Y)
    assert np.array_equal(out[0], out[1])


def test_free_piston_extends_to_the_stop_at_a_damping_limited_speed():
    p = dataclasses.replace(NOMINAL, piston_locked=0.0, load_mass=0.5)
    y0 = fa.rest_state(p, x_piston=0.01)
    ys = simulate(p, np.full(2000, 0.6 * p.current_max), y0=y0)
    q = ys[:, fa.XP] + ys[:, fa.XS]
    v = ys[:, fa.VP] + ys[:, fa.VS]
    assert q[-1] == pytest.approx(p.stroke, abs=1e-4)  # reached and held by the stop
    assert q.max() < p.stroke + 1e-3
    assert 0.05 < v.max() < 1.5  # speed limited by the hydraulic damping, eq (5)
    locked = simulate(NOMINAL, np.full(200, 0.6 * p.current_max))
    assert np.all(locked[:, fa.XP] == locked[0, fa.XP])  # locked piston never moves


# ============================================================================== env
def _actions(n, seed=1):
    return np.random.default_rng(seed).uniform(-1, 1, (n, 1)).astype(np.float32)


def test_spaces_and_observation_bounds():
    assert gym.make(ENV_ID).spec.max_episode_steps == 5000
    env = gym.make(ENV_ID).unwrapped
    assert env.action_space.shape == (1,) and env.observation_space.shape == (8,)
    assert env.dt == 2e-4
    O, R, S = _rollout(env, 3, _actions(600))
    assert O.dtype == np.float32 and np.all(np.isfinite(O)) and np.all(np.isfinite(R))
    for o in O:
        assert env.observation_space.contains(o)


def test_vector_env_autoresets_after_the_episode():
    venv = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=5)
    venv.reset(seed=0)
    truncs = []
    for _ in range(6):
        _, r, term, trunc, _ = venv.step(np.zeros((2, 1), dtype=np.float32))
        truncs.append(trunc.copy())
    assert truncs[4].all() and not truncs[5].any()


def test_info_state_and_params():
    env = gym.make(ENV_ID, randomize=False)
    obs, info = env.reset(seed=0)
    assert tuple(info["state"]) == fa.STATE_NAMES
    assert info["params"] == NOMINAL.as_dict()
    _, _, _, _, info = env.step(_a(0.5))
    assert info["state"]["ic"] == 0.0  # one control period of computation delay
    _, _, _, _, info = env.step(_a(0.5))
    assert info["state"]["ic"] > 0


def test_randomisation_draws_inside_yaml_ranges(spec):
    env = gym.make(ENV_ID)
    for s in range(20):
        _, info = env.reset(seed=s)
        for e in spec.entries:
            lo, hi = e.value_range(getattr(NOMINAL, e.name))
            assert lo <= info["params"][e.name] <= hi
    assert {e.name for e in spec.entries} >= {"coulomb_friction", "stiction_retract", "stiction_extend",
                                             "damping_gain", "sensor_stiffness", "hysteresis_width"}


def test_observation_and_reward_semantics():
    env = gym.make(ENV_ID, randomize=False, error_scale=100.0, action_rate_penalty=0.5).unwrapped
    ref = np.full(6000, 300.0)
    obs, _ = env.reset(seed=0, options={"reference": ref})
    assert obs[1] == pytest.approx(300 / 1340) and np.allclose(obs[2:7], 300 / 1340)
    obs, r, _, _, info = env.step(_a(0.4))
    assert env.channel_values()["i"] == 0.0  # the command waits one control period
    obs, r, _, _, info = env.step(_a(0.4))
    fs = NOMINAL.sensor_stiffness * info["state"]["xs"]
    assert obs[0] == pytest.approx(info["state"]["fm"] / 1340, rel=1e-5)  # measured: conditioned
    assert abs(info["state"]["fm"]) < abs(fs)  # the conditioning filter lags the true force
    assert obs[7] == pytest.approx(0.4)
    assert r == pytest.approx(-((300 - fs) / 100) ** 2, rel=1e-6)  # reward on the true force
    assert env.channel_values()["i"] == pytest.approx(0.4 * NOMINAL.current_max)


def test_closed_loop_tracks_the_papers_square_waves():
    from hydro_envs.plants.force_actuator.closed_loop import proportional_loop

    t = DT * np.arange(2500)
    ref = np.stack([a * np.where((10 * t) % 1 < 0.5, 1.0, -1.0) for a in (50, 200, 800)])
    out, vmax = proportional_loop(NOMINAL, ref, 2.44)
    for j in range(3):
        seg = out[j, 400:500]  # end of the second half period (reference -A)
        r = ref[j, 450]
        assert np.sign(seg.mean()) == np.sign(r) and 0.7 * abs(r) < abs(seg.mean()) <= 1.02 * abs(r)
    assert vmax.max() < fa.LOCKED_VELOCITY_BOUND  # inside the friction stiffness bound


def test_reset_options_free_piston_and_errors():
    env = gym.make(ENV_ID, randomize=False).unwrapped
    env.reset(seed=0, options={"params": {"piston_locked": 0.0}, "state": {"xp": 0.02}})
    for _ in range(300):
        _, _, _, _, info = env.step(_a(0.6))
    assert info["state"]["xp"] > 0.03
    with pytest.raises(ValueError):
        env.reset(options={"reference": np.full(10, 5000.0)})
    with pytest.raises(ValueError):
        env.reset(options={"bogus": 1})
    with pytest.raises(ValueError):
        env.step(_a(float("nan")))


@pytest.mark.parametrize("kind", ["square", "sine", "chirp", "steps"])
def test_reference_kinds_stay_in_the_feasible_band(kind):
    env = gym.make(ENV_ID, reference=kind).unwrapped
    for s in range(5):
        env.reset(seed=s)
        ref = env._batch.REF[0]
        p = env.params
        assert ref.min() >= 0.85 * p.min_thrust - 1e-9 and ref.max() <= 0.85 * p.max_thrust + 1e-9


def test_guards_hold_over_long_random_rollouts_at_randomisation_extremes(spec):
    rng = np.random.default_rng(7)
    corners = [spec.corner(False), spec.corner(True)] + [
        spec.corner(list(rng.integers(0, 2, len(spec.entries)).astype(bool))) for _ in range(2)]
    env = gym.make(ENV_ID, randomize=False).unwrapped
    for c in corners:
        env.reset(seed=1, options={"params": c.as_dict()})
        acts = np.repeat(rng.choice([-1.0, 1.0, 0.0, 0.3], 250), 20).astype(np.float32)
        fs, ff = [], []
        for a in acts:
            obs, r, _, _, info = env.step(_a(a))
            assert np.all(np.isfinite(obs)) and math.isfinite(r)
            fs.append(c.sensor_stiffness * info["state"]["xs"]), ff.append(c.friction_stiffness * info["state"]["z"])
        fs, ff = np.array(fs), np.array(ff)
        g_hi = max(c.stiction_retract, c.stiction_extend)
        assert np.all(np.abs(ff) <= g_hi + 1e-9)
        # sensed force stays within the blocked-force range plus a bounded dynamic overshoot
        assert fs.max() < 1.5 * c.max_thrust and fs.min() > 1.5 * c.min_thrust
        assert np.ptp(fs) > c.max_thrust  # the bang-bang really crossed the range
        assert env.guard_clamps <= 0.01 * len(acts) * env.n_substeps


def test_render_rgb_array():
    env = gym.make(ENV_ID, render_mode="rgb_array", randomize=False)
    env.reset(seed=0)
    f0 = env.render()
    for _ in range(100):
        env.step(_a(1.0))
    f1 = env.render()
    assert f0.dtype == np.uint8 and f0.shape == f1.shape and not np.array_equal(f0, f1)


# ------------------------------------------------------------------ validation rows
def test_validation_rows_are_finite_and_the_sensor_rows_pass():
    """Which rows pass is asserted for the whole report in test_validation_report.py."""
    rows = fa_validation.rows()
    names = [r.name for r in rows]
    assert any("eq (4)" in n for n in names) and any("Table 1" in n for n in names)
    for r in rows:
        assert math.isfinite(r.reproduced), r.name
        if "vs Table 1" in r.name:
            expected = "table"  # eq (4) against Table 1: two printed numbers
        elif "calibrates" in r.name or "vs eq (4)" in r.name or "-6 dB" in r.name:
            expected = "consistency"  # the model's own inputs or a number a constant is set on
        else:
            expected = "independent"
        assert r.kind == expected, r.name
        if "sensor" in r.name:
            assert r.passed, (r.name, r.published, r.reproduced, r.tolerance)


def test_seed_arx_loop_has_its_6db_bandwidth_close_to_its_3db_one():
    """The argument of the -3 dB row: eq (6) under proportional feedback crosses -180 deg near
    156 Hz, and at 0.3-2/3 of its critical gain its -6 dB bandwidth is 1.1-1.3 times the -3 dB
    one (so 001's low-amplitude -6 dB of 196 Hz puts that amplitude's -3 dB well above 100 Hz).
    Checked against a direct evaluation of the polynomials on the unit circle."""
    a, b = np.array(fa_validation.SEED_ARX_A), np.array(fa_validation.SEED_ARX_B)
    f = np.linspace(1.0, 1000.0, 200000)
    zi = np.exp(-2j * np.pi * f * fa.SEED_T)
    p = -np.polyval(b[::-1], zi) / np.polyval(a[::-1], zi)
    j = np.flatnonzero((np.sign(p.imag[:-1]) != np.sign(p.imag[1:])) & (p.real[:-1] < 0))[0]
    assert 150.0 < f[j] < 162.0
    for frac in fa_validation.ARX_GAIN_FRACTIONS:
        _, b3, b6 = fa_validation.seed_arx_loop_bandwidths(frac)
        k = -frac / p.real[j]
        t = k * p / (1 + k * p)
        db = 20 * np.log10(np.abs(t) / abs(t[0]))
        assert b3 == pytest.approx(f[np.flatnonzero(db < -3)[0]], rel=0.01)
        assert b6 == pytest.approx(f[np.flatnonzero(db < -6)[0]], rel=0.01)
        assert 1.1 < b6 / b3 < 1.3


def test_limit_cycle_frequency_comes_from_zero_crossings():
    """The limit-cycle frequency estimate resolves better than the 10 Hz of an FFT over the
    0.1 s window: a 95 Hz sine (any phase) with an offset and a little noise reads 95 +- 0.5 Hz."""
    rng = np.random.default_rng(0)
    t = fa.SEED_T * np.arange(500)
    for phase in (0.0, 1.0, 2.5):
        x = 40.0 * np.sin(2 * np.pi * 95.0 * t + phase) + 0.3 * rng.standard_normal(t.size)
        assert closed_loop._crossing_frequency(x - x.mean(), fa.SEED_T) == pytest.approx(95.0, abs=0.5)
    assert math.isnan(closed_loop._crossing_frequency(np.ones(50), fa.SEED_T))


def test_env_applies_each_command_control_delay_later():
    """The valve current of step k is the action of step k - d (d = control_delay / dt), also
    for a copy reset in the middle of a run, whose pending commands start at zero."""
    import gymnasium as gym

    from hydro_envs.envs.force_actuator import DT
    from hydro_envs.plants.force_actuator.model import I_IMAX

    d = 3
    venv = gym.make_vec("hydro_envs/ForceActuator-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        params={"control_delay": d * DT}, randomize=False)
    venv.reset(seed=0)
    b = venv.unwrapped._batch if hasattr(venv, "unwrapped") else venv._batch
    imax = float(b.P[0, I_IMAX])
    rng = np.random.default_rng(1)
    sent: list[np.ndarray] = []
    for k in range(60):  # longer than the buffer (MAX_DELAY_STEPS + 1 = 51 slots)
        if k == 40:
            venv.reset(options={"reset_mask": np.array([False, True])})
            sent = [np.array([s[0], 0.0]) for s in sent]  # copy 1 forgets its pending commands
        a = rng.uniform(-1, 1, (2, 1)).astype(np.float32)
        venv.step(a)
        sent.append(a[:, 0].astype(np.float64))
        want = sent[-1 - d] * imax if len(sent) > d else np.zeros(2)
        np.testing.assert_allclose(b.U[:, 0], want, rtol=0, atol=1e-12 * imax)
