"""Baseline controllers (agents/controllers.py) checked against the nominal servo env."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import load_env_creator

import hydro_envs  # noqa: F401
from agents.controllers import controller_names, make_controller
from agents.controllers.friction_models import identified_friction
from agents.controllers.servo_cylinder import (
    ProportionalPositionController,
    ServoPIDController,
    pid_tuning,
)
from hydro_envs.envs.shaking_table.references import generate_table_reference, reference_limits
from hydro_envs.plants.force_actuator import model as fa
from hydro_envs.plants.shaking_table import model as st
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

P = ServoCylinderParams()
L = P.stroke
N = 2000
QUANT = 3e-5  # encoder resolution [m]
T = np.arange(N + 60) * 1e-3


@pytest.fixture(scope="module")
def env():
    e = gym.make("hydro_envs/ServoCylinderPosition-v0", randomize=False)
    yield e
    e.close()


def rollout(env, ctrl, ref, x0, seed=0):
    """True positions x_k after step k and the reference they are compared with (ref[k+1])."""
    obs, _ = env.reset(seed=seed, options={"reference": ref, "state": {"x": x0}})
    xs, acts = np.empty(N), np.empty(N)
    for k in range(N):
        a, _ = ctrl.predict(obs, episode_start=np.array([k == 0]))
        obs, _, _, _, info = env.step(a)
        xs[k], acts[k] = info["state"]["x"], a[0]
    return xs, ref[1 : N + 1], acts


def rmse(e):
    return float(np.sqrt(np.mean(e**2)))


def test_tuning_uses_the_table_1_linearisation():
    t = pid_tuning(P)
    # hand values from 002 Table 1: K_q = C_v w x_vm sqrt(2/rho (p_s - p_R)/2) / A
    k_q = 0.6 * 20.75e-3 * 0.279e-3 * np.sqrt(2 / 847 * 13.8e6 / 2) / 6.63e-4
    # omega_h at mid-stroke: beta A^2 (2 / (A L/2 + V)) / m
    v_half = 6.63e-4 * 0.0696 / 2 + 88.7e-6
    omega_h = np.sqrt(689e6 * 6.63e-4**2 * 2 / v_half / 12.3)
    assert t["k_q"] == pytest.approx(k_q, rel=1e-3)  # 0.669 m/s per unit action
    assert t["omega_h"] == pytest.approx(omega_h, rel=1e-3)  # 664 rad/s
    # the loop crossover K_q K_p at 0.03 omega_h (20 1/s), with the load-pressure loop of 0.09
    assert t["kp"] * k_q == pytest.approx(0.03 * omega_h, rel=1e-6)
    assert t["k_dp"] == 0.09


def test_step_zero_steady_state_error_and_antiwindup(env):
    ref = np.full(N + 60, 0.85 * L)
    x0 = 0.05 * L  # 56 mm step: K_p e = 1.7 > 1, the action saturates
    over = {}
    for aw in ("back_calculation", "conditional", "none"):
        xs, r, acts = rollout(env, ServoPIDController.from_params(anti_windup=aw), ref, x0)
        assert np.sum(np.abs(acts) >= 1.0) > 10, aw  # saturation really happened
        over[aw] = xs.max() - 0.85 * L
        if aw != "none":
            # settled: true error within one encoder count over the last second
            assert np.max(np.abs(r[1000:] - xs[1000:])) <= QUANT, aw
    # stated bound: overshoot <= 9 mm (16 % of the step; the slow integral, T_i = 0.2 s, adds most
    # of it) with anti-windup; windup overshoots more
    assert over["back_calculation"] <= 9e-3
    assert over["conditional"] <= 9e-3
    assert over["none"] > max(over["back_calculation"], over["conditional"])


@pytest.mark.parametrize("freq", [0.2, 0.5])
def test_pid_beats_p_on_slow_sine(env, freq):
    ref = 0.5 * L + 0.3 * L * np.sin(2 * np.pi * freq * T)
    xs_p, r, _ = rollout(env, ProportionalPositionController(), ref, 0.5 * L)
    xs_pid, _, _ = rollout(env, ServoPIDController.from_params(), ref, 0.5 * L)
    assert rmse(r[200:] - xs_pid[200:]) < rmse(r[200:] - xs_p[200:])


def test_pid_removes_the_steady_error_a_load_leaves_the_p_loop():
    """2 kN on the rod: the P loop with load-pressure feedback settles ``k_dp p_L / (p_s K_p)``
    off (0.44 mm with k_dp = 0.06); the PID's integral removes it."""
    from agents.controllers.servo_cylinder import P_K_DP

    e = gym.make("hydro_envs/ServoCylinderPosition-v0", randomize=False)
    ref = np.full(N + 60, 0.5 * L)
    out = {}
    for name, ctrl in (("p", ProportionalPositionController()), ("pid", ServoPIDController.from_params())):
        obs, _ = e.reset(seed=0, options={"reference": ref, "state": {"x": 0.5 * L}, "params": {"load_force": 2000.0}})
        for k in range(N):
            a, _ = ctrl.predict(obs, episode_start=np.array([k == 0]))
            obs, _, _, _, info = e.step(a)
        out[name] = 0.5 * L - info["state"]["x"]
    p_l = 2000.0 / P.piston_area
    expected = P_K_DP * p_l / P.supply_pressure / ProportionalPositionController().kp
    assert out["p"] == pytest.approx(expected, rel=0.1)  # F_L > 0 pushes the piston towards x = 0
    assert abs(out["pid"]) < 0.05 * abs(out["p"])


