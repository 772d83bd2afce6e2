"""``hydro_envs/LoadSensing-v0`` and the LS circuit plant (seed 000 sec. 2, Fig. 1).

Checks against independent truths: the compensator's force balance (the margin), the
orifice law of the control valve, a stiff Radau reference, the numerical Jacobian, the env's
info, channels and guards at the randomisation corners (the contract every env keeps, seeding
and vector copies among it: ``test_env_contract.py``). The hydro-mechanical baseline (action 0)
must be stable and keep the margin."""

from __future__ import annotations

import itertools
import math

import gymnasium as gym
import numpy as np
import pytest

import hydro_envs  # noqa: F401
from hydro_envs.params import ParameterError
from hydro_envs.plants.load_sensing import model as cc
from hydro_envs.plants.load_sensing.params import LoadSensingParams
from hydro_envs.randomization import load_randomization
from hydro_envs import registry
from hydro_envs.sim.reference import reference_rollout
from hydro_envs.sim.rk4 import local_substeps
from hydro_envs.sim.stiffness import DEFAULT_SAFETY, RK4_REAL_STABILITY_LIMIT, substeps_from_stiffness
from env_helpers import rollout as _rollout

ENV_ID = "hydro_envs/LoadSensing-v0"
NOMINAL = LoadSensingParams()
OBS_DIM = 12
BAR = 1e5


@pytest.fixture(scope="module")
def spec():
    return load_randomization("load_sensing", LoadSensingParams)


def _ramp(v=0.1, n=2100, t_start=0.2, t_ramp=0.1):
    t = np.arange(n) * 1e-3
    return np.clip((t - t_start) / t_ramp, 0.0, 1.0) * v


def _random_actions(n, seed=0, shape=(2,)):
    return np.random.default_rng(seed).uniform(-1, 1, (n, *shape)).astype(np.float32)


# ------------------------------------------------------------------------------ plant
def test_margin_is_the_seed_20_bar():
    assert cc.margin(NOMINAL) == pytest.approx(20.0 * BAR, rel=1e-12)
    assert cc.margin(NOMINAL, NOMINAL.solenoid_force_max) - cc.margin(NOMINAL) == pytest.approx(
        NOMINAL.solenoid_force_max / cc.derived(NOMINAL)["spool_area"])


def test_parameters_validated():
    with pytest.raises(ParameterError, match="control_area_small"):
        LoadSensingParams(control_area_small=1e-3, control_area_large=5e-4)
    with pytest.raises(ParameterError, match="load_mass"):
        LoadSensingParams(load_mass=-1.0)
    arr = NOMINAL.to_array()
    assert arr.shape == (cc.N_PARAMS,)
    assert LoadSensingParams.from_array(arr) == NOMINAL


def _run(p, u_seq, y0, dt=1e-3):
    n_sub = substeps_from_stiffness(cc.stiffness_modes(p), dt)[0]
    Y, P = y0[None].copy(), p.to_array()[None]
    W, c = np.zeros((1, 5, cc.N_STATES)), np.zeros(1, dtype=np.int64)
    out = [Y[0].copy()]
    for u in u_seq:
        registry.get("load_sensing").kernels.step_serial(Y, np.asarray(u, float)[None], P, dt, np.array([n_sub]), W, c)
        out.append(Y[0].copy())
    return np.array(out), int(c[0])


