"""``hydro demo``: servo-cylinder rollouts under a proportional controller, with a summary.

The controller is the classical loop for a valve-controlled cylinder: the plant is an
integrator with velocity gain ``K_q = v_noload`` per unit action (orifice law, 002 eqs
(3)-(5)), so ``a = K_p e`` closes a first-order loop with bandwidth ``K_q K_p``. We place it
at 40 1/s, well below the usual stability limit ``2 zeta_h omega_h`` of a valve-controlled
cylinder (omega_h = 680 rad/s at the stroke end, zeta_h ~ 0.1 gives 136 1/s).
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import hydro_envs  # noqa: F401
from hydro_envs.plants.servo_cylinder import ServoCylinderParams, no_load_velocity

ENV_ID = "hydro_envs/ServoCylinderPosition-v0"
LOOP_BANDWIDTH = 40.0  # 1/s


class ProportionalPositionController:
    """``a = K_p (r - x)`` on the env observation (SB3-style ``predict``)."""

    def __init__(self, nominal: ServoCylinderParams | None = None, error_scale: float = 0.01,
                 bandwidth: float = LOOP_BANDWIDTH) -> None:
        nominal = nominal or ServoCylinderParams()
        self.kp = bandwidth / no_load_velocity(nominal)  # action per metre of error
        self.error_scale = error_scale

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(obs)
        error = obs[..., 0:1] * self.error_scale  # obs[0] = e / error_scale
        return np.clip(self.kp * error, -1.0, 1.0).astype(np.float32), state


def run_demo(episodes: int = 5, seed: int = 0) -> int:
    env = gym.make(ENV_ID)
    ctrl = ProportionalPositionController()
    print(f"hydro-envs demo: {episodes} randomised episodes of {ENV_ID} under a P controller "
          f"(K_p = {ctrl.kp:.1f} 1/m, loop bandwidth {LOOP_BANDWIDTH:.0f} 1/s)\n")
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
