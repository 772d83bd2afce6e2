"""SB3 training (agents/train.py), hyperparameter files (configs/agents/) and trained-policy
loading (agents/policies.py).

Tiny runs (a few hundred timesteps, 16-unit nets, 100-step episodes) check the run folder, the
round trip of the resolved config, the frozen evaluation normalisation, reproducibility and the
configuration errors. The checks of truth: the logged final evaluation equals an independent
rollout of the saved model behind its saved statistics with raw env rewards; evaluation leaves
the statistics untouched; two runs with the same seed agree bit for bit.
"""

from __future__ import annotations

import csv
import json
import math

import hydro_envs  # noqa: F401  (as agents/train.py: the OpenMP wait default before torch loads)
import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")
torch = pytest.importorskip("torch")

from stable_baselines3.common.callbacks import BaseCallback  # noqa: E402

from agents import train as T  # noqa: E402
from agents.policies import load_trained  # noqa: E402
from hydro_envs.envs.sb3 import make_sb3_vec_env  # noqa: E402

ENV = "hydro_envs/ServoCylinderPosition-v0"
EP = 100  # episode length of the tiny runs [steps]
N_EVAL = 3
TINY_PPO = {"n_envs": 4, "n_steps": 64, "batch_size": 64, "n_epochs": 2,
            "policy_kwargs": {"net_arch": [16, 16], "activation_fn": "tanh", "log_std_init": -1.0},
            "env_kwargs": {"max_episode_steps": EP}}
TINY_SAC = {"n_envs": 2, "learning_starts": 100, "batch_size": 32, "buffer_size": 2000, "gradient_steps": 1,
            "policy_kwargs": {"net_arch": [16, 16]}, "env_kwargs": {"max_episode_steps": EP}}
RUN_FILES = ("config.yml", "args.json", "model.zip", "vecnormalize.pkl", "best_model.zip",
             "best_vecnormalize.pkl", "evaluations.csv", "evaluations.npz")


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


class ActionRecorder(BaseCallback):
    """The actions sent to the env in the first ``n`` env steps."""

    def __init__(self, n: int) -> None:
        super().__init__()
        self.n = n
        self.actions: list[np.ndarray] = []

    def _on_step(self) -> bool:
        if len(self.actions) < self.n:
            a = self.locals.get("clipped_actions", self.locals.get("actions"))
            self.actions.append(np.array(a, copy=True))
        return True


def _run(tmp, algo, hp, name, seed=0, timesteps=512, randomize=True, eval_freq=256, rec=None):
    return T.train(ENV, algo, hyperparams=hp, timesteps=timesteps, seed=seed, randomize=randomize,
                   out=tmp, name=name, eval_freq=eval_freq, n_eval_episodes=N_EVAL, progress_bar=False,
                   callbacks=[rec] if rec else ())


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("runs")
    rec = ActionRecorder(64)  # the whole first rollout (n_steps = 64)
    return _run(tmp, "ppo", TINY_PPO, "ppo_a", rec=rec), rec


@pytest.fixture(scope="module")
def sac_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("runs")
    return _run(tmp, "sac", TINY_SAC, "sac_nominal", timesteps=300, randomize=False, eval_freq=0)


@pytest.mark.parametrize("which", ["ppo", "sac"])
def test_run_folder_holds_every_artifact(which, ppo_run, sac_run):
    run = ppo_run[0] if which == "ppo" else sac_run
    for f in RUN_FILES:
        assert (run / f).is_file(), f
    events = list((run / "tb").rglob("events.out.tfevents.*"))
    assert events and all(e.stat().st_size > 0 for e in events)
    args = json.loads((run / "args.json").read_text())
    assert args["env_id"] == ENV and args["algo"] == which and args["seed"] == 0
    assert args["randomize"] is (which == "ppo")
    cfg = yaml.safe_load((run / "config.yml").read_text())[ENV]
    assert ("randomize" not in cfg["env_kwargs"]) if which == "ppo" else (cfg["env_kwargs"]["randomize"] is False)
    with open(run / "evaluations.csv") as fh:
        rows = list(csv.DictReader(fh))
    npz = np.load(run / "evaluations.npz")
    # PPO: evaluations at 256 and 512 timesteps; SAC (eval_freq 0): only the final one
    expected = [256, 512] if which == "ppo" else [300]
    assert [int(r["timesteps"]) for r in rows] == expected
    assert npz["timesteps"].tolist() == expected
    assert npz["results"].shape == (len(expected), N_EVAL)
    assert np.all(npz["ep_lengths"] == EP)
    assert npz["eval_seeds"].tolist() == [T.DEFAULT_EVAL_SEED + i for i in range(N_EVAL)]
    for r, res in zip(rows, npz["results"]):
        assert float(r["mean_return"]) == pytest.approx(res.mean(), rel=1e-12)
        assert math.isfinite(float(r["mean_return"])) and float(r["max_return"]) <= 0.0  # rewards <= 0


