"""Physics of the seed-002 servo cylinder and the fixed-step kernel, checked against
independent truths: conservation laws, a stiff Radau reference, the analytic orifice law,
the numerical Jacobian, and the guards' physical invariants."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydro_envs.params import ParameterError
from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.randomization import load_randomization
from hydro_envs import registry
from hydro_envs.sim.reference import reference_rollout
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, RK4_REAL_STABILITY_LIMIT, rk4_amplification, substeps_from_stiffness

DT = 1e-3
ATOL = np.array([1e-13, 1e-10, 1e-3, 1e-3, 1e-15, 1e-11, 1e-15])


def simulate(params: ServoCylinderParams, y0, commands, n_sub: int, dt: float = DT) -> np.ndarray:
    """Fixed-step kernel rollout under per-step commands [V]; returns (n+1, 6) states."""
    Y = np.array(y0, dtype=float)[None, :].copy()
    P = params.to_array()[None, :]
    W = np.zeros((1, 5, sc.N_STATES))
    clamps = np.zeros(1, dtype=np.int64)
    nsub = np.array([n_sub], dtype=np.int64)
    out = np.empty((len(commands) + 1, sc.N_STATES))
    out[0] = Y[0]
    U = np.zeros((1, 1))
    for k, u in enumerate(commands):
        U[0, 0] = u
        registry.get("servo_cylinder").kernels.step_serial(Y, U, P, dt, nsub, W, clamps)
        out[k + 1] = Y[0]
    return out


def rest_state(p: ServoCylinderParams, x: float, v: float = 0.0) -> np.ndarray:
    y = np.zeros(sc.N_STATES)
    y[sc.X] = x
    y[sc.V] = v
    y[sc.P1] = y[sc.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
    return y


def random_step_commands(rng: np.random.Generator, n: int, hold: int, u_max: float) -> np.ndarray:
    levels = rng.uniform(-u_max, u_max, n // hold + 1)
    return np.repeat(levels, hold)[:n]


def nrmse(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - ref) ** 2)) / (ref.max() - ref.min()))


# ------------------------------------------------------------------------- parameters
def test_nominal_parameters_are_table_1():
    p = ServoCylinderParams()
    assert p.mass == 12.3 and p.piston_area == pytest.approx(6.63e-4)
    assert p.stroke == pytest.approx(0.0696) and p.line_volume_1 == pytest.approx(88.7e-6)
    assert p.bulk_modulus == pytest.approx(689e6) and p.oil_density == 847.0
    assert p.valve_natural_frequency == pytest.approx(2 * np.pi * 175)
    # K_v = C_v sqrt(2/rho) = 2.92e-2 m^1.5/sqrt(kg) (Table 1)
    assert p.discharge_coefficient * np.sqrt(2 / p.oil_density) == pytest.approx(2.92e-2, rel=2e-3)
    # x_vm = k_v * 10 V (Table 1: 0.0279 mm/V, 0.279 mm)
    assert p.spool_gain * p.command_max == pytest.approx(p.spool_stroke)


@pytest.mark.parametrize(
    "field,value,fragment",
    [("mass", -1.0, "mass"), ("stroke", 0.0, "stroke"), ("bulk_modulus", float("nan"), "bulk_modulus"),
     ("discharge_coefficient", 1.5, "discharge_coefficient")],
)
def test_invalid_parameter_names_field_and_range(field, value, fragment):
    with pytest.raises(ParameterError) as exc:
        ServoCylinderParams(**{field: value})
    msg = str(exc.value)
    assert fragment in msg and "allowed range" in msg


def test_cross_field_relations_are_checked():
    with pytest.raises(ParameterError, match="static_friction"):
        ServoCylinderParams(coulomb_friction=80.0, static_friction=60.0)
    with pytest.raises(ParameterError, match="pressure_floor"):
        ServoCylinderParams(tank_pressure=5e5, supply_pressure=4e5)


# ------------------------------------------------------------------- conservation laws
def _conservative(p: ServoCylinderParams) -> ServoCylinderParams:
    """Valve closed, friction and load off: a lossless mass on two oil springs."""
    return dataclasses.replace(
        p, coulomb_friction=0.0, static_friction=0.0, viscous_friction=0.0, load_force=0.0
    )


def test_energy_conserved_with_valve_closed_and_no_friction():
    p = _conservative(ServoCylinderParams())
    y0 = rest_state(p, x=0.5 * p.stroke, v=0.2)  # 0.3 mm oscillation, far from the stops
    # h = 50 us: RK4's energy error per oscillation scales as (omega h)^6 (see below)
    ys = simulate(p, y0, np.zeros(1000), n_sub=20)
    e = sc.closed_valve_energy(ys, p, y0)
    e0 = 0.5 * p.mass * 0.2**2
    assert np.max(np.abs(e - e0)) / e0 <= 1e-6
    # the energy really moves between the mass and the oil (the test is not vacuous)
    assert np.min(0.5 * p.mass * ys[:, sc.V] ** 2) < 1e-3 * e0


def test_energy_error_converges_at_rk4_rate():
    p = _conservative(ServoCylinderParams())
    y0 = rest_state(p, x=0.5 * p.stroke, v=0.2)
    e0 = 0.5 * p.mass * 0.2**2
    drift = []
    for n_sub in (2, 4):
        ys = simulate(p, y0, np.zeros(300), n_sub=n_sub)
        drift.append(np.max(np.abs(sc.closed_valve_energy(ys, p, y0) - e0)) / e0)
    # RK4's amplitude error on an oscillator is O((omega h)^6) per step, O(h^5) over a
    # fixed time: halving h must shrink the drift by ~32 (>= 16 allows for the nonlinearity)
    assert drift[0] / drift[1] >= 16


def test_oil_mass_conserved_in_closed_chambers():
    p = _conservative(ServoCylinderParams())
    y0 = rest_state(p, x=0.3 * p.stroke, v=0.3)
    ys = simulate(p, y0, np.zeros(500), n_sub=10)
    # constant-beta liquid: rho = rho0 exp(p / beta); oil mass rho V in each sealed chamber
    v1 = p.piston_area * ys[:, sc.X] + p.line_volume_1
    v2 = p.piston_area * (p.stroke - ys[:, sc.X]) + p.line_volume_2
    m1 = v1 * np.exp(ys[:, sc.P1] / p.bulk_modulus)
    m2 = v2 * np.exp(ys[:, sc.P2] / p.bulk_modulus)
    assert np.max(np.abs(m1 / m1[0] - 1)) < 1e-9
    assert np.max(np.abs(m2 / m2[0] - 1)) < 1e-9
    assert np.ptp(ys[:, sc.P1]) > 1e5  # pressures did change


# ----------------------------------------------------------------- orifice-law truth
def test_steady_velocity_matches_orifice_law_with_friction_load():
    p = ServoCylinderParams()
    y0 = rest_state(p, x=0.002)
    ys = simulate(p, y0, np.full(120, p.command_max), n_sub=3)
    window = (ys[:, sc.X] > 0.3 * p.stroke) & (ys[:, sc.X] < 0.7 * p.stroke)
    idx = np.flatnonzero(window)
    v_sim = (ys[idx[-1], sc.X] - ys[idx[0], sc.X]) / ((idx[-1] - idx[0]) * DT)
    # steady state: A (p1 - p2) = F_f(v) = F_C + d v (v >> v_S); with matched orifices
    # Q = K w x_vm sqrt(dp_edge), dp_edge = (p_s - p_R - dp_load)/2  ->  solve for v
    from scipy.optimize import brentq

    def residual(v):
        dp_load = (p.coulomb_friction + (p.static_friction - p.coulomb_friction) * np.exp(-v / p.stribeck_velocity)
                   + p.viscous_friction * v) / p.piston_area
        q = p.discharge_coefficient * p.area_gradient * p.spool_stroke * np.sqrt(
            2 / p.oil_density * (p.supply_pressure - p.tank_pressure - dp_load) / 2)
        return q / p.piston_area - v

    v_true = brentq(residual, 0.1, 1.0)
    assert v_sim == pytest.approx(v_true, rel=5e-3)
    # and the frictionless orifice-law speed of the validate row is about 0.66-0.67 m/s
    assert sc.no_load_velocity(p) == pytest.approx(0.669, abs=2e-3)


# ------------------------------------------------------------------ reference solver
def _random_step_case(seconds: float, seed: int = 3):
    p = ServoCylinderParams()
    rng = np.random.default_rng(seed)
    n = int(round(seconds / DT))
    cmds = random_step_commands(rng, n, hold=150, u_max=p.command_max)
    y0 = rest_state(p, x=0.5 * p.stroke)
    return p, y0, cmds


def _compare_with_radau(seconds: float) -> tuple[float, float, float, int]:
    p, y0, cmds = _random_step_case(seconds)
    n_sub = substeps_from_stiffness(sc.stiffness_modes(p), DT)[0]
    fixed = simulate(p, y0, cmds, n_sub=n_sub)
    ref = reference_rollout(registry.get("servo_cylinder"), y0, cmds[:, None], p.to_array(), DT, rtol=1e-10, atol=ATOL)
    # the case must really hit both stops, or it does not test the contact
    hits = (ref[:, sc.X] > p.stroke).any() and (ref[:, sc.X] < 0).any()
    pressure = max(nrmse(fixed[:, sc.P1], ref[:, sc.P1]), nrmse(fixed[:, sc.P2], ref[:, sc.P2]))
    return nrmse(fixed[:, sc.X], ref[:, sc.X]), pressure, hits, n_sub


def test_fixed_step_matches_radau_with_end_stop_contact_short():
    pos, pres, hits, n_sub = _compare_with_radau(0.6)
    assert hits
    assert n_sub == 2
    assert pos <= 1e-4 and pres <= 1e-3


@pytest.mark.slow
def test_fixed_step_matches_radau_with_end_stop_contact_2s():
    pos, pres, hits, _ = _compare_with_radau(2.0)
    assert hits
    assert pos <= 1e-4 and pres <= 1e-3


def test_rk4_converges_at_fourth_order_on_smooth_motion():
    p = ServoCylinderParams()
    y0 = rest_state(p, x=0.5 * p.stroke)
    t = DT * np.arange(150)
    cmds = 2.0 * np.sin(2 * np.pi * 8 * t)  # +-2 V: stays clear of the stops
    ref = reference_rollout(registry.get("servo_cylinder"), y0, cmds[:, None], p.to_array(), DT, rtol=1e-11, atol=ATOL)
    errs = [np.max(np.abs(simulate(p, y0, cmds, n)[:, sc.P1] - ref[:, sc.P1])) for n in (4, 8)]
    assert errs[0] / errs[1] >= 10  # 2^4 = 16 in the asymptotic range


# ------------------------------------------------------------------- stiffness bound
def numerical_jacobian(y, u, p_arr):
    n = sc.N_STATES
    J = np.empty((n, n))
    scale = np.array([1e-7, 1e-6, 1.0, 1.0, 1e-9, 1e-7, 1e-10])
    for j in range(n):
        yp, ym = y.copy(), y.copy()
        yp[j] += scale[j]
        ym[j] -= scale[j]
        fp, fm = np.empty(n), np.empty(n)
        registry.get("servo_cylinder").kernels.rhs(yp, u, p_arr, fp)
        registry.get("servo_cylinder").kernels.rhs(ym, u, p_arr, fm)
        J[:, j] = (fp - fm) / (2 * scale[j])
    return J


def test_stiffness_bound_covers_the_numerical_jacobian():
    spec = load_randomization("servo_cylinder", ServoCylinderParams)
    rng = np.random.default_rng(0)
    sets = [ServoCylinderParams(), spec.corner(False), spec.corner(True)] + [
        spec.corner(rng.integers(0, 2, len(spec.entries)).astype(bool)) for _ in range(4)
    ]
    for p in sets:
        bound = max(sc.stiffness_modes(p).values())
        pa = p.to_array()
        worst = 0.0
        ps, pt, L = p.supply_pressure, p.tank_pressure, p.stroke
        pen = p.piston_area * ps / p.stop_stiffness
        z_max = sc.friction_bounds(p)["z_max"]
        # states that stress each mode: zero velocity (the seals' pre-sliding), speed (the
        # bristles' relaxation, capped), zero orifice drop, stop contact
        for x in (0.0, 1e-4, 0.5 * L, L - 1e-4, L + pen):
            for v, z in ((0.0, 0.0), (2e-5, z_max), (-0.02, -0.5 * z_max), (-0.3, z_max), (0.6, -z_max)):
                for p1, p2 in ((0.5 * (ps + pt), 0.5 * (ps + pt)), (ps, pt), (pt + 1.0, ps - 1.0)):
                    for xv in (0.0, p.spool_stroke, -p.spool_stroke):
                        y = np.array([x, v, p1, p2, xv, 0.0, z])
                        lam = np.abs(np.linalg.eigvals(numerical_jacobian(y, np.array([0.0]), pa)))
                        worst = max(worst, lam.max())
        assert worst <= bound * 1.02, (worst, bound)
        assert worst >= 0.3 * bound  # the bound is not uselessly loose


def test_substep_choice_is_stable_for_every_randomised_corner():
    spec = load_randomization("servo_cylinder", ServoCylinderParams)
    for flags in (False, True):
        p = spec.corner(flags)
        n_sub, h, _ = substeps_from_stiffness(sc.stiffness_modes(p), DT)
        assert h * max(sc.stiffness_modes(p).values()) <= DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT + 1e-12
    assert abs(rk4_amplification(-RK4_REAL_STABILITY_LIMIT)) == pytest.approx(1.0, abs=1e-12)
    # inside the bound a real mode decays monotonically (no chatter): 0 < R < 1
    for z in np.linspace(-DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT, -1e-3, 50):
        assert 0.0 < rk4_amplification(z).real < 1.0


# ------------------------------------------------------------------------------ guards
def test_cavitation_floor_holds_and_is_needed():
    """Closed valve, piston thrown at 3 m/s: the expanding chamber would fall below vacuum."""
    p = dataclasses.replace(ServoCylinderParams(), coulomb_friction=0.0, static_friction=0.0)
    v0 = 3.0
    y0 = rest_state(p, x=0.5 * p.stroke, v=v0)
    # linear oil spring: amplitude v0/omega, pressure swing beta A amplitude / V; it far
    # exceeds the 7 MPa available above vacuum, so without the floor p would go negative
    omega = sc.hydraulic_natural_frequency(p, 0.5 * p.stroke)
    swing = p.bulk_modulus * p.piston_area * (v0 / omega) / (p.piston_area * 0.5 * p.stroke + p.line_volume_1)
    assert swing > 0.5 * (p.supply_pressure + p.tank_pressure)
    Y = y0[None, :].copy()
    P = p.to_array()[None, :]
    W = np.zeros((1, 5, sc.N_STATES))
    clamps = np.zeros(1, dtype=np.int64)
    nsub = np.array([3])
    lowest = np.inf
    for _ in range(200):
        registry.get("servo_cylinder").kernels.step_serial(Y, np.zeros((1, 1)), P, DT, nsub, W, clamps)
        lowest = min(lowest, Y[0, sc.P1], Y[0, sc.P2])
    assert lowest >= p.pressure_floor
    assert lowest == pytest.approx(p.pressure_floor, abs=1.0)  # the floor was reached


def test_end_stop_force_is_continuous_and_never_pulls():
    from hydro_envs.laws.contact import end_stop_force

    k, alpha, L = 1e8, 2.0, 0.07
    assert end_stop_force(L, 0.5, 0.0, L, k, alpha) == 0.0
    assert abs(end_stop_force(L + 1e-12, 0.5, 0.0, L, k, alpha)) < 1e-3  # continuous at contact
    assert end_stop_force(-1e-5, -0.2, 0.0, L, k, alpha) > 0  # pushes out of the lower stop
    assert end_stop_force(L + 1e-5, 0.2, 0.0, L, k, alpha) < 0
    # leaving the stop fast: damping would pull, the clip keeps it at zero
    assert end_stop_force(-1e-5, 5.0, 0.0, L, k, alpha) == 0.0
    assert end_stop_force(L + 1e-5, -5.0, 0.0, L, k, alpha) == 0.0


def test_stop_holds_full_thrust_within_static_penetration():
    p = ServoCylinderParams()
    ys = simulate(p, rest_state(p, 0.5 * p.stroke), np.full(400, p.command_max), n_sub=3)
    pen_static = p.piston_area * (p.supply_pressure - p.tank_pressure) / p.stop_stiffness
    assert ys[-1, sc.X] - p.stroke == pytest.approx(pen_static, rel=0.05)
    assert ys[:, sc.X].max() - p.stroke < 3 * pen_static  # impact overshoot bounded
    assert ys[-1, sc.P1] == pytest.approx(p.supply_pressure, rel=1e-3)  # stalled: p1 -> p_s
    assert ys[-1, sc.P2] == pytest.approx(p.tank_pressure, abs=2e3)


def test_parallel_and_serial_kernels_are_bit_identical():
    spec = load_randomization("servo_cylinder", ServoCylinderParams)
    rng = np.random.default_rng(1)
    n = 64
    params = [spec.sample(rng) for _ in range(n)]
    P = np.stack([q.to_array() for q in params])
    Y0 = np.stack([rest_state(q, rng.uniform(0.2, 0.8) * q.stroke) for q in params])
    nsub = np.array([substeps_from_stiffness(sc.stiffness_modes(q), DT)[0] for q in params], dtype=np.int64)
    out = []
    for kernel in (registry.get("servo_cylinder").kernels.step_serial, registry.get("servo_cylinder").kernels.step_parallel):
        Y = Y0.copy()
        W = np.zeros((n, 5, sc.N_STATES))
        c = np.zeros(n, dtype=np.int64)
        rng_u = np.random.default_rng(2)
        for _ in range(200):
            kernel(Y, rng_u.uniform(-10, 10, (n, 1)), P, DT, nsub, W, c)
        out.append(Y)
    assert np.array_equal(out[0], out[1])


def test_minimum_chamber_volume_guard_keeps_derivatives_finite():
    """A plant with almost no dead volume pushed into the lower stop: A x + V1 < 0."""
    p = dataclasses.replace(ServoCylinderParams(), line_volume_1=2e-7, line_volume_2=2e-7,
                            min_chamber_volume=1e-7)
    x = -1e-3  # 1 mm penetration (far beyond what the stop allows) -> A x + V1 = -4.6e-7 m^3
    assert p.piston_area * x + p.line_volume_1 < 0
    y = np.array([x, -0.01, 2e6, 2e6, 0.0, 0.0, 0.0])
    dy = np.empty(sc.N_STATES)
    registry.get("servo_cylinder").kernels.rhs(y, np.array([0.0]), p.to_array(), dy)
    assert np.all(np.isfinite(dy))
    # chamber 1 is being compressed (v < 0, valve closed): its pressure must rise at the
    # rate of the guarded volume, beta / V_min * A |v|
    assert dy[sc.P1] == pytest.approx(p.bulk_modulus / p.min_chamber_volume * p.piston_area * 0.01)
