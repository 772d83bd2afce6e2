"""Generic slider plant (hydro_envs/plants/slider.py) and its identification
(identification/slider.py), checked against analytic solutions, the Radau reference, the
numerical Jacobian and recovery of known parameters from noisy simulated records."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from hydro_envs.data import channels_for, load_measured, write_measured
from hydro_envs.params import ParameterError
from hydro_envs.plants.slider import model as sl
from hydro_envs.plants.slider.params import SliderParams
from hydro_envs.plants.slider.model import simulate_slider, slider_friction, stiffness_modes
from hydro_envs import registry
from hydro_envs.sim.reference import reference_rollout
from hydro_envs.sim.stiffness import substeps_from_stiffness
from identification.slider import SliderIdentificationError, identify_slider, identify_slider_measured

NO_FRICTION = dict(coulomb_friction=0.0, static_friction=0.0, viscous_friction=0.0)


# =============================================================================== plant
def test_plant_id_parameters_sources_and_channels():
    p = SliderParams()
    assert (p.mass, p.coulomb_friction, p.static_friction, p.stribeck_velocity, p.viscous_friction,
            p.force_offset) == (1.0, 10.0, 15.0, 5e-3, 20.0, 0.0)
    for row in SliderParams.describe():
        assert row["source"].strip(), row["name"]
    assert [(c.name, c.unit) for c in channels_for("slider")] == [("f", "N"), ("x", "m")]


@pytest.mark.parametrize("field, value", [("mass", 0.0), ("stribeck_velocity", 0.0), ("stroke", -1.0),
                                          ("viscous_friction", math.nan)])
def test_invalid_parameters_name_field_and_range(field, value):
    with pytest.raises(ParameterError, match=field):
        SliderParams(**{field: value})


def test_static_below_coulomb_is_rejected():
    with pytest.raises(ParameterError, match="static_friction"):
        SliderParams(coulomb_friction=10.0, static_friction=5.0)


def test_constant_force_without_friction_is_uniform_acceleration():
    p = SliderParams(**NO_FRICTION, force_offset=2.0, mass=3.0, stroke=10.0)
    dt, n, f = 1e-3, 500, 11.0
    y = simulate_slider(p, np.full(n, f), dt, y0=np.array([1.0, 0.1]))
    t = dt * np.arange(n + 1)
    acc = (f - 2.0) / 3.0
    np.testing.assert_allclose(y[:, 0], 1.0 + 0.1 * t + 0.5 * acc * t**2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[:, 1], 0.1 + acc * t, rtol=0, atol=1e-12)


def test_viscous_slider_matches_the_exponential_solution():
    p = SliderParams(coulomb_friction=0.0, static_friction=0.0, viscous_friction=20.0, mass=1.0,
                     force_offset=-3.0, stroke=10.0)
    dt, n, f = 1e-3, 400, 7.0
    y = simulate_slider(p, np.full(n, f), dt, y0=np.array([1.0, 0.0]))
    t = dt * np.arange(n + 1)
    v_inf = (f + 3.0) / 20.0
    tau = 1.0 / 20.0
    v = v_inf * (1 - np.exp(-t / tau))
    x = 1.0 + v_inf * (t - tau * (1 - np.exp(-t / tau)))
    np.testing.assert_allclose(y[:, 1], v, atol=1e-10)
    np.testing.assert_allclose(y[:, 0], x, atol=1e-12)


def test_stribeck_slider_matches_radau_reference():
    p = SliderParams()
    dt = 1e-3
    rng = np.random.default_rng(0)
    f = np.repeat(rng.uniform(-30, 30, 40), 25)  # 1 s of random force steps, through v = 0
    y = simulate_slider(p, f, dt)
    ref = reference_rollout(registry.get("slider"), sl.rest_state(p), f[:, None], p.to_array(), dt,
                            rtol=1e-10, atol=np.array([1e-12, 1e-10, 1e-12, 1e-10]))
    assert np.max(np.abs(y[:, 0] - ref[:, 0])) < 2e-8  # 20 nm over 37 mm of travel
    assert np.max(np.abs(y[:, 1] - ref[:, 1])) < 1e-6
    assert np.ptp(y[:, 0]) > 0.01
    # fourth-order convergence once the stiff tanh mode is resolved
    e = [np.max(np.abs(simulate_slider(p, f, dt, n_sub=n)[:, 0] - ref[:, 0])) for n in (52, 104)]
    assert e[0] / e[1] > 8
    # the stability-only step (kernel default safety) is stable but coarse at stick-slip
    coarse = simulate_slider(p, f, dt, safety=0.8)
    assert 1e-7 < np.max(np.abs(coarse[:, 0] - ref[:, 0])) < 1e-4


def test_sticks_below_breakaway_and_slides_above():
    """Below F_S + F_0 the slider only creeps at about v_eps atanh(f/F_S) (the tanh
    regularisation); above it, it breaks away and reaches the Coulomb-viscous speed."""
    from scipy.optimize import brentq

    p = SliderParams(force_offset=1.0)
    dt, n = 1e-3, 1000
    below = simulate_slider(p, np.full(n, 0.9 * p.static_friction + 1.0), dt)
    # creep speed: the first (stable) root of F_f(v) = 0.9 F_S on the rising tanh branch
    grid = np.geomspace(1e-9, p.stribeck_velocity, 4000)
    i = int(np.argmax(slider_friction(grid, p) > 0.9 * p.static_friction))
    creep = brentq(lambda v: slider_friction(v, p) - 0.9 * p.static_friction, grid[i - 1], grid[i])
    assert creep < 2.5 * p.friction_sign_velocity
    assert below[-1, 1] == pytest.approx(creep, rel=1e-6)
    above = simulate_slider(dataclasses.replace(p, stroke=10.0), np.full(n, 30.0 + 1.0), dt,
                            y0=np.array([0.1, 0.0]))
    v_ss = (30.0 - p.coulomb_friction) / p.viscous_friction  # 1 m/s, exp term negligible
    # velocity after 0.25 s (tau = m / b = 50 ms), on a long stroke (no stop in the way)
    assert above[250, 1] == pytest.approx(v_ss * (1 - math.exp(-5)), rel=0.01)


def test_friction_helper_matches_the_rhs():
    p = SliderParams(force_offset=0.5)
    dy = np.empty(sl.N_STATES)
    for v in (-0.3, -4e-3, -1e-4, 0.0, 2e-4, 6e-3, 0.5):
        registry.get("slider").kernels.rhs(np.array([0.1, v, 0.1, v]), np.array([0.0]), p.to_array(), dy)
        assert dy[1] == pytest.approx(-(slider_friction(v, p) + 0.5) / p.mass, rel=1e-12, abs=1e-12)


def numerical_jacobian(y, p_arr, f=0.0):
    n = y.size
    J = np.empty((n, n))
    for j in range(n):
        yp, ym = y.copy(), y.copy()
        yp[j] += 1e-9
        ym[j] -= 1e-9
        fp, fm = np.empty(n), np.empty(n)
        registry.get("slider").kernels.rhs(yp, np.array([f]), p_arr, fp)
        registry.get("slider").kernels.rhs(ym, np.array([f]), p_arr, fm)
        J[:, j] = (fp - fm) / 2e-9
    return J


@pytest.mark.parametrize("params", [
    SliderParams(),
    SliderParams(mass=0.05, friction_sign_velocity=1e-5, stop_stiffness=1e9),
    SliderParams(mass=200.0, coulomb_friction=300.0, static_friction=600.0, stribeck_velocity=1e-3),
])
def test_stiffness_bound_covers_the_numerical_jacobian(params):
    bound = max(stiffness_modes(params).values())
    pa = params.to_array()
    L = params.stroke
    pen = params.force_max / params.stop_stiffness
    worst = 0.0
    for x in (0.0, 0.5 * L, L + pen, -pen):
        for v in (0.0, 1e-7, -1e-6, params.friction_sign_velocity, -params.stribeck_velocity, 0.3):
            lam = np.abs(np.linalg.eigvals(numerical_jacobian(np.array([x, v, x, v]), pa)))
            worst = max(worst, lam.max())
    assert worst <= 1.02 * bound
    assert worst >= 0.3 * bound


def test_end_stop_holds_the_full_force_and_never_pulls():
    p = SliderParams()
    dt = 1e-3
    y = simulate_slider(p, np.full(800, p.force_max), dt)
    pen_static = p.force_max / p.stop_stiffness  # friction is ~0 at rest (tanh(0) = 0)
    assert y[-1, 0] - p.stroke == pytest.approx(pen_static, rel=0.02)
    # impact: an undamped spring hit at v_imp under a constant force penetrates at most
    # v_imp sqrt(m/k) + 2 f/k; damping and friction only reduce it
    k_hit = int(np.argmax(y[:, 0] > p.stroke))
    v_imp = max(y[k_hit - 1, 1], y[k_hit, 1])
    bound = v_imp * math.sqrt(p.mass / p.stop_stiffness) + 2 * pen_static
    assert pen_static < np.max(y[:, 0]) - p.stroke < bound
    y = simulate_slider(p, np.full(800, -p.force_max), dt)
    assert -y[-1, 0] == pytest.approx(pen_static, rel=0.02)


def test_batch_equals_single_and_serial_equals_parallel():
    rng = np.random.default_rng(1)
    params = [SliderParams(mass=rng.uniform(0.5, 2.0), force_offset=rng.uniform(-2, 2)) for _ in range(70)]
    F = np.repeat(rng.uniform(-40, 40, (70, 20)), 10, axis=1)
    Yb = simulate_slider(params, F, 1e-3)  # 70 copies -> parallel kernel
    assert Yb.shape == (70, 201, sl.N_STATES)
    for i in (0, 33, 69):
        np.testing.assert_array_equal(Yb[i], simulate_slider(params[i], F[i], 1e-3))
    P = np.stack([q.to_array() for q in params])
    nsub = np.array([substeps_from_stiffness(stiffness_modes(q), 1e-3)[0] for q in params], dtype=np.int64)
    out = []
    for kernel in (registry.get("slider").kernels.step_serial, registry.get("slider").kernels.step_parallel):
        Y = np.stack([sl.rest_state(q) for q in params])
        W = np.zeros((70, 5, sl.N_STATES))
        c = np.zeros(70, dtype=np.int64)
        for k in range(50):
            kernel(Y, F[:, k : k + 1].copy(), P, 1e-3, nsub, W, c)
        out.append(Y)
    assert np.array_equal(out[0], out[1])
    assert np.all(c == 0)  # the guard has nothing to clamp


# ---------------------------------------------------------------------------- backlash
PLAY = dataclasses.replace(SliderParams(), backlash_gap=1e-4, stroke=10.0)


def test_backlash_force_is_a_dead_zone_that_never_pulls():
    from hydro_envs.laws.contact import backlash_force

    g, k, a = 1e-4, 1e6, 240.0
    assert backlash_force(0.0, 1.0, g, k, a) == 0.0
    assert backlash_force(0.99e-4, -1.0, g, k, a) == 0.0
    assert backlash_force(g + 1e-6, 0.0, g, k, a) == pytest.approx(1.0)  # drive pushes the load +x
    assert backlash_force(-g - 1e-6, 0.0, g, k, a) == pytest.approx(-1.0)
    assert backlash_force(g + 1e-12, 0.1, g, k, a) == pytest.approx(0.0, abs=1e-5)  # continuous at contact
    assert backlash_force(g + 1e-6, -1.0, g, k, a) == 0.0  # separating fast: no pull
    assert backlash_force(-g - 1e-6, 1.0, g, k, a) == 0.0


def test_play_conserves_momentum_without_friction_and_stops():
    """The contact is internal: with friction, offset and stops off, total momentum grows by the
    applied impulse only, through several impacts across the play."""
    p = dataclasses.replace(PLAY, coulomb_friction=0.0, static_friction=0.0, viscous_friction=0.0)
    f = np.repeat([20.0, -20.0, 20.0, -20.0], 50)
    y = simulate_slider(p, f, 1e-4)
    mu = p.load_mass_fraction
    mom = p.mass * (mu * y[:, sl.V] + (1 - mu) * y[:, sl.VD])
    impulse = np.concatenate([[0.0], np.cumsum(f) * 1e-4])
    np.testing.assert_allclose(mom, impulse, atol=1e-12)
    assert np.max(np.abs(y[:, sl.XD] - y[:, sl.X])) > p.backlash_gap  # in contact at times


def test_load_moves_on_its_own_friction_while_the_drive_crosses_the_play():
    """Pushed +x, then the force reversed: the drive leaves the load, which slides on its own
    friction share (no contact force) until the drive, having crossed the play of 2 g, meets it
    from the other side and pulls it back."""
    p = PLAY
    dt = 1e-4
    f = np.concatenate([np.full(2000, 20.0), np.full(2000, -20.0)])
    y = simulate_slider(p, f, dt, n_sub=4)
    mu = p.load_mass_fraction
    k0 = 2000
    d = y[:, sl.XD] - y[:, sl.X]
    # before the reversal: in contact on the +x side, the drive ahead by g plus the deflection
    assert p.backlash_gap < d[k0] < p.backlash_gap + 20.0 / p.coupling_stiffness
    # the drive meets the load on the other side of the play
    meet = k0 + int(np.argmax(d[k0:] < -p.backlash_gap))
    assert meet > k0 + 5 and y[meet, sl.V] > 0.0  # the load is still sliding +x
    acc = np.gradient(y[:, sl.V], dt)
    leave = k0 + int(np.argmax(d[k0:] < p.backlash_gap))  # contact released
    free = np.arange(leave + 2, meet - 2)
    fric = mu * slider_friction(y[free, sl.V], p)
    np.testing.assert_allclose(acc[free], -fric / (mu * p.mass), rtol=1e-3)
    # after the meeting the drive pulls it back: the load reverses
    assert np.min(y[meet:, sl.V]) < -0.05


def test_backlash_stiffness_bound_covers_the_numerical_jacobian():
    p = dataclasses.replace(PLAY, stroke=0.2)
    bound = max(stiffness_modes(p).values())
    pa = p.to_array()
    g = p.backlash_gap
    pen = p.force_max / p.coupling_stiffness
    worst = 0.0
    for d in (0.0, g + 0.5 * pen, -g - pen):
        for v, vd in ((0.0, 0.0), (0.01, 0.0), (0.0, -0.2), (p.friction_sign_velocity, 0.1)):
            lam = np.abs(np.linalg.eigvals(numerical_jacobian(np.array([0.1, v, 0.1 + d, vd]), pa)))
            worst = max(worst, lam.max())
    assert worst <= 1.02 * bound
    assert worst >= 0.3 * bound
    # the contact mode alone, sliding fast (friction slope small), against its own bound: in the
    # spring, and while the damper engages at the fastest closing speed
    from hydro_envs.laws.contact import CONTACT_DAMPING_RAMP

    md = (1 - p.load_mass_fraction) * p.mass
    v_close = math.sqrt(4 * g * (p.force_max + p.static_friction) / md)
    states = [(0.2, g + 0.5 * pen, 0.2), (0.2, -g - pen, 0.2), (0.2, g + 0.5 * CONTACT_DAMPING_RAMP, 0.2 + v_close),
              (-0.2, -g - 0.5 * CONTACT_DAMPING_RAMP, -0.2 - v_close)]
    contact = max(np.abs(np.linalg.eigvals(numerical_jacobian(np.array([0.1, v, 0.1 + d, vd]), pa))).max()
                  for v, d, vd in states)
    assert 0.3 * stiffness_modes(p)["backlash"] <= contact <= 1.02 * stiffness_modes(p)["backlash"]


def test_drive_track_recovers_the_hidden_drive_from_load_and_force():
    """The observer of the driven body (hidden state behind the play) from a noisy load
    position and the force: within a few um of the truth once the first contact is made; with
    the wrong play it is off by the play's difference; without a play it is the load."""
    from hydro_envs.plants.slider.observer import drive_track
    from identification.diagnosis.records import smoothed

    p = dataclasses.replace(PLAY, stroke=0.2)
    dt = 1e-3
    rng = np.random.default_rng(4)
    t = dt * np.arange(4000)
    f = 14 * np.sin(2 * np.pi * 1.1 * t) + 6 * np.sin(2 * np.pi * 2.9 * t + 1)  # 8 reversals per s
    y = simulate_slider(p, f, dt, y0=np.array([0.1, 0.0, 0.1, 0.0]))[:-1]
    raw = y[:, sl.X] + 1e-6 * rng.standard_normal(f.size)
    x = smoothed(raw, dt)  # as the diagnosis passes it
    xd, _ = drive_track(p, x, f, dt)
    settled = slice(200, None)
    err = np.sqrt(np.mean((xd[settled] - y[settled, sl.XD]) ** 2))
    assert err < 1.5e-5, err  # 5 um from the raw record; the 20 ms smoothing costs the rest
    assert np.sqrt(np.mean((drive_track(p, raw, f, dt)[0][settled] - y[settled, sl.XD]) ** 2)) < 8e-6
    wrong, _ = drive_track(dataclasses.replace(p, backlash_gap=0.5 * p.backlash_gap), x, f, dt)
    assert np.sqrt(np.mean((wrong[settled] - y[settled, sl.XD]) ** 2)) > 3e-5
    same, _ = drive_track(dataclasses.replace(p, backlash_gap=0.0), x, f, dt)
    np.testing.assert_array_equal(same, x)


