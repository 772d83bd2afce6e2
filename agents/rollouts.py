"""``hydro demo --rollouts``: servo-cylinder rollouts under the proportional position
controller of its controller module, with a summary of the tracking error, the drawn parameters
and the step rates."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import hydro_envs  # noqa: F401
from agents.controllers import controller_module
from hydro_envs import registry

ENV_ID = "hydro_envs/ServoCylinderPosition-v0"


def run_demo(episodes: int = 5, seed: int = 0) -> int:
    env = gym.make(ENV_ID)
    mod = controller_module(registry.spec_for_env(ENV_ID).name)
    ctrl = mod.ProportionalPositionController()
    print(f"hydro-envs demo: {episodes} randomised episodes of {ENV_ID} under a P controller "
          f"(K_p = {ctrl.kp:.1f} 1/m, loop bandwidth {mod.LOOP_BANDWIDTH:.0f} 1/s)\n")
    header = f"{'ep':>3} {'reference':>9} {'RMSE mm':>8} {'max|e| mm':>9} {'mass kg':>8} {'F_C N':>6} {'beta GPa':>8} {'substeps':>8} {'clamps':>6}"
    print(header)
    print("-" * len(header))
    t_total, n_total, rmses = 0.0, 0, []
    for ep in range(episodes):
        kind = ("steps", "smooth", "sine", "chirp")[ep % 4]
        obs, info = env.reset(seed=seed + ep, options={"reference": kind})
        errors = []
        t0 = time.perf_counter()
        done = False
        while not done:
            action, _ = ctrl.predict(obs)
            obs, reward, terminated, truncated, info = env.step(action)
            errors.append(obs[0] * ctrl.error_scale)
            done = terminated or truncated
        t_total += time.perf_counter() - t0
        n_total += len(errors)
        e = np.array(errors)
        rmse = float(np.sqrt(np.mean(e**2)))
        rmses.append(rmse)
        p = info["params"]
        print(f"{ep:>3} {kind:>9} {rmse*1e3:8.3f} {np.max(np.abs(e))*1e3:9.3f} {p['mass']:8.2f} "
              f"{p['coulomb_friction']:6.1f} {p['bulk_modulus']/1e9:8.3f} {env.unwrapped.n_substeps:8d} "
              f"{env.unwrapped.guard_clamps:6d}")
    print(f"\nmean tracking RMSE {np.mean(rmses)*1e3:.3f} mm over {episodes} episodes; "
          f"single env {n_total / t_total:,.0f} steps/s including the controller")

    n = 256
    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=seed)
    venv.step(ctrl.predict(obs)[0])  # compile/warm
    t0 = time.perf_counter()
    steps = 500
    for _ in range(steps):
        obs, *_ = venv.step(ctrl.predict(obs)[0])
    dt = time.perf_counter() - t0
    print(f"vector env: {n} copies x {steps} steps at {n * steps / dt / 1e6:.2f} M env-steps/s")
    return 0
