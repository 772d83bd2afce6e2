"""Env steps/s of an rl_zoo3 run's vector env against the package's own SB3 adapter.

Prints (no pass/fail; the target in brackets), for one env id and ``--n-envs`` copies stepped
with random actions in the same process:

* ``zoo, DummyVecEnv``: the vector env rl_zoo3 builds without the shipped ``vec_env_wrapper``
  (SB3's ``make_vec_env`` of single envs, each in a ``Monitor``);
* ``zoo, shipped YAML``: that env after :func:`agents.zoo.native_vec_env`, the wrapper the
  shipped ``configs/agents/*.yml`` name (the native batch env under a ``VecMonitor``);
* ``make_sb3_vec_env``: :func:`hydro_envs.envs.sb3.make_sb3_vec_env`, what ``agents.train`` uses.

and each rate as a ratio to the last  [zoo with the shipped YAML within 1.5x].

Usage: ``python bench/zoo_step_rate.py [--env ID] [--n-envs 64] [--steps 2000] [--repeats 5]``.
Timings are the best of ``--repeats`` runs.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np


def _actions(venv, steps: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo, hi = venv.action_space.low, venv.action_space.high
    return rng.uniform(lo, hi, size=(steps, venv.num_envs, *venv.action_space.shape)).astype(np.float32)


def _seconds(venv, acts: np.ndarray) -> float:
    t0 = time.perf_counter()
    for a in acts:
        venv.step(a)
    return time.perf_counter() - t0


def alternating_rates(venvs: dict, steps: dict, repeats: int) -> dict:
    """Best env-steps/s of each vector env, timed in alternating rounds (the machine's drift
    then hits every env alike)."""
    acts = {k: _actions(v, steps[k]) for k, v in venvs.items()}
    for v in venvs.values():
        v.reset()
    best = {k: np.inf for k in venvs}
    for _ in range(repeats):
        for k, v in venvs.items():
            best[k] = min(best[k], _seconds(v, acts[k]))
    return {k: steps[k] * venvs[k].num_envs / best[k] for k in venvs}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--env", default="hydro_envs/ServoCylinderPosition-v0")
    ap.add_argument("--n-envs", type=int, default=64, help="copies (the shipped PPO config's n_envs)")
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)

    import gymnasium as gym
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    import hydro_envs  # noqa: F401
    from agents.zoo import native_vec_env
    from hydro_envs.envs.sb3 import make_sb3_vec_env

    spec = gym.spec(args.env)
    with tempfile.TemporaryDirectory() as log:
        def zoo_env():  # as rl_zoo3's ExperimentManager.create_envs builds it
            return make_vec_env(lambda **kw: spec.make(**kw), n_envs=args.n_envs, seed=0, monitor_dir=log,
                                vec_env_cls=DummyVecEnv)

        venvs = {"zoo, DummyVecEnv": zoo_env(), "zoo, shipped YAML": native_vec_env(zoo_env()),
                 "make_sb3_vec_env": make_sb3_vec_env(args.env, n_envs=args.n_envs, seed=0)}
        steps = {k: args.steps for k in venvs}
        steps["zoo, DummyVecEnv"] = max(args.steps // 10, 50)  # about 10x slower: fewer steps
        rates = alternating_rates(venvs, steps, args.repeats)
    ref = rates["make_sb3_vec_env"]
    print(f"{args.env}, {args.n_envs} copies, random actions")
    print(f"{'vector env':<22} {'env-steps/s':>12} {'/ make_sb3_vec_env':>19}")
    for name, r in rates.items():
        print(f"{name:<22} {r:>12.0f} {r / ref:>19.3f}")


if __name__ == "__main__":
    main()