def test_simulate_rejects_bad_input():
    with pytest.raises(ValueError, match="NaN"):
        simulate_slider(SliderParams(), np.array([1.0, np.nan]), 1e-3)
    with pytest.raises(ValueError, match="dt"):
        simulate_slider(SliderParams(), np.ones(3), 0.0)


# ====================================================================== identification
TRUE = dataclasses.replace(SliderParams(), force_offset=-3.0)
DT = 1.0 / 2000.0  # 2 kHz record
NOISE_X = 1e-6  # 1 um position noise (encoder/LVDT class)
NOISE_F = 0.05  # N force-sensor noise
MIN_SPEED = 2e-3  # 4 v_eps: the simulated plant creeps (tanh) below a few v_eps; see module doc


def plateau_reference(speeds, dt, plateau=0.6, ramp=0.15, x0=0.1):
    """Back-and-forth constant-velocity segments with cosine ramps (a constant-velocity test,
    cf. 002 eqs (9)-(10), 004 eq (1)); returns reference position and velocity."""
    parts = []
    nr, npl = int(ramp / dt), int(plateau / dt)
    r = 0.5 * (1 - np.cos(np.pi * np.arange(nr) / nr))
    for s in speeds:
        for vel in (s, -s):
            parts.append(np.concatenate([vel * r, np.full(npl, vel), vel * r[::-1], np.zeros(int(0.1 / dt))]))
    v = np.concatenate(parts)
    return x0 + np.cumsum(v) * dt, v