def test_batch_equals_rows_and_episode_start_resets():
    rng = np.random.default_rng(0)
    obs = rng.uniform(-1, 1, (40, 4, 11))
    obs[..., 0] *= 3.0
    batch = ServoPIDController.from_params()
    rows = [ServoPIDController.from_params() for _ in range(4)]
    for k in range(40):
        starts = np.array([k == 0, k == 0 or k == 20, k == 0, k == 0 or k == 31])
        a_b, _ = batch.predict(obs[k], episode_start=starts)
        for i in range(4):
            a_i, _ = rows[i].predict(obs[k, i], episode_start=starts[i])
            assert a_i.shape == (1,)
            np.testing.assert_array_equal(a_b[i], a_i)
    assert a_b.shape == (4, 1)
    # episode_start resets the integrator (and the derivative memory) of that copy only
    c = ServoPIDController.from_params()
    o = np.zeros((2, 11))
    o[:, 1] = 5e-3 / (0.5 * L)  # reference 5 mm above the measured position: a constant 5 mm error
    o[:, 0] = 0.5
    for _ in range(50):
        c.predict(o)
    assert np.all(c.integral > 0)
    a_reset, _ = c.predict(o, episode_start=np.array([True, False]))
    a_fresh, _ = ServoPIDController.from_params().predict(o[0])
    assert a_reset[0, 0] == a_fresh[0] and a_reset[1, 0] > a_reset[0, 0]


def test_friction_feedforward_slow_sine(env):
    """PID vs PID with the identified Stribeck law in its pressure target, slow sines through
    reversals: the model swings the load pressure ahead of each reversal."""
    res = {}
    model = identified_friction("servo_cylinder", "stribeck")
    for freq in (0.2, 0.5):
        ref = 0.5 * L + 0.05 * L * np.sin(2 * np.pi * freq * T)
        xs_pid, r, _ = rollout(env, ServoPIDController.from_params(), ref, 0.5 * L)
        xs_ff, _, _ = rollout(env, ServoPIDController.from_params(model=model), ref, 0.5 * L)
        res[freq] = (rmse(r[200:] - xs_pid[200:]), rmse(r[200:] - xs_ff[200:]))
    print("slow-sine RMSE [m] (PID, PID+FF):", res)
    for pid, pff in res.values():
        assert pff < pid
    ff = ServoPIDController.from_params(model=model)
    # the feed-forward is the pressure target: zero at standstill, odd in v
    o = np.zeros(11)
    assert ff.feedforward(o[None])[0] == 0.0
    o2 = o.copy()
    o2[2] = 1e-3 / (0.5 * L)  # +1 mm in 10 ms -> 0.1 m/s
    assert ff.preview_velocity(0, o2[None])[0] == pytest.approx(0.1)
    o3 = o.copy()
    o3[3] = o2[2]  # the same between the 10 and 20 ms previews (the one the target uses)
    assert ff.feedforward(o3[None])[0] > 0


