"""The agent configs are rl-baselines3-zoo files as they are.

The fast tests read every entry the way rl_zoo3 does (``policy_kwargs`` is ``eval``-ed with
``torch.nn`` as ``nn``; ``normalize`` is a bool or a mapping) and check that the result is what
SB3 takes. The slow test trains each algorithm for a few thousand steps with ``rl_zoo3.train``
itself (``pip install -e .[zoo]``; ``make test-all`` installs it).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from agents.policy_kwargs import parse_policy_kwargs, policy_kwargs_object

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs" / "agents").glob("*.yml"))


def _entries():
    for path in CONFIGS:
        for env_id, entry in yaml.safe_load(path.read_text()).items():
            yield path.stem, env_id, entry


@pytest.mark.parametrize("algo,env_id,entry", list(_entries()), ids=lambda v: v if isinstance(v, str) else "")
def test_entry_reads_as_the_zoo_reads_it(algo, env_id, entry):
    torch = pytest.importorskip("torch")
    from hydro_envs import registry

    assert env_id in {e.id for _, e in registry.env_entries()}, env_id
    pk = entry["policy_kwargs"]
    assert isinstance(pk, str) and pk.startswith("dict("), f"{algo} {env_id}: policy_kwargs must be the zoo's string"
    zoo = eval(pk, {"__builtins__": {}}, {"dict": dict, "nn": torch.nn})  # what rl_zoo3 does
    act = zoo.get("activation_fn")
    assert act is None or (isinstance(act, type) and issubclass(act, torch.nn.Module)), act
    # the project's own (non-evaluating) parser gives the same SB3 kwargs
    assert policy_kwargs_object(parse_policy_kwargs(pk)) == zoo
    assert isinstance(entry.get("normalize", False), (bool, dict))
    assert str(entry["learning_rate"]).replace("lin_", "").replace(".", "", 1).replace("e-", "", 1).isdigit()


@pytest.mark.slow
@pytest.mark.parametrize("algo", [p.stem for p in CONFIGS])
def test_rl_zoo3_trains_with_the_shipped_config(algo, tmp_path):
    pytest.importorskip("rl_zoo3")
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", algo, "--env", "hydro_envs/ServoCylinderPosition-v0",
           "--gym-packages", "hydro_envs", "-conf", str(CONFIGS[[p.stem for p in CONFIGS].index(algo)]),
           "-n", "4096", "--eval-freq", "-1", "-f", str(tmp_path), "--seed", "0",
           "--hyperparams", "learning_starts:1000"] if algo != "ppo" else [
           sys.executable, "-m", "rl_zoo3.train", "--algo", algo, "--env", "hydro_envs/ServoCylinderPosition-v0",
           "--gym-packages", "hydro_envs", "-conf", str(CONFIGS[[p.stem for p in CONFIGS].index(algo)]),
           "-n", "4096", "--eval-freq", "-1", "-f", str(tmp_path), "--seed", "0"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    assert list(tmp_path.glob(f"{algo}/*/*.zip")), r.stdout[-2000:]
    # the shipped vec_env_wrapper gave the zoo the native batch env (agents/zoo.py), not a DummyVecEnv
    assert list(tmp_path.glob(f"{algo}/*/native.monitor.csv")), sorted(p.name for p in tmp_path.glob(f"{algo}/*/*"))
    from agents.policies import load_trained

    run = next(tmp_path.glob(f"{algo}/*/*.zip")).parent
    assert load_trained(run, trust_pickle=True).env_id == "hydro_envs/ServoCylinderPosition-v0"