def sine_reference(duration, dt, x0=0.1):
    t = np.arange(int(duration / dt)) * dt
    x = x0 + 0.04 * np.sin(2 * np.pi * 1.0 * t) + 0.01 * np.sin(2 * np.pi * 3.1 * t)
    return x, np.gradient(x, dt)


def pd_experiment(params, x_ref, v_ref, dt, seed, kp=2.5e5, kd=1000.0):
    """Closed-loop PD position control on the batched kernel (the controller sees the true
    state, e.g. encoder + tachometer); the record gets sensor noise. Returns f, x (noisy)."""
    rng = np.random.default_rng(seed)
    P = params.to_array()[None, :]
    Y = np.array([[x_ref[0], 0.0, x_ref[0], 0.0]])
    W = np.zeros((1, 5, sl.N_STATES))
    c = np.zeros(1, dtype=np.int64)
    nsub = np.array([substeps_from_stiffness(stiffness_modes(params), dt, sl.ACCURATE_SAFETY)[0]], dtype=np.int64)
    U = np.zeros((1, 1))
    n = x_ref.size
    xs, fs = np.empty(n), np.empty(n)
    for k in range(n):
        f = kp * (x_ref[k] - Y[0, 0]) + kd * (v_ref[k] - Y[0, 1])
        xs[k], fs[k] = Y[0, 0], f
        U[0, 0] = f
        registry.get("slider").kernels.step_serial(Y, U, P, dt, nsub, W, c)
    return fs + NOISE_F * rng.standard_normal(n), xs + NOISE_X * rng.standard_normal(n)