def test_steady_flow_obeys_the_control_valve_orifice_law():
    p = NOMINAL
    a_cv = cc.cv_area_for_velocity(p, 0.08)
    ys, _ = _run(p, [[0.0, 0.0]] * 100 + [[0.0, a_cv]] * 1900, cc.standby_state(p, 0.05))
    y = ys[-1]
    q = p.discharge_coefficient * a_cv * math.sqrt(2 * (y[cc.PS] - y[cc.PL]) / p.oil_density)
    assert y[cc.VA] * p.piston_area == pytest.approx(q, rel=2e-3)
    # the actuator force balance holds the load: A_c (p_l - p_T) = F_L + friction(v), the seals
    # sliding at their Coulomb level (the steady state of their LuGre law)
    fric = p.actuator_viscous * y[cc.VA] + p.actuator_coulomb * math.copysign(1.0, y[cc.VA])
    assert p.piston_area * (y[cc.PL] - p.tank_pressure) == pytest.approx(p.load_force + fric, rel=1e-3)
    # the compensator keeps p_s - p_ls at (F0 + k x)/A; x sits just past the lap (P -> X feeds
    # piston 1's leak), so the margin is 20 bar plus at most a couple of per cent
    d = cc.derived(p)
    f_flow = -d["k_flow_force"] * (y[cc.X] - p.metering_lap) * (y[cc.PS] - y[cc.PX])
    balance = (p.spring_preload + p.spring_stiffness * y[cc.X] - f_flow) / d["spool_area"]
    assert y[cc.PS] - y[cc.PLS] == pytest.approx(balance, rel=1e-6)
    assert 20.0 * BAR <= y[cc.PS] - y[cc.PLS] <= 20.5 * BAR


def test_solenoid_force_shifts_the_margin_by_f_over_a():
    p = NOMINAL
    a_cv = cc.cv_area_for_velocity(p, 0.05)
    y0 = cc.standby_state(p, 0.05)
    y_a, _ = _run(p, [[0.0, a_cv]] * 1500, y0)
    y_b, _ = _run(p, [[p.solenoid_force_max, a_cv]] * 1500, y0)
    shift = (y_b[-1, cc.PS] - y_b[-1, cc.PLS]) - (y_a[-1, cc.PS] - y_a[-1, cc.PLS])
    assert shift == pytest.approx(p.solenoid_force_max / cc.derived(p)["spool_area"], rel=0.02)
    assert y_b[-1, cc.VA] > y_a[-1, cc.VA]  # larger drop across the same CV: faster