def test_resolved_config_round_trips(ppo_run, sac_run):
    for run, algo in ((ppo_run[0], "ppo"), (sac_run, "sac")):
        stored = yaml.safe_load((run / "config.yml").read_text())
        again = T.resolve_config(T.load_agent_config(run / "config.yml", algo, ENV), algo, ENV)
        assert again == stored[ENV]
        # the stored entry is complete: every SB3 constructor argument is written out
        assert set(T._algo_defaults(algo)) <= set(stored[ENV])
        assert stored[ENV]["policy_kwargs"]["net_arch"] == [16, 16]


def test_shipped_configs_resolve_for_every_env():
    ids = sorted(e.id for _, e in hydro_envs.registry.env_entries())
    for algo in T.ALGOS:
        data = yaml.safe_load(T.config_path(algo).read_text())
        assert sorted(data) == ids, algo
        for env_id in ids:
            cfg = T.resolve_config(T.load_agent_config(None, algo, env_id), algo, env_id)
            assert cfg["normalize"]["norm_obs"] is True
            if algo == "ppo":
                assert cfg["n_steps"] * cfg["n_envs"] >= 2048
            else:
                assert cfg["normalize"]["norm_reward"] is False and 0.97 <= cfg["gamma"] <= 0.999


def test_final_evaluation_equals_independent_rollout_of_saved_policy(ppo_run):
    """The last logged evaluation (final model, statistics synced at the end) equals a rollout
    of load_trained(run) on fresh copies seeded eval_seed + i, summing raw env rewards."""
    run = ppo_run[0]
    pol = load_trained(run)
    venv = make_sb3_vec_env(ENV, n_envs=N_EVAL, seed=T.DEFAULT_EVAL_SEED, max_episode_steps=EP)
    obs = venv.reset()
    ret = np.zeros(N_EVAL)
    for _ in range(EP):
        a, _ = pol.predict(obs)
        obs, r, d, _ = venv.step(a)
        ret += r
    assert d.all()
    logged = np.load(run / "evaluations.npz")["results"][-1]
    np.testing.assert_array_equal(ret, logged)


def test_load_trained_predicts_in_the_action_space(ppo_run, sac_run):
    for run in (ppo_run[0], sac_run):
        pol = load_trained(run)
        space = pol.action_space
        rng = np.random.default_rng(0)
        obs_space = pol.observation_space
        batch = rng.uniform(obs_space.low, obs_space.high, (32, *obs_space.shape)).astype(np.float32)
        a, state = pol.predict(batch)
        assert a.shape == (32, *space.shape) and state is None
        assert np.all(a >= space.low) and np.all(a <= space.high)
        a1, _ = pol.predict(batch[0], episode_start=np.array([True]))
        assert a1.shape == space.shape
        np.testing.assert_allclose(a1, a[0], rtol=1e-5, atol=1e-7)  # batch vs single matmul: 1 ulp
        # normalisation = the saved VecNormalize statistics, clipped
        vn = pol.obs_normalizer
        manual = np.clip((batch - vn.obs_rms.mean) / np.sqrt(vn.obs_rms.var + vn.epsilon), -vn.clip_obs, vn.clip_obs)
        np.testing.assert_allclose(pol.normalize(batch), manual, rtol=1e-6, atol=1e-6)
        assert vn.training is False and vn.norm_reward is False
        with pytest.raises(ValueError, match="obs must have shape"):
            pol.predict(np.zeros(3, dtype=np.float32))
        with pytest.raises(ValueError, match="finite"):
            pol.predict(np.full(obs_space.shape, np.nan, dtype=np.float32))
    best = load_trained(ppo_run[0], which="best")
    assert best.predict(batch)[0].shape == (32, 1)
    with pytest.raises(FileNotFoundError):
        load_trained(ppo_run[0].parent / "missing")