# ====================================================================== every env


def _nominal_reference(env_id, steps):
    """A hand-made reference per env (independent of the env's generators, except the table's,
    whose reference must be the acceleration of a feasible motion from rest)."""
    t = np.arange(steps + 60) * 1e-3
    if env_id == "hydro_envs/ServoCylinderPosition-v0":
        return 0.5 * L + 0.25 * L * np.sin(2 * np.pi * 1.0 * t)
    if env_id == "hydro_envs/RodlessCylinder-v0":
        Lr = RodlessCylinderParams().stroke
        return 0.5 * Lr + 0.2 * Lr * np.sin(2 * np.pi * 0.5 * t)
    if env_id == "hydro_envs/ShakingTable-v0":
        p = st.ShakingTableParams.preset("modified_ifas")
        return generate_table_reference("sine", np.random.default_rng(1), steps + 60, 1e-3, reference_limits(p))[0]
    if env_id == "hydro_envs/ForceActuator-v0":
        tf = np.arange(steps + 60) * 2e-4
        return 300.0 * np.where((tf * 10.0) % 1.0 < 0.5, 1.0, -1.0) + 100.0
    if env_id == "hydro_envs/LoadSensing-v0":
        v = np.zeros(steps + 60)
        v[150:] = 0.08
        v[900:] = 0.12
        return v
    raise AssertionError(env_id)


def _true_output(env_id, venv, info):
    b = venv._batch
    if env_id == "hydro_envs/ServoCylinderPosition-v0":
        return info["state"]["x"]
    if env_id == "hydro_envs/RodlessCylinder-v0":
        return info["state"]["y"]
    if env_id == "hydro_envs/ShakingTable-v0":
        return np.array([st.table_acceleration(b.Y[i], b.P[i]) for i in range(b.n)])
    if env_id == "hydro_envs/ForceActuator-v0":
        return info["params"]["sensor_stiffness"] * info["state"]["xs"]
    return info["state"]["va"]


def _closed_loop(env_id, ctrl, steps, n=2, seed=0):
    import gymnasium as gym

    cls = load_env_creator(gym.spec(env_id).vector_entry_point)
    venv = cls(num_envs=n, max_episode_steps=steps + 5, randomize=False)
    venv._batch.parallel = False
    ref = _nominal_reference(env_id, steps)
    obs, _ = venv.reset(seed=seed, options={"reference": ref})
    ys = np.zeros((steps, n))
    acts = np.zeros((steps, n, venv._batch.action_dim))
    start = np.ones(n, dtype=bool)
    for k in range(steps):
        a, _ = ctrl.predict(obs, episode_start=start)
        start[:] = False
        acts[k] = np.asarray(a).reshape(n, -1)
        obs, _, _, _, info = venv.step(a)
        ys[k] = _true_output(env_id, venv, info)
    venv.close()
    return ys, ref[1:steps + 1, None], acts


CASES = {  # env: (steps, skip) -- the RMSE is taken after `skip` steps (initial offset)
    "hydro_envs/ServoCylinderPosition-v0": (1500, 200),
    "hydro_envs/RodlessCylinder-v0": (1500, 300),
    "hydro_envs/ShakingTable-v0": (2000, 0),
    "hydro_envs/ForceActuator-v0": (1500, 0),
    "hydro_envs/LoadSensing-v0": (1500, 0),
}
BASELINE = {"hydro_envs/LoadSensing-v0": "passive"}


@pytest.fixture(scope="module")
def closed_loop_rmse():
    cache = {}

    def get(env_id, name):
        if (env_id, name) not in cache:
            steps, skip = CASES[env_id]
            ys, r, acts = _closed_loop(env_id, make_controller(env_id, name), steps)
            cache[(env_id, name)] = (float(np.sqrt(np.mean((r[skip:] - ys[skip:]) ** 2))), ys, acts)
        return cache[(env_id, name)]

    return get


