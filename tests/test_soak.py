"""Soak of every environment: a short version of ``bench/soak.py`` runs here.

Every env is driven with random and bang-bang actions at the corners of its randomisation
ranges and beyond them; no NaN/inf, guard breach, stroke breach, energy creation or
non-passive dissipation may occur (:mod:`hydro_envs.sim.soak`). The checks themselves are
tested to fail on states and parameters that violate them.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import hydro_envs  # noqa: F401
from hydro_envs.plants.force_actuator import model as fa
from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs import soak
from hydro_envs import registry
from hydro_envs.sim.stiffness import substeps_from_stiffness

SHORT_STEPS = 48_000


@pytest.mark.parametrize("env_id", soak.SOAK_ENVS)
def test_short_soak_has_no_breach(env_id):
    """No breach of any kind, the physical bounds included: every hydraulic chamber below its
    relief's full-flow pressure (+ RELIEF_TOL), every pneumatic chamber above 250 K
    (MIN_TEMPERATURE) and its isentropic floor."""
    r = soak.soak_env(env_id, SHORT_STEPS, num_envs=24, seed=11, episode_steps=250)
    assert r.steps >= SHORT_STEPS
    assert r.draws["corner"] > 0 and r.draws["beyond"] > 0  # both kinds of extreme draws ran
    assert r.breaches == 0, (r.counts, r.examples)
    model = registry.spec_for_env(env_id).contract
    if model.relief_bounds is not None:  # the bound was checked and met
        assert 0.3 < r.max_pressure_ratio <= 1.0 + soak.RELIEF_TOL, r.max_pressure_ratio
    if model.soak_temperatures is not None:
        assert soak.MIN_TEMPERATURE <= r.min_temperature < 300.0 and r.cold_steps == 0, r.min_temperature


@pytest.mark.slow
@pytest.mark.parametrize("env_id", soak.SOAK_ENVS)
def test_long_soak_has_no_breach(env_id):
    r = soak.soak_env(env_id, 1_000_000, num_envs=256, seed=5)
    assert r.breaches == 0, (r.counts, r.examples)


def test_soak_covers_every_registered_env():
    plants = {spec.name for spec, _ in registry.env_entries()}
    assert {registry.spec_for_env(e).name for e in soak.SOAK_ENVS} == plants and len(soak.SOAK_ENVS) == 6


# ------------------------------------------------------------------ the checks can fail
def _servo_batch(params, y0, nsub=None):
    P = params.to_array()[None, :]
    Y0 = np.asarray(y0, dtype=float)[None, :]
    n_sub = substeps_from_stiffness(sc.stiffness_modes(params), 1e-3)[0] if nsub is None else nsub
    return P, Y0, np.array([n_sub], dtype=np.int64)


def _replay(P, Y0, NSUB, u=0.0):
    U = np.array([[u]])
    W = np.zeros((1, 5, sc.N_STATES))
    Yend = np.empty_like(Y0)
    out = np.zeros((1, 7))
    registry.get("servo_cylinder").module("energy").energy_replay(Y0, U, P, 1e-3, NSUB, W, Yend, out)
    # the replay is the env kernel's integration, bit for bit
    Yk = Y0.copy()
    registry.get("servo_cylinder").kernels.step_parallel(Yk, U, P, 1e-3, NSUB, np.zeros_like(W), np.zeros(1, dtype=np.int64))
    assert np.array_equal(Yk, Yend)
    return out[0], Yend[0]


def _window_excess(outs):
    outs = np.asarray(outs)
    scale = max(np.abs(outs[:, 0]).max(), np.abs(outs[:, 1]).max())
    return soak.energy_excess(outs[0, 0], outs[-1, 1], outs[:, 2].sum(), outs[:, 4].sum(), scale)


def test_energy_check_passes_a_stop_impact_at_the_stiffness_bound_substeps():
    p = dataclasses.replace(sc.ServoCylinderParams(), stop_stiffness=1e10)
    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    P, Y0, NSUB = _servo_batch(p, [p.stroke - 1e-4, 0.5, pm, pm, 0.0, 0.0, 0.0])
    outs = []
    for _ in range(soak.ENERGY_WINDOW):  # into the stop, bounce, out
        o, y = _replay(P, Y0, NSUB, u=5.0)
        assert o[5] == 0  # passive
        outs.append(o)
        Y0 = y[None, :].copy()
    assert np.array(outs)[:, 6].any()  # the stop was engaged
    assert _window_excess(outs) <= 1.0


def test_energy_check_fails_when_the_stop_is_integrated_outside_rk4_stability():
    """One RK4 step of 1 ms on a 1e11 N/m stop (h sqrt(k/m) = 90): energy is created."""
    p = dataclasses.replace(sc.ServoCylinderParams(), stop_stiffness=1e11)
    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    P, Y0, NSUB = _servo_batch(p, [p.stroke + 1e-6, 0.3, pm, pm, 0.0, 0.0, 0.0], nsub=1)
    o, _ = _replay(P, Y0, NSUB)
    assert _window_excess([o]) > 1e3


def test_passivity_check_fails_on_a_friction_that_pushes():
    """A viscous coefficient written negative into the kernel's parameter array (the dataclass
    would refuse it) and, apart, a micro-damping held constant at speed (the fading the law
    needs to stay dissipative switched off): the friction power, less the bristles' stored
    energy rate, is negative at every stage."""
    p = sc.ServoCylinderParams()
    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    z_ss = p.coulomb_friction / p.bristle_stiffness
    P, Y0, NSUB = _servo_batch(p, [0.03, 0.05, pm, pm, 0.0, 0.0, z_ss])
    o, _ = _replay(P, Y0, NSUB)
    assert o[5] == 0
    pushing = P.copy()
    pushing[0, sc.I_D] = -5000.0  # -12.5 W at 50 mm/s against the 2 W the Coulomb level takes
    o, _ = _replay(pushing, Y0, NSUB)
    assert o[5] == NSUB[0]  # every sub-step has negative-power stages
    # just after breakaway the bristles hold F_S at a speed whose level is F_C: a constant
    # micro-damping returns more than they release
    Y1 = Y0.copy()
    Y1[0, sc.Z] = p.static_friction / p.bristle_stiffness
    Y1[0, sc.V] = 0.05
    assert _replay(P, Y1, NSUB)[0][5] == 0
    constant = P.copy()
    constant[0, sc.I_DFADE] = 1e3
    assert _replay(constant, Y1, NSUB)[0][5] > 0


@pytest.mark.parametrize("friction_model", [0.0, 1.0])
def test_force_actuator_free_piston_balance_and_static_friction_passivity(friction_model):
    """Free piston driven at full current into a stop, with the Dahl state (a port) or the
    static friction curve (a dissipative element): no energy created over the window; the
    static curve with negative levels is caught as non-passive."""
    p = dataclasses.replace(fa.ForceActuatorParams(), piston_locked=0.0, load_mass=0.5,
                            friction_model=friction_model)
    n_sub = substeps_from_stiffness(fa.stiffness_modes(p), 2e-4)[0]
    P = p.to_array()[None, :]
    Y0 = fa.rest_state(p)[None, :]
    U = np.array([[p.rated_current]])
    W = np.zeros((1, 5, fa.N_STATES))
    NSUB = np.array([n_sub], dtype=np.int64)
    outs = []
    for _ in range(200):  # 40 ms
        Yend = np.empty_like(Y0)
        out = np.zeros((1, 7))
        registry.get("force_actuator").module("energy").energy_replay(Y0, U, P, 2e-4, NSUB, W, Yend, out)
        assert out[0, 5] == 0
        outs.append(out[0])
        Y0 = Yend
    assert abs(Y0[0, fa.XP] - 0.5 * p.stroke) > 1e-3  # the piston moved
    outs = np.array(outs)
    for k in range(0, len(outs), soak.ENERGY_WINDOW):
        assert _window_excess(outs[k:k + soak.ENERGY_WINDOW]) <= 1.0
    if friction_model == 1.0:
        P[0, fa.I_FC] = P[0, fa.I_FSR] = P[0, fa.I_FSE] = -30.0
        Y0[0, fa.VP] = 0.05
        out = np.zeros((1, 7))
        registry.get("force_actuator").module("energy").energy_replay(Y0, U, P, 2e-4, NSUB, W, np.empty_like(Y0), out)
        assert out[0, 5] > 0


def test_state_checks_fail_on_breached_states():
    p = sc.ServoCylinderParams()
    P = p.to_array()[None, :]
    pm = 0.5 * (p.supply_pressure + p.tank_pressure)
    flags = np.zeros((1, 2), dtype=np.int64)
    run = np.zeros((1, 6))
    ok = np.array([[0.03, 0.1, pm, pm, 0.0, 0.0]])
    registry.get("servo_cylinder").module("energy").state_breaches(ok, P, run, flags)
    assert flags.tolist() == [[0, 0]]
    below = ok.copy()
    below[0, sc.P2] = 0.5 * p.pressure_floor
    registry.get("servo_cylinder").module("energy").state_breaches(below, P, run, flags)
    assert flags.tolist() == [[1, 0]]
    nan = ok.copy()
    nan[0, sc.P1] = math.nan
    registry.get("servo_cylinder").module("energy").state_breaches(nan, P, run, flags)
    assert flags[0, 0] == 1
    # penetration: running maxima v = 0.1 m/s, F = 0 N (p1 = p2, no load) -> tolerance
    # 2 (2 F/k + v sqrt(m/k)) = 0.2 sqrt(m/k) = 70 nm
    run[:] = 0.0
    tol = 2.0 * 0.1 * math.sqrt(p.mass / p.stop_stiffness)
    inside = ok.copy()
    inside[0, sc.X] = p.stroke + 0.9 * tol
    registry.get("servo_cylinder").module("energy").state_breaches(inside, P, run, flags)
    assert flags.tolist() == [[0, 0]]
    out = ok.copy()
    out[0, sc.X] = p.stroke + 1.1 * tol
    registry.get("servo_cylinder").module("energy").state_breaches(out, P, run, flags)
    assert flags.tolist() == [[0, 1]]


def test_extreme_draws_are_at_corners_and_beyond():
    import gymnasium as gym

    venv = gym.make_vec("hydro_envs/ServoCylinderPosition-v0", num_envs=1, vectorization_mode="vector_entry_point")
    b = venv._batch
    rng = np.random.default_rng(0)
    spec, base = b.spec, b.base_params
    for _ in range(20):
        values, kind = soak.extreme_draw(b, rng, False, 2.0)
        assert kind == "corner"
        for e in spec.entries:
            lo, hi = e.value_range(getattr(base, e.name))
            assert values[e.name] in (lo, hi)
    n_out = 0
    for _ in range(20):
        values, kind = soak.extreme_draw(b, rng, True, 2.0)
        b.params_cls.from_mapping(values, base=base)  # a valid parameter set
        if kind == "beyond":
            n_out += any(not (lo <= values[e.name] <= hi) for e in spec.entries
                         for lo, hi in [e.value_range(getattr(base, e.name))])
    assert n_out >= 15
    venv.close()


def test_limit_checks_fail_on_a_chamber_above_its_relief_and_a_cold_chamber():
    from hydro_envs.plants.rodless_cylinder import model as rc

    p = sc.ServoCylinderParams()
    P = p.to_array()[None, :]
    full = p.relief_pressure + p.relief_override
    ok = np.array([[0.03, 0.0, full, p.tank_pressure, 0.0, 0.0, 0.0]])
    tracker = soak._LimitTracker(sc.CONTRACT)
    assert not tracker.breaches(ok, P)["relief"].any() and tracker.max_ratio == pytest.approx(1.0)
    over = ok.copy()
    over[0, sc.P2] = full * (1.0 + 1.5 * soak.RELIEF_TOL)
    assert tracker.breaches(over, P)["relief"].all() and tracker.max_pressure == over[0, sc.P2]
    none = dataclasses.replace(p, relief_flow=0.0).to_array()[None, :]  # no relief: no bound
    assert not soak._LimitTracker(sc.CONTRACT).breaches(over, none)["relief"].any()
    q = rc.RodlessCylinderParams()
    cold = soak._LimitTracker(rc.CONTRACT)
    floor = float(rc.soak_temperature_floor(q.to_array()[None, :])[0])  # 293.15 (1.01/10.5)^(2/7): 150 K
    assert floor == pytest.approx(q.supply_temperature * (q.exhaust_pressure / (1.5 * q.supply_pressure)) ** (0.4 / 1.4))
    for t, breach in ((0.98 * floor, True), (1.02 * floor, True), (240.0, True), (251.0, False)):
        y = rc.rest_state(q, 0.5 * q.stroke, ta=t)[None, :]
        assert bool(cold.breaches(y, q.to_array()[None, :])["temperature"][0]) is breach
    assert cold.min_temperature == pytest.approx(0.98 * floor) and cold.cold_steps == 3
    assert floor < soak.MIN_TEMPERATURE  # the 250 K bound is the binding one
    assert not soak._LimitTracker(fa.CONTRACT).breaches(ok[:, :0], P)["relief"].any()  # no chambers: no bound
