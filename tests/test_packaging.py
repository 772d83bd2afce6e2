"""The built wheel works without the repository: package data present, every env id runs."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from hydro_envs import registry

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(out),
                    str(ROOT)], check=True, cwd=out)
    (whl,) = out.glob("hydro_envs-*.whl")
    return whl


def test_wheel_ships_every_config(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for spec in registry.specs(with_model=True):
        if spec.randomization_file() is not None:
            plant = spec.package.rsplit(".", 1)[-1]
            assert f"hydro_envs/configs/plants/{plant}/randomization.yaml" in names, spec.name
    # every file of the top-level configs/ folder ships as hydro_envs.configs
    shipped_repo = {"hydro_envs/" + p.relative_to(ROOT).as_posix() for p in ROOT.glob("configs/**/*.y*ml")}
    assert len(shipped_repo) > 30 and shipped_repo <= names, sorted(shipped_repo - names)
    assert not any(n.startswith(("tests/", "configs/", "docs/")) for n in names)


_CHILD = """
import gymnasium as gym, numpy as np, hydro_envs
from hydro_envs import registry
assert "{target}" in hydro_envs.__file__, hydro_envs.__file__
for _, e in registry.env_entries():
    env = gym.make(e.id)
    env.reset(seed=0)
    for _ in range(3):
        obs, *_ = env.step(env.action_space.sample())
    assert np.all(np.isfinite(obs)), e.id
    print("ENV", e.id)
from hydro_envs.config_files import config_root
assert "{target}" in str(config_root()), config_root()
from agents.benchmark_cli import SHIPPED_CONFIGS, load_config, config_path
names = sorted(f.stem for f in SHIPPED_CONFIGS.glob("*.yaml"))
assert len(names) >= 14, names
from agents.benchmark_cli import _policy_path, _preflight_policies
for name in names:  # every shipped config found by name and loaded from the wheel, with the policies it names
    assert "{target}" in str(config_path(name)), config_path(name)
    cfg = load_config(config_path(name))
    runs = [_policy_path(str(r)) for r in cfg.get("policies") or []]
    assert all("{target}" in r for r in runs), runs
    if runs:
        _preflight_policies(cfg["env"], [f"sb3:{{r}}" for r in runs], False)
from hydro_envs.cli import main
# and the benchmark runs from the wheel (2 draws, 20 steps, no figures) on a config with policies;
# the others differ in controllers, which run from the repository in test_benchmark
assert main(["benchmark", "--config", "force_actuator", "--n", "2", "--steps", "20", "--params", "nominal",
             "--no-figures", "--out", "bench_force_actuator"]) == 0
"""


def test_installed_wheel_alone_makes_resets_and_steps_every_env(wheel, tmp_path):
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
                   check=True)
    env = {**os.environ, "PYTHONPATH": str(target), "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    run = subprocess.run([sys.executable, "-c", _CHILD.format(target=target)], cwd=tmp_path, env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    made = [ln for ln in run.stdout.splitlines() if ln.startswith("ENV ")]
    assert len(made) == len(list(registry.env_entries())) == 14, run.stdout[-2000:]
