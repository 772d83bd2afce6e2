"""agents/backend.py and the Ray backend of the benchmark, the diagnosis sweep and multi-seed
training: same results as serial. Needs the ``ray`` extra; skipped without it."""

import importlib
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from agents import backend as be

ray = pytest.importorskip("ray")

ROOT = Path(__file__).resolve().parents[1]
SERVO = "hydro_envs/ServoCylinderPosition-v0"


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray with 2 CPUs for this module (not a cluster named by $RAY_ADDRESS)."""
    if ray.is_initialized():  # pragma: no cover - another module left one running
        ray.shutdown()
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             runtime_env={"env_vars": {"PYTHONPATH": path}})
    # the stand-in policy below lives in this test module, which the workers cannot import
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    yield ray
    ray.shutdown()


# ------------------------------------------------------------------ the helper
def _square(x):
    return x * x


def _fail_on_three(x):
    if x == 3:
        raise ValueError(f"item {x} is bad: reason given here")
    return x


def test_backend_errors_without_ray_and_bad_arguments(monkeypatch):
    with pytest.raises(ValueError, match=r"backend = 'dask'; allowed serial, ray"):
        be.run_tasks(_square, [(1,)], backend="dask")
    with pytest.raises(ValueError, match=r"chunk_size must be an integer >= 1"):
        be.chunk_ranges(5, 0)
    assert be.chunk_ranges(5, 2) == [(0, 2), (2, 4), (4, 5)]
    assert be.chunk_ranges(0, 3) == []
    monkeypatch.setitem(sys.modules, "ray", None)  # as if the extra were not installed
    with pytest.raises(ImportError, match=r"pip install hydro-envs\[ray\]"):
        be.import_ray()


def test_map_chunks_keeps_order_and_raises_the_original_error(local_ray):
    items = list(range(11))
    seen = []
    for size in (None, 1, 3, 20):
        seen.clear()
        out = be.map_chunks(_square, items, backend="ray", chunk_size=size,
                            on_result=lambda i, r: seen.append((i, r)))
        assert out == [x * x for x in items]
        assert seen == list(enumerate(out))
    assert be.map_chunks(_square, items) == [x * x for x in items]  # serial
    assert be.run_tasks(_square, [(2,), (5,)], backend="ray") == [4, 25]
    with pytest.raises(ValueError, match=r"^item 3 is bad: reason given here$"):
        be.map_chunks(_fail_on_three, range(6), backend="ray", chunk_size=2)
    with pytest.raises(ValueError, match=r"^item 3 is bad: reason given here$"):
        be.map_chunks(_fail_on_three, range(6))


# ------------------------------------------------------------------ benchmark
class _StandIn:
    """A stand-in for a trained policy (P control with a seed-dependent gain)."""

    def __init__(self, gain):
        self.gain = gain

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.clip(self.gain * np.asarray(obs)[..., :1], -1, 1).astype(np.float32), state


def _loader(run):
    return _StandIn(0.1 if run.endswith("s0") else 0.2)


def _same(a, b, where=""):
    """Bit-for-bit equality of (nested) benchmark results; NaN equals NaN."""
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}/{k}")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    else:
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=where, strict=True)


@pytest.mark.slow  # 20-80 s: run by make test-all
def test_benchmark_on_ray_equals_serial_bit_for_bit(local_ray):
    from agents import benchmark as bm

    ctrls = ["pid", "pid_ff_stribeck", "sb3:runs/p_s0", "sb3:runs/p_s1"]
    kw = dict(params="in", n=4, seed=3, episode_steps=50, policy_loader=_loader, figures=False)
    serial = bm.run_benchmark(SERVO, ctrls, **kw)
    for chunk in (1, 3):  # single draws; uneven chunks (3 + 1 draws)
        par = bm.run_benchmark(SERVO, ctrls, backend="ray", chunk_size=chunk, **kw)
        assert par.draws == serial.draws
        assert par.members == serial.members
        _same(par.episodes, serial.episodes, f"episodes, chunk {chunk}")
        _same(par.summary, serial.summary, f"summary, chunk {chunk}")
        _same(par.param_arrays, serial.param_arrays, f"params, chunk {chunk}")
        _same(par.traces, serial.traces, f"traces, chunk {chunk}")
        assert par.dt == serial.dt and par.markdown() == serial.markdown()


def test_benchmark_cli_takes_the_backend(local_ray, capsys):
    from hydro_envs.cli import main as hydro_main

    args = ["benchmark", "--env", SERVO, "--controllers", "pid", "--n", "2", "--steps", "30", "--no-figures"]
    assert hydro_main(args) == 0
    serial = capsys.readouterr().out.splitlines()[:-1]  # last line: run time
    assert hydro_main(args + ["--backend", "ray", "--chunk-size", "1"]) == 0
    assert capsys.readouterr().out.splitlines()[:-1] == serial
    assert hydro_main(args + ["--backend", "ray", "--chunk-size", "0"]) == 2
    assert "--chunk-size = 0; allowed an integer >= 1" in capsys.readouterr().err


# ------------------------------------------------------------------ diagnosis sweep
@pytest.mark.slow  # 20-80 s: run by make test-all
def test_diagnosis_sweep_on_ray_equals_serial(local_ray):
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    bench = importlib.import_module("bench.diagnosis")
    cases = [("slider", "coulomb", 1001), ("slider", None, 5000)]
    kw = dict(duration=3.0, max_effects=1, candidates=("coulomb", "stribeck"), verbose=False)  # cheap cases
    serial = bench.run_cases(cases, **kw)
    par = bench.run_cases(cases, backend="ray", **kw)
    for r in serial + par:
        r.pop("seconds")
    assert all(r["named"] != "error" for r in serial), serial
    _same(par, serial, "diagnosis rows")


# ------------------------------------------------------------------ multi-seed training
def test_multiseed_arguments():
    from agents.multiseed import train_seeds

    with pytest.raises(ValueError, match=r"seeds must be distinct"):
        train_seeds(SERVO, "ppo", [0, 0])
    with pytest.raises(ValueError, match=r"'seed' cannot be passed"):
        train_seeds(SERVO, "ppo", [0], seed=1)
    with pytest.raises(ValueError, match=r"backend = 'mpi'"):
        train_seeds(SERVO, "ppo", [0], backend="mpi")


def test_multiseed_on_ray_equals_serial(local_ray, tmp_path):
    """One task per seed: the same weights and evaluations as the serial runs (torch threads 1)."""
    torch = pytest.importorskip("torch")
    pytest.importorskip("stable_baselines3")
    from agents.multiseed import train_seeds
    from agents.policies import load_trained

    hp = {"n_envs": 2, "n_steps": 16, "batch_size": 32, "n_epochs": 1,
          "policy_kwargs": {"net_arch": [8], "activation_fn": "tanh"}, "env_kwargs": {"max_episode_steps": 40}}
    kw = dict(hyperparams=hp, timesteps=32, eval_freq=0, n_eval_episodes=2, progress_bar=False)
    serial = train_seeds(SERVO, "ppo", [0, 1], name="ms", out=tmp_path / "serial", **kw)
    par = train_seeds(SERVO, "ppo", [0, 1], name="ms", out=tmp_path / "ray", backend="ray", **kw)
    assert [p.name for p in serial] == [p.name for p in par] == ["ms_s0", "ms_s1"]
    assert all(p.parent == (tmp_path / "ray").resolve() for p in par)
    for a, b in zip(serial, par):
        sa, sb = load_trained(a).model.policy.state_dict(), load_trained(b).model.policy.state_dict()
        for k in sa:
            assert torch.equal(sa[k], sb[k]), (a.name, k)
        np.testing.assert_array_equal(np.load(a / "evaluations.npz")["results"],
                                      np.load(b / "evaluations.npz")["results"])
    s0, s1 = (load_trained(p).model.policy.state_dict() for p in serial)
    assert not all(torch.equal(s0[k], s1[k]) for k in s0)  # the seeds differ
    with pytest.raises(FileExistsError, match=r"ms_s0 exists"):  # a task's error, re-raised as it was
        train_seeds(SERVO, "ppo", [0], name="ms", out=tmp_path / "ray", backend="ray", **kw)