@pytest.mark.parametrize("env_id,name", [(e, c) for e in CASES for c in controller_names(e)
                                         if c not in ("zero", "passive")])
def test_classical_controller_tracks_nominal_reference(closed_loop_rmse, env_id, name):
    rmse_c, ys, acts = closed_loop_rmse(env_id, name)
    base = BASELINE.get(env_id, "zero")
    rmse_0, _, _ = closed_loop_rmse(env_id, base)
    assert np.all(np.isfinite(ys)) and np.all(np.isfinite(acts))
    assert np.all(np.abs(acts) <= 1.0)
    if env_id == "hydro_envs/LoadSensing-v0":
        # honest: the CV PID only trims slow offsets; it must not be worse than the passive
        # hydro-mechanical compensator by more than 5 % (measured: equal within 1 %)
        assert rmse_c <= 1.05 * rmse_0, (rmse_c, rmse_0)
    elif env_id == "hydro_envs/ShakingTable-v0" and (name.startswith("pid") or name in ("flow_fb", "flow_fb_lugre")):
        # the table's LuGre seals (003 eq (11) as their steady state) stick at every reversal of
        # this sine and break away with acceleration spikes of order (F_s - F_c) / M that a PID on
        # the integrated acceleration error cannot remove (with the old tanh(7.33 v) friction the
        # seals never stuck: < 0.5 x zero). Measured: pid 0.83, pid_ff_stribeck 0.60,
        # pid_ff_neural 0.70 x zero, flow_fb (blind to friction) 0.51, flow_fb_lugre 0.55 (its
        # 30 um bristles against the main task's sines); flow (static identified friction) < 0.5
        assert rmse_c < 0.9 * rmse_0, (rmse_c, rmse_0)
    else:
        assert rmse_c < 0.5 * rmse_0, (rmse_c, rmse_0)


def test_model_based_beats_pid_on_the_hydraulic_plants(closed_loop_rmse):
    for env_id in ("hydro_envs/ServoCylinderPosition-v0", "hydro_envs/ShakingTable-v0"):
        flow = closed_loop_rmse(env_id, "flow")[0]
        pid = closed_loop_rmse(env_id, "pid")[0]
        assert flow < 0.8 * pid, (env_id, flow, pid)


@pytest.mark.parametrize("env_id", list(CASES))
def test_controllers_batch_equals_rows(env_id):
    import gymnasium as gym

    dim = gym.spec(env_id)
    cls = load_env_creator(dim.vector_entry_point)
    space = cls(num_envs=1, randomize=False).single_observation_space
    rng = np.random.default_rng(0)
    obs = rng.uniform(np.maximum(space.low, -1), np.minimum(space.high, 1), (25, 3, space.shape[0]))
    for name in controller_names(env_id):
        batch = make_controller(env_id, name)
        rows = [make_controller(env_id, name) for _ in range(3)]
        for k in range(25):
            starts = np.array([k == 0, k in (0, 10), k == 0])
            a_b, _ = batch.predict(obs[k], episode_start=starts)
            assert a_b.dtype == np.float32 and np.all(np.abs(a_b) <= 1.0)
            for i in range(3):
                a_i, _ = rows[i].predict(obs[k, i], episode_start=starts[i])
                np.testing.assert_allclose(a_b[i], a_i, rtol=1e-6, atol=1e-7, err_msg=f"{env_id} {name}")