def test_fixed_step_matches_radau():
    spec = load_randomization("load_sensing", LoadSensingParams)
    p = spec.corner([False, True, True, False, False])  # cold oil, heavy, high force, soft oil
    n = 400
    rng = np.random.default_rng(0)
    u = np.column_stack([np.repeat(rng.uniform(-20, 20, n // 50), 50),
                         np.r_[np.zeros(50), np.full(n - 50, cc.cv_area_for_velocity(p, 0.12))]])
    y0 = cc.standby_state(p, 0.05)
    fixed, _ = _run(p, u, y0)
    atol = np.array([1e-12, 1e-9, 1.0, 1.0, 1e-12, 1e-9, 1.0, 1e-12, 1e-9, 1e-14, 1.0, 1e-6, 1e-14])
    ref = reference_rollout(registry.get("load_sensing"), y0, u, p.to_array(), 1e-3, rtol=1e-9, atol=atol)
    # NRMSE at the default 5 sub-steps; the +-20 N solenoid steps throw the FC spool onto its
    # seat (a stiff contact: RK4 drops to first order there), hence the looser spool bound
    for idx, tol in ((cc.VA, 2e-3), (cc.PS, 2e-3), (cc.PL, 2e-3), (cc.Y, 2e-3), (cc.X, 1e-2)):
        err = np.sqrt(np.mean((fixed[:, idx] - ref[:, idx]) ** 2)) / np.ptp(ref[:, idx])
        assert err < tol, (cc.STATE_NAMES[idx], err)
    assert fixed[:, cc.X].min() < 0.0  # the seat contact really happened


def test_stiffness_bound_covers_the_numerical_jacobian(spec):
    """The modes that size the sub-step with the worst cases of the locally refined ones bound
    the numerical Jacobian everywhere; with the local rate at the state
    (:func:`local_mode_rate`, the worst case on a spool stop) instead, at that state."""
    rng = np.random.default_rng(0)
    sets = [NOMINAL, spec.corner(False), spec.corner(True)] + [
        spec.corner(rng.integers(0, 2, len(spec.entries)).astype(bool)) for _ in range(2)]
    for p in sets:
        everywhere = max(cc.stiffness_modes(p).values())
        bound = max(everywhere, max(cc.local_mode_rates(p).values()))
        pa = p.to_array()
        worst = 0.0
        base = cc.standby_state(p, 0.1)
        for x in (0.0, -50e-6, p.metering_lap, p.metering_lap + p.port_length, p.spool_stroke + 50e-6):
            for yc in (0.0, 0.5 * p.control_stroke, p.control_stroke + 1e-5):
                for ps_px in ((1.0, 0.5), (1.0, 1.0 - 1e-6)):
                    y = base.copy()
                    y[cc.X], y[cc.Y] = x, yc
                    y[cc.PX] = y[cc.PS] * ps_px[1]
                    u = np.array([0.0, p.cv_area_max])
                    J = np.empty((cc.N_STATES, cc.N_STATES))
                    f0, f1 = np.empty(cc.N_STATES), np.empty(cc.N_STATES)
                    for j in range(cc.N_STATES):
                        h = max(abs(y[j]) * 1e-7, 1e-9)
                        yp, ym = y.copy(), y.copy()
                        yp[j] += h
                        ym[j] -= h
                        registry.get("load_sensing").kernels.rhs(yp, u, pa, f0)
                        registry.get("load_sensing").kernels.rhs(ym, u, pa, f1)
                        J[:, j] = (f0 - f1) / (2 * h)
                    here = np.abs(np.linalg.eigvals(J)).max()
                    on_stop = x < 0.0 or x > p.spool_stroke
                    local = pa[cc.D_LOCAL] if on_stop else cc.local_mode_rate(y, pa)
                    assert here <= 1.02 * max(everywhere, local), (x, yc, ps_px, here, everywhere, local)
                    worst = max(worst, here)
        assert worst <= 1.02 * bound, (worst, cc.stiffness_modes(p), cc.local_mode_rates(p))
        assert worst >= 0.3 * bound


def test_local_modes_left_out_of_the_substep_are_refined_where_stiff():
    """The sub-step count leaves out the spool stops and the orifices' zero-drop slopes (their
    worst cases would need 5 sub-steps per 1 ms instead of 3); the look-ahead takes a sub-step
    as the worst case's fine ones on a stop or across a zero drop, as the local rate's count
    near one, and whole at the standby's working drops."""
    dt = 1e-3
    pa = NOMINAL.to_array()
    n = substeps_from_stiffness(cc.stiffness_modes(NOMINAL), dt)[0]
    assert n == 3
    assert substeps_from_stiffness({**cc.stiffness_modes(NOMINAL), **cc.local_mode_rates(NOMINAL)}, dt)[0] == 5
    h = dt / n
    stable = DEFAULT_SAFETY * RK4_REAL_STABILITY_LIMIT
    m = cc.local_mode_refinement(pa, h)
    assert m >= 2 and h * max(cc.local_mode_rates(NOMINAL).values()) / m <= stable
    rest = cc.standby_state(NOMINAL, 0.1)
    assert cc.local_mode_substeps(rest, rest, pa, h, m) == 1
    seat = rest.copy()
    seat[cc.X] = -1e-6
    assert cc.local_mode_substeps(rest, seat, pa, h, m) == m
    assert cc.local_mode_substeps(seat, rest, pa, h, m) == m
    # the delivery pressure passing the load pressure between start and prediction (CV drop 0)
    below = rest.copy()
    below[cc.PS] = below[cc.PL] - 1e3
    assert cc.local_mode_substeps(rest, below, pa, h, m) == m
    # the delivery pressure a tenth of the transition pressure above the load: the CV's drop
    # in the laminar core, stiff in the delivery volume
    near = rest.copy()
    near[cc.PS] = near[cc.PL] + 0.1 * NOMINAL.orifice_transition_pressure
    assert h * cc.local_mode_rate(near, pa) > stable
    assert cc.local_mode_substeps(near, near, pa, h, m) == m
    # the drop-threshold short cut gives the count the local rates give
    rng = np.random.default_rng(5)
    for _ in range(400):
        a = rest.copy()
        a[cc.X] = rng.uniform(-1e-5, NOMINAL.metering_lap + 2 * NOMINAL.port_length)
        a[cc.PX] = a[cc.PS] - rng.choice([1.0, 1e3, 1e5, 1e6]) * rng.uniform(-1, 3)
        a[cc.PL] = a[cc.PS] - rng.choice([1.0, 1e3, 1e5, 1e6]) * rng.uniform(-1, 3)
        b = a.copy()
        b[[cc.PS, cc.PX, cc.PL]] += rng.normal(0.0, 2e4, 3)
        if cc._on_spool_stop(a, pa) or cc._on_spool_stop(b, pa) or cc._drop_crossed(a, b, pa):
            want = m
        else:
            want = local_substeps(h * max(cc.local_mode_rate(a, pa), cc.local_mode_rate(b, pa)), stable, m)
        assert cc.local_mode_substeps(a, b, pa, h, m) == want
    # the rate bound at a state is the zero-drop worst case of bounds.local_mode_rates there
    zero = near.copy()
    zero[cc.X] = NOMINAL.metering_lap + NOMINAL.port_length  # P -> X fully open
    zero[cc.PX] = zero[cc.PS]
    zero[cc.PL] = zero[cc.PS] - 1.0
    zero[cc.Y] = 0.0
    zero[cc.XA] = 0.0
    worst = cc.local_mode_rates(NOMINAL)
    assert cc.local_mode_rate(zero, pa) == pytest.approx(max(worst["control_chamber"], worst["delivery"]), rel=1e-3)


# ------------------------------------------------------------------------------- env API
def test_episode_limit():
    assert gym.make(ENV_ID).spec.max_episode_steps == 2000


def test_spaces_and_observation_bounds():
    env = gym.make(ENV_ID).unwrapped
    assert env.action_space.shape == (2,) and env.action_space.dtype == np.float32
    assert env.observation_space.shape == (OBS_DIM,)
    assert np.all(np.isfinite(env.observation_space.low)) and np.all(np.isfinite(env.observation_space.high))
    O, _, _ = _rollout(env, 3, _random_actions(600, 1))
    assert O.dtype == np.float32
    for o in O:
        assert env.observation_space.contains(o)


def _make_vec(n=3, **kw):
    return gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kw)


def test_info_state_params_render_and_channels():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    obs, info = env.reset(seed=4)
    assert tuple(info["state"]) == cc.STATE_NAMES
    assert info["params"]["oil_temperature"] >= 22.0
    for _ in range(50):
        obs, r, te, tr, info = env.step(np.zeros(2, dtype=np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    ch = env.unwrapped.channel_values()
    assert set(ch) == {c.name for c in __import__("hydro_envs.data.channels", fromlist=["x"]).channels_for("load_sensing")}
    assert ch["p_s"] == info["state"]["p_s"]


def test_randomize_false_and_draws_inside_yaml(spec):
    _, info = gym.make(ENV_ID, randomize=False).reset(seed=0)
    assert info["params"] == NOMINAL.as_dict()
    env = gym.make(ENV_ID)
    for s in range(20):
        _, info = env.reset(seed=s)
        for row in spec.table():
            lo, hi = row["value_range"]
            assert lo <= info["params"][row["name"]] <= hi


def test_reset_options():
    env = gym.make(ENV_ID).unwrapped
    ref = _ramp(0.07)
    obs, info = env.reset(seed=0, options={"reference": ref, "params": {"load_mass": 700.0}})
    assert info["params"]["load_mass"] == 700.0
    assert info["state"]["va"] == 0.0
    for _ in range(400):
        obs, *_ = env.step(np.zeros(2, dtype=np.float32))
    assert obs[0] == pytest.approx(0.07 / 0.2)
    with pytest.raises(ValueError, match="reference"):
        env.reset(seed=0, options={"reference": np.full(10, 0.5)})
    with pytest.raises(ValueError, match="unknown reset option"):
        env.reset(seed=0, options={"bogus": 1})
    with pytest.raises(ValueError, match="xa"):
        env.reset(seed=0, options={"state": {"xa": 2.0}})


# ------------------------------------------------------------------ baseline and guards
def _corner_rollout(spec, flags, actions, ref):
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0, options={"params": spec.corner(list(flags)).as_dict(), "reference": ref})
    S = []
    for a in actions:
        _, _, _, _, info = env.step(a)
        S.append([info["state"][k] for k in ("va", "p_s", "p_ls", "p_l", "p_x", "xa")])
    return np.array(S), env


def test_hydromechanical_baseline_is_stable_and_keeps_the_margin(spec):
    """Action 0 at all 32 corners of the randomisation: the velocity settles to the demand
    (CV set at the nominal margin: within 1 %), the margin to 20 bar (+2.5 %), and the ringing
    of heavy loads decays (the envelope shrinks)."""
    ref = _ramp(0.1)
    zero = np.zeros((2000, 2), dtype=np.float32)
    for flags in itertools.product([False, True], repeat=len(spec.entries)):
        S, _ = _corner_rollout(spec, flags, zero, ref)
        va, margin = S[:, 0], S[:, 1] - S[:, 2]
        assert abs(va[-300:].mean() - 0.1) < 1e-3, flags
        assert 20.0 * BAR <= margin[-300:].mean() <= 20.5 * BAR, flags
        early, late = va[1000:1500].std(), va[1500:].std()
        assert late <= max(0.8 * early, 1e-6), (flags, early, late)


def test_heavy_loads_ring_more_than_light_ones(spec):
    """The baseline leaves work for the agent: the heavy-load corners oscillate after a step."""
    ref = np.where(np.arange(2100) * 1e-3 > 0.2, 0.15, 0.0)
    zero = np.zeros((1200, 2), dtype=np.float32)
    light, _ = _corner_rollout(spec, [True, False, True, False, False], zero, ref)
    heavy, _ = _corner_rollout(spec, [True, True, True, False, False], zero, ref)
    e_light = np.sqrt(np.mean((light[300:1000, 0] - 0.15) ** 2))
    e_heavy = np.sqrt(np.mean((heavy[300:1000, 0] - 0.15) ** 2))
    assert e_heavy > 5 * e_light


@pytest.mark.parametrize("which", ["low", "high", "random1", "random2"])
def test_guards_hold_under_bang_bang_at_corners(spec, which):
    flags = {"low": [False] * 5, "high": [True] * 5}.get(which)
    if flags is None:
        flags = list(np.random.default_rng(int(which[-1])).integers(0, 2, 5).astype(bool))
    rng = np.random.default_rng(7)
    acts = np.repeat(rng.choice([-1.0, 1.0], (40, 2)), 50, axis=0).astype(np.float32)
    S, env = _corner_rollout(spec, flags, acts, np.full(2100, 0.2))
    p = spec.corner(flags)
    assert np.all(np.isfinite(S))
    assert S[:, 1:5].min() >= p.pressure_floor
    assert S[:, 1].max() < p.relief_pressure + 20 * BAR  # the relief valve caps p_s
    assert -1e-3 < S[:, 5].min() and S[:, 5].max() < p.stroke + 1e-3  # stroke ends hold


@pytest.mark.slow
def test_vector_env_long_random_rollout_at_corners(spec):
    n = 64
    venv = _make_vec(n)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    for i in range(n):
        flags = rng.integers(0, 2, len(spec.entries)).astype(bool)
        mask = np.zeros(n, bool)
        mask[i] = True
        venv.reset(options={"reset_mask": mask, "params": spec.corner(list(flags)).as_dict()})
    for _ in range(6000):
        obs, r, te, tr, info = venv.step(rng.uniform(-1, 1, (n, 2)).astype(np.float32))
        assert np.all(np.isfinite(obs)) and np.all(np.isfinite(r))
        assert info["state"]["p_s"].min() >= NOMINAL.pressure_floor


def test_demand_of_an_episode_shorter_than_the_initial_rest_is_all_rest():
    from hydro_envs.envs.load_sensing import generate_demand

    for kind in ("steps", "ramps", "mixed"):
        d = generate_demand(kind, np.random.default_rng(3), 50, 1e-3)  # 50 ms < the 0.1-0.3 s rest
        assert d.shape == (50,) and np.all(d == 0.0)