def test_evaluation_uses_frozen_statistics_and_fixed_draws(ppo_run):
    """Evaluation copies the training statistics, never updates them, never normalises the
    reward, and sees the same seeded parameter draws every time."""
    cfg = T.resolve_config(T.load_agent_config(None, "ppo", ENV), "ppo", ENV, TINY_PPO)
    train_env, eval_env = T.make_envs(ENV, cfg, seed=0, n_eval_episodes=N_EVAL)
    assert eval_env.training is False and eval_env.norm_reward is False
    train_env.reset()
    rng = np.random.default_rng(1)
    for _ in range(50):  # give the training statistics something to learn
        train_env.step(rng.uniform(-1, 1, (cfg["n_envs"], 1)).astype(np.float32))
    mean_before = train_env.obs_rms.mean.copy()
    count_before = train_env.obs_rms.count
    pol = load_trained(ppo_run[0])
    r1, l1 = T.evaluate(pol.model, eval_env, T.DEFAULT_EVAL_SEED, train_env)
    assert eval_env.training is False and eval_env.norm_reward is False
    # the eval statistics are a copy of the training ones and did not move during evaluation
    np.testing.assert_array_equal(eval_env.obs_rms.mean, mean_before)
    assert eval_env.obs_rms.count == count_before
    assert eval_env.obs_rms is not train_env.obs_rms
    np.testing.assert_array_equal(train_env.obs_rms.mean, mean_before)
    assert np.all(l1 == EP) and np.all(r1 <= 0)
    # same draws every evaluation: same returns, and the reset parameters repeat
    r2, _ = T.evaluate(pol.model, eval_env, T.DEFAULT_EVAL_SEED, train_env)
    np.testing.assert_array_equal(r1, r2)
    batch = eval_env.venv.venv.unwrapped._batch
    draws = []
    for _ in range(2):
        eval_env.seed(T.DEFAULT_EVAL_SEED)
        eval_env.reset()
        draws.append(batch.P.copy())
    np.testing.assert_array_equal(draws[0], draws[1])
    assert not np.array_equal(draws[0][0], draws[0][1])  # randomised: the copies differ
    # raw rewards: the eval env's reward equals the original (unnormalised) one
    _, r, _, _ = eval_env.step(np.zeros((N_EVAL, 1), dtype=np.float32))
    np.testing.assert_array_equal(r, eval_env.get_original_reward())


def test_nominal_training_evaluates_the_nominal_plant(sac_run):
    cfg = yaml.safe_load((sac_run / "config.yml").read_text())[ENV]
    _, eval_env = T.make_envs(ENV, cfg, seed=0, n_eval_episodes=N_EVAL)
    eval_env.seed(5)
    eval_env.reset()
    P = eval_env.venv.venv.unwrapped._batch.P
    assert np.all(P == P[0])


def test_same_seed_same_first_rollout_and_weights(ppo_run, tmp_path):
    """Bit-identical on CPU with torch.set_num_threads(1): the first rollout's actions and the
    final weights of two runs with seed 0; seed 1 differs."""
    run_a, rec_a = ppo_run
    rec_b = ActionRecorder(64)
    run_b = _run(tmp_path, "ppo", TINY_PPO, "ppo_b", rec=rec_b)
    assert len(rec_a.actions) == len(rec_b.actions) == 64
    np.testing.assert_array_equal(np.array(rec_a.actions), np.array(rec_b.actions))
    pa, pb = load_trained(run_a).model.policy.state_dict(), load_trained(run_b).model.policy.state_dict()
    for k in pa:
        assert torch.equal(pa[k], pb[k]), k
    np.testing.assert_array_equal(np.load(run_a / "evaluations.npz")["results"],
                                  np.load(run_b / "evaluations.npz")["results"])
    rec_c = ActionRecorder(1)
    _run(tmp_path, "ppo", {**TINY_PPO, "n_steps": 16, "batch_size": 64}, "ppo_c", seed=1, timesteps=64,
         rec=rec_c, eval_freq=0)
    assert not np.array_equal(rec_c.actions[0], rec_a.actions[0])