@pytest.mark.parametrize("plant,truth", [
    ("servo_cylinder", {"F_c": P.coulomb_friction, "F_v": P.viscous_friction}),
    # the table's open-loop plateaus below ~30 mm/s stick-slip on the LuGre seals (the Stribeck
    # dip's slope, -41 kN s/m, beats F_v): their mean force is no steady-state point and the fit's
    # F_s comes out at 844 N of 1254 N (test_identified_table_static_level_is_low_from_stick_slip)
    # and F_v at 408 of 429 N s/m (5 %, trading off with the low F_s); F_c within 1 %
    ("shaking_table", {"F_c": st.ShakingTableParams().coulomb_friction}),
    # the rodless test's slowest plateau is 8.2 mm/s = 2.5 v_s, where the Stribeck excess is
    # e^-6.3 of F_s - F_c (0.04 N): the points do not determine F_s (the fit's comes from the
    # slow plateaus' +1.6 N stick-slip excess, test_identified_rodless_static_level_is_a_bound),
    # so only F_c and F_v are checked here
    ("rodless_cylinder", {"F_c": RodlessCylinderParams().coulomb_friction,
                          "F_v": RodlessCylinderParams().viscous_friction}),
])
def test_identified_friction_recovers_the_plant_law(plant, truth):
    fit = identified_friction(plant, "stribeck")
    for k, v in truth.items():
        assert fit.parameters[k] == pytest.approx(v, rel=0.03), (plant, k)
    vv = np.array([-0.1, -0.03, 0.03, 0.1])
    if plant == "shaking_table":
        return  # its stick-slip plateaus (above) are no static law the nets and the fit share
    for kind in ("neural", "rbf"):  # 002 sec. 5's two nets, trained on the same points
        net = identified_friction(plant, kind)
        np.testing.assert_allclose(net.predict(vv), fit.predict(vv), rtol=0.05, atol=2.0, err_msg=kind)


def test_identified_rodless_static_level_is_a_bound():
    """Reported, not hidden: the rodless open-loop test holds no plateau below 2.5 v_s, so its
    static level is not identified; the fit lands above F_c and below F_c plus twice the truth's
    excess (a loose bound, not a recovery)."""
    fit = identified_friction("rodless_cylinder", "stribeck")
    p = RodlessCylinderParams()
    assert p.coulomb_friction < fit.parameters["F_s"] < p.coulomb_friction + 2.0 * (p.static_friction - p.coulomb_friction)


def test_identified_table_static_level_is_low_from_stick_slip():
    """Reported, not hidden: the table's open-loop virtual test cannot hold a steady speed in the
    Stribeck dip (it stick-slips), so the identified static level underestimates F_s."""
    fit = identified_friction("shaking_table", "stribeck")
    f_s = st.ShakingTableParams().static_friction
    assert 0.55 * f_s < fit.parameters["F_s"] < 0.8 * f_s


def test_table_velocity_gain_of_the_tuning_rule_is_the_plant_s():
    """K_q of the table rule (orifice-law no-load speed) against an open-loop run: a held
    action of 0.2 moves the nominal table at 0.2 K_q within the friction/load-pressure loss."""
    from agents.controllers.shaking_table import table_tuning
    from hydro_envs import registry
    from hydro_envs.sim.stiffness import substeps_from_stiffness

    p = st.ShakingTableParams.preset("modified_ifas")
    t = table_tuning(p)
    y = st.rest_state(p, -0.1).reshape(1, -1)
    U = np.array([[0.2 * p.command_max]])
    nsub = np.array([substeps_from_stiffness(st.stiffness_modes(p), 1e-3)[0]])
    W = np.zeros((1, 5, st.N_STATES))
    for _ in range(400):
        registry.get("shaking_table").kernels.step_serial(y, U, p.to_array()[None], 1e-3, nsub, W, np.zeros(1, dtype=np.int64))
    assert y[0, st.V] == pytest.approx(0.2 * t["k_q"], rel=0.05)
    assert t["kp"] * t["k_q"] == pytest.approx(0.5)  # lambda (retuned for margins without dry friction)


def test_force_pid_gain_is_below_the_limit_cycle_onset():
    """The PID's proportional gain K_u / 2.2 (K_u of the loop without dry friction,
    tests/test_controller_margins.py) sits well below the nominal plant's limit-cycle onset
    (K_f = 4.05, with the controller's loop lag, eq (5)'s damping and the seals), and K_u below that onset: the
    seals' pre-sliding spring raises it."""
    from agents.controllers.force_actuator import K_ULTIMATE, force_tuning
    from hydro_envs.plants.force_actuator.closed_loop import limit_cycle_sweep

    t = force_tuning()
    pp, _ = limit_cycle_sweep(fa.ForceActuatorParams(), [t["kf"], K_ULTIMATE, 3.9, 4.1])
    assert pp[0] < 20.0 and pp[1] < 20.0 and pp[2] < 20.0 < pp[3]