@pytest.fixture(scope="module")
def rich_record():
    """Constant-velocity plateaus 3..80 mm/s in both directions plus a 2 Hz sine for the mass."""
    xp, vp = plateau_reference([0.003, 0.005, 0.008, 0.012, 0.02, 0.04, 0.08], DT)
    ts = np.arange(int(4 / DT)) * DT
    xs = 0.1 + 0.03 * np.sin(2 * np.pi * 2 * ts) * np.sin(np.pi * ts / 4) ** 2
    x_ref = np.concatenate([xp, xs])
    v_ref = np.concatenate([vp, np.gradient(xs, DT)])
    return pd_experiment(TRUE, x_ref, v_ref, DT, seed=0)


@pytest.fixture(scope="module")
def sine_record():
    x_ref, v_ref = sine_reference(16.0, DT)
    return pd_experiment(TRUE, x_ref, v_ref, DT, seed=1)


def rel_err(est, name):
    return abs(est.params[name] - getattr(TRUE, name)) / abs(getattr(TRUE, name))


ALL = ("mass", "coulomb_friction", "static_friction", "stribeck_velocity", "viscous_friction", "force_offset")
MAIN = ("mass", "coulomb_friction", "viscous_friction", "force_offset")


def test_recovers_all_six_parameters_from_a_rich_record(rich_record):
    f, x = rich_record
    est = identify_slider(f, x, DT, cutoff=50.0, min_speed=MIN_SPEED)
    assert est.stribeck_identified, est.notes
    for name in ALL:
        assert rel_err(est, name) < 0.05, (name, est.params[name], getattr(TRUE, name))
    # in fact much closer than 5 %: every parameter within 1.5 %
    assert max(rel_err(est, n) for n in ALL) < 0.015
    assert est.fit_percent > 95.0
    assert est.acceleration_noise_ratio < 0.01
    js = json.loads(json.dumps(est.to_json_dict(), allow_nan=False))
    assert set(js["parameters"]) == set(ALL)
    assert js["stribeck_identified"] is True
    q = est.to_params()
    assert q.mass == pytest.approx(est.params["mass"])