@pytest.mark.parametrize(
    "algo, over, match",
    [
        ("ppo", {"learnin_rate": 1e-3}, "learnin_rate"),
        ("ppo", {"gamma": 1.5}, "gamma"),
        ("ppo", {"gamma": "fast"}, "gamma"),
        ("ppo", {"n_steps": 0}, "n_steps"),
        ("ppo", {"batch_size": 10**6}, "batch_size"),
        ("ppo", {"learning_rate": "lin_-1"}, "learning_rate"),
        ("ppo", {"n_envs": 2.5}, "n_envs"),
        ("ppo", {"policy": "CnnPolicy"}, "policy"),
        ("ppo", {"policy_kwargs": {"net_arch": [64, -1]}}, "net_arch"),
        ("ppo", {"policy_kwargs": {"net_arch": {"pi": [8], "qf": [8]}}}, "net_arch"),
        ("ppo", {"policy_kwargs": {"activation_fn": "sigmoid"}}, "activation_fn"),
        ("ppo", {"policy_kwargs": {"n_critics": 2}}, "n_critics"),
        ("ppo", {"normalize": {"norm_obs": True, "clip": 5}}, "normalize.clip"),
        ("ppo", {"normalize": {"clip_obs": 0}}, "clip_obs"),
        ("ppo", {"noise_std": 0.1}, "noise_std"),
        ("sac", {"tau": 0}, "tau"),
        ("sac", {"ent_coef": "automatic"}, "ent_coef"),
        ("sac", {"train_freq": [1, "rollout"]}, "train_freq"),
        ("sac", {"gradient_steps": 0}, "gradient_steps"),
        ("td3", {"noise_type": "pink"}, "noise_type"),
        ("td3", {"policy_delay": 0}, "policy_delay"),
        ("td3", {"env_kwargs": ["randomize"]}, "env_kwargs"),
    ],
)
def test_bad_config_raises_naming_the_key(algo, over, match):
    entry = T.load_agent_config(None, algo, ENV)
    with pytest.raises(T.ConfigError, match=match) as exc:
        T.resolve_config(entry, algo, ENV, over)
    assert ENV in str(exc.value)


def test_bad_files_envs_and_env_kwargs(tmp_path, capsys):
    with pytest.raises(T.ConfigError, match="no entry for env"):
        T.load_agent_config({"hydro_envs/Other-v0": {}}, "ppo", ENV)
    bad = tmp_path / "bad.yml"
    bad.write_text(yaml.safe_dump({ENV: {"n_envs": 2, "n_timesteps": 100, "policy": "MlpPolicy", "gama": 0.9}}))
    with pytest.raises(T.ConfigError, match=r"bad\.yml.*gama"):
        T.resolve_config(T.load_agent_config(bad, "ppo", ENV), "ppo", ENV)
    missing = tmp_path / "missing.yml"
    missing.write_text(yaml.safe_dump({ENV: {"n_envs": 2, "policy": "MlpPolicy"}}))
    with pytest.raises(T.ConfigError, match="n_timesteps"):
        T.resolve_config(T.load_agent_config(missing, "ppo", ENV), "ppo", ENV)
    with pytest.raises(T.ConfigError, match="not registered"):
        T.train("hydro_envs/Nope-v0", "ppo", out=tmp_path)
    with pytest.raises(T.ConfigError, match="algo"):
        T.train(ENV, "a2c", out=tmp_path)
    # the env's own check of an env kwarg is reported as a config error
    cfg = T.resolve_config(T.load_agent_config(None, "ppo", ENV), "ppo", ENV,
                           {"env_kwargs": {"error_scale": -1.0}, "n_envs": 2, "n_steps": 8, "batch_size": 8})
    with pytest.raises(T.ConfigError, match="error_scale"):
        T.make_envs(ENV, cfg, seed=0, n_eval_episodes=0)
    with pytest.raises(T.ConfigError, match="max_episode_step"):
        T.train(ENV, "ppo", out=tmp_path, hyperparams={"env_kwargs": {"max_episode_step": 10}}, progress_bar=False)
    # the command line reports config errors with exit code 2 and the key in the message
    rc = T.main(["--env", ENV, "--algo", "ppo", "--out", str(tmp_path), "--no-progress-bar",
                 "--hyperparams", "gamma=2"])
    assert rc == 2 and "gamma" in capsys.readouterr().err
    assert not any(tmp_path.glob("ServoCylinder*"))  # nothing written for a rejected config