def test_sine_record_cannot_pin_the_stribeck_dip_and_says_so(rich_record, sine_record):
    """Data limitation: with fast reversals only, the dip is crossed in a few milliseconds
    per reversal, faster than any differentiation filter can render; the dip estimates then
    depend on the filter cut-off (the rich record's do not), are off by more than 5 %, and
    the tool reports them as not identified. The four main parameters stay within 5 %."""
    f, x = sine_record
    fits = {fc: identify_slider(f, x, DT, cutoff=fc, min_speed=MIN_SPEED, stribeck="fit") for fc in (25.0, 50.0, 100.0)}
    est = fits[50.0]
    for name in MAIN:
        assert rel_err(est, name) < 0.05, (name, est.params[name])
    assert not est.stribeck_identified
    assert any("near-constant speed" in note for note in est.notes)
    assert max(rel_err(est, "static_friction"), rel_err(est, "stribeck_velocity")) > 0.05
    vs = [fits[fc].params["stribeck_velocity"] for fc in fits]
    assert (max(vs) - min(vs)) / min(vs) > 0.10  # filter-dependent
    fr, xr = rich_record
    vs_rich = [identify_slider(fr, xr, DT, cutoff=fc, min_speed=MIN_SPEED).params["stribeck_velocity"]
               for fc in (25.0, 50.0, 100.0)]
    assert (max(vs_rich) - min(vs_rich)) / min(vs_rich) < 0.01  # filter-independent
    # with the dip fixed from a constant-velocity test, the sine record is fine
    fixed = identify_slider(f, x, DT, cutoff=50.0, min_speed=MIN_SPEED, stribeck="fixed",
                            stribeck_velocity=TRUE.stribeck_velocity, static_friction=TRUE.static_friction)
    for name in MAIN:
        assert rel_err(fixed, name) < 0.02
    js = json.loads(json.dumps(fixed.to_json_dict(), allow_nan=False))
    assert js["std_errors_naive"]["mass"] > 0 and "static_friction" not in js["std_errors"]


def test_ignoring_the_dip_biases_coulomb_and_viscous_friction(rich_record):
    """Negative control: the dip is real in the rich record; a model without it is wrong."""
    f, x = rich_record
    est = identify_slider(f, x, DT, cutoff=50.0, min_speed=MIN_SPEED, stribeck="none")
    assert rel_err(est, "viscous_friction") > 0.15
    assert est.fit_percent < identify_slider(f, x, DT, cutoff=50.0, min_speed=MIN_SPEED).fit_percent - 3


def test_hac_standard_errors_exceed_naive_ones_for_the_coulomb_viscous_split(rich_record):
    """The residuals of a filtered record are autocorrelated (docs/references.md): the HAC errors are
    reported alongside the naive ones and are larger for the no-dip model's misfit."""
    f, x = rich_record
    est = identify_slider(f, x, DT, cutoff=50.0, min_speed=MIN_SPEED, stribeck="none")
    assert est.hac_lag > 1
    assert est.std_errors["viscous_friction"] > 2 * est.std_errors_naive["viscous_friction"]


def test_identification_from_a_measured_data_file(tmp_path, sine_record):
    f, x = sine_record
    t = DT * np.arange(f.size)
    path = write_measured(tmp_path / "slider.csv", t, {"f": f, "x": x}, plant="slider")
    data = load_measured(path)
    est = identify_slider_measured(data, cutoff=50.0, min_speed=MIN_SPEED, stribeck="none")
    direct = identify_slider(f, x, DT, cutoff=50.0, min_speed=MIN_SPEED, stribeck="none")
    assert est.params["mass"] == pytest.approx(direct.params["mass"], rel=1e-9)


def test_poor_data_raise_clear_errors(sine_record):
    f, x = sine_record
    cases = []
    bad = x.copy()
    bad[1234] = np.nan
    cases.append(((f, bad), "NaN"))
    cases.append(((f[:300], x[:300]), "too short"))
    cases.append(((f, np.full_like(x, 0.1) + NOISE_X * np.random.default_rng(0).standard_normal(x.size)), "no motion"))
    cases.append(((np.zeros_like(f), x), "constant"))
    # pushed one way only: sign(v) is constant, Coulomb and offset are inseparable
    n = 8000
    push = np.full(n, 20.0)
    y = simulate_slider(dataclasses.replace(TRUE, stroke=10.0), push, DT, y0=np.array([0.1, 0.0]))
    rng = np.random.default_rng(2)
    cases.append(((push + 0.5 * np.sin(np.arange(n) * 0.01), y[:-1, 0] + 1e-6 * rng.standard_normal(n)),
                  "direction"))
    for (ff, xx), fragment in cases:
        with pytest.raises(SliderIdentificationError, match=fragment):
            identify_slider(ff, xx, DT, cutoff=50.0, min_speed=MIN_SPEED)
    with pytest.raises(SliderIdentificationError, match="stribeck_velocity"):
        identify_slider(f, x, DT, stribeck="fixed")
