"""SB3 training throughput and time-to-PID on the servo cylinder.

Prints (no pass/fail):

* default mode -- SB3 training steps/s on ``hydro_envs/ServoCylinderPosition-v0`` with the
  batched-kernel adapter (:func:`hydro_envs.envs.sb3.make_sb3_vec_env`: one compiled kernel call
  steps every copy) versus SB3's ``DummyVecEnv`` of ``gymnasium.make`` envs (a Python loop over
  the copies), both inside ``VecNormalize`` as in :mod:`agents.train`; the batched adapter once
  with one numba thread and once with numba's default (all cores). For PPO with 8 and 64
  copies (rollout ``n_steps * n_envs = 2048``, 10 epochs of minibatch 256, 64-64 MLP) it
  reports the rollout-collection rate (policy forward + env step) and the overall rate
  including the updates; for SAC with 1 and 4 copies (one gradient step of batch 256 per env
  step, 256-256 MLP) the overall rate after ``learning_starts``. The best of ``--repeats``.

* ``--time-to-pid`` -- trains PPO or SAC (``configs/agents/<algo>.yml``, constant learning
  rate) on the *nominal* servo env (no randomisation) and every ``--eval-every`` timesteps
  measures the tracking RMSE of the deterministic policy on ``--n-eval`` fixed episodes
  (the env's ``--reference`` kind, default ``mixed``, for training and evaluation; seeds
  ``eval_seed + i``, nominal plant, 2 s each), the same
  episodes on which :class:`agents.controllers.PIDController` (tuned from the nominal plant) is
  measured once. RMSE is that of the *true* position against the reference it is compared
  with (``x_k`` after step ``k`` against ``r[k+1]``, as in ``tests/test_controllers.py``),
  over all episodes after the first 200 ms (the initial transient from the random start
  position, where both saturate). It prints the wall and process-CPU minutes of training
  (evaluation time excluded) until the learned RMSE is at or below PID's, or says it did not
  get there within ``--budget-min`` wall minutes.

Usage::

    python bench/training.py [--repeats 2] [--quick]
    python bench/training.py --time-to-pid [--algo ppo|sac] [--budget-min 10] [--eval-every N]
                             [--reference mixed|steps|smooth|sine|chirp]

``--quick`` measures fewer steps. Run on an otherwise idle machine; torch uses
``--torch-threads`` threads (default 1), numba all cores.
"""

from __future__ import annotations

import os

# main() applies the package's OpenMP spin setting before torch and numba load libgomp
# (hydro_envs/_openmp.py); set OMP_WAIT_POLICY or GOMP_SPINCOUNT in the environment to measure another
import hydro_envs  # noqa: E402

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ENV_ID = "hydro_envs/ServoCylinderPosition-v0"
SKIP_STEPS = 200  # initial transient excluded from the RMSE [steps = ms]


# --------------------------------------------------------------------------- throughput
def _venv(kind: str, n_envs: int, seed: int = 0):
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from hydro_envs.envs.sb3 import make_sb3_vec_env

    if kind == "batched":
        venv = make_sb3_vec_env(ENV_ID, n_envs=n_envs, seed=seed)
    else:
        venv = DummyVecEnv([lambda: gym.make(ENV_ID) for _ in range(n_envs)])
        venv.seed(seed)
    return VecNormalize(venv, norm_obs=True, norm_reward=True, gamma=0.99)


def _timing_callback():
    from stable_baselines3.common.callbacks import BaseCallback

    class RolloutTimer(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.rollout_s = 0.0
            self.rollout_steps = 0
            self._t = 0.0
            self._n = 0

        def _on_rollout_start(self) -> None:
            self._t, self._n = time.perf_counter(), self.num_timesteps

        def _on_rollout_end(self) -> None:
            self.rollout_s += time.perf_counter() - self._t
            self.rollout_steps += self.num_timesteps - self._n

        def _on_step(self) -> bool:
            return True

    return RolloutTimer()


def ppo_rate(kind: str, n_envs: int, rollouts: int) -> tuple[float, float]:
    """(rollout steps/s, overall training steps/s) of PPO over ``rollouts`` rollouts of 2048."""
    from stable_baselines3 import PPO

    venv = _venv(kind, n_envs)
    n_steps = max(2048 // n_envs, 1)
    model = PPO("MlpPolicy", venv, n_steps=n_steps, batch_size=256, n_epochs=10, seed=0, device="cpu",
                policy_kwargs=dict(net_arch=dict(pi=[64, 64], vf=[64, 64])))
    model.learn(n_steps * n_envs)  # warm-up: compilation, allocations
    timer = _timing_callback()
    total = rollouts * n_steps * n_envs
    t0 = time.perf_counter()
    model.learn(total, callback=timer, reset_num_timesteps=False)
    wall = time.perf_counter() - t0
    venv.close()
    return timer.rollout_steps / timer.rollout_s, total / wall


def sac_rate(kind: str, n_envs: int, steps: int) -> float:
    """Overall SAC training steps/s (one gradient step per env step) after learning_starts."""
    from stable_baselines3 import SAC

    venv = _venv(kind, n_envs)
    model = SAC("MlpPolicy", venv, learning_starts=256, batch_size=256, train_freq=1, gradient_steps=n_envs,
                seed=0, device="cpu", policy_kwargs=dict(net_arch=[256, 256]))
    model.learn(300)  # fills learning_starts, warms up
    t0 = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False)
    wall = time.perf_counter() - t0
    venv.close()
    return steps / wall


def throughput(repeats: int, quick: bool) -> None:
    import numba
    import torch

    rollouts = 2 if quick else 4
    sac_steps = 300 if quick else 2000
    n_threads = numba.config.NUMBA_NUM_THREADS
    kinds = [("batched", 1), ("batched", n_threads), ("dummy", n_threads)] if n_threads > 1 else [
        ("batched", 1), ("dummy", 1)]
    print(f"SB3 training throughput on {ENV_ID} (best of {repeats}; env steps/s; torch threads "
          f"{torch.get_num_threads()}; OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}, "
          f"GOMP_SPINCOUNT={os.environ.get('GOMP_SPINCOUNT')}; "
          f"load average at start {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs)")
    print("'batched/k': make_sb3_vec_env with k numba threads; 'Dummy': DummyVecEnv of gymnasium.make envs")
    print(f"{'algo':<5} {'n_envs':>6} {'env':<10} {'rollout':>9} {'train':>9}")
    for n in (8, 64):
        for kind, nt in kinds:
            numba.set_num_threads(nt)
            r, t = max((ppo_rate(kind, n, rollouts) for _ in range(repeats)), key=lambda x: x[1])
            label = f"batched/{nt}" if kind == "batched" else "Dummy"
            print(f"{'PPO':<5} {n:>6} {label:<10} {r:>9.0f} {t:>9.0f}", flush=True)
    for n in (1, 4):
        for kind, nt in kinds:
            numba.set_num_threads(nt)
            t = max(sac_rate(kind, n, sac_steps) for _ in range(repeats))
            label = f"batched/{nt}" if kind == "batched" else "Dummy"
            print(f"{'SAC':<5} {n:>6} {label:<10} {'':>9} {t:>9.0f}", flush=True)
    numba.set_num_threads(n_threads)


# --------------------------------------------------------------------------- time to PID
def tracking_rmse(policy, n: int, seed: int, reference: str = "mixed") -> float:
    """RMSE [m] of ``policy(obs, first_step) -> actions`` on ``n`` nominal episodes seeded
    ``seed + i`` (true position vs reference, after the first ``SKIP_STEPS`` steps)."""
    import gymnasium as gym

    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", randomize=False,
                        reference=reference)
    obs, _ = venv.reset(seed=seed)
    batch = venv.unwrapped.batch
    steps = venv.unwrapped.max_episode_steps
    ref = batch.REF[:, 1 : steps + 1].copy()  # compared with x after step k: r[k + 1]
    xs = np.empty((n, steps))
    for k in range(steps):
        a = policy(obs, k == 0)
        obs, _, _, _, info = venv.step(a)
        xs[:, k] = info["state"]["x"]
    venv.close()
    e = (ref - xs)[:, SKIP_STEPS:]
    return float(np.sqrt(np.mean(e**2)))


def pid_policy():
    from agents.controllers.servo_cylinder import ServoPIDController as PIDController

    pid = PIDController.from_params()

    def act(obs, first):
        a, _ = pid.predict(obs, episode_start=np.full(obs.shape[0], first))
        return a

    return act


def time_to_pid(algo: str, budget_min: float, eval_every: int, n_eval: int, eval_seed: int, seed: int,
                out: str | None, reference: str = "mixed") -> None:
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.train import train

    pid_rmse = tracking_rmse(pid_policy(), n_eval, eval_seed, reference)
    print(f"PID RMSE on {n_eval} nominal '{reference}' episodes (seeds {eval_seed}..{eval_seed + n_eval - 1}, after "
          f"{SKIP_STEPS} ms): {pid_rmse * 1e3:.4f} mm", flush=True)

    class Race(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.next = eval_every
            self.eval_wall = self.eval_cpu = 0.0
            self.reached: tuple[int, float, float, float] | None = None
            self.history: list[tuple[int, float, float]] = []

        def _on_training_start(self) -> None:
            self.w0, self.c0 = time.perf_counter(), time.process_time()

        def train_times(self) -> tuple[float, float]:
            return (time.perf_counter() - self.w0 - self.eval_wall, time.process_time() - self.c0 - self.eval_cpu)

        def _on_step(self) -> bool:
            wall, cpu = self.train_times()
            if self.num_timesteps >= self.next:
                self.next += eval_every
                w, c = time.perf_counter(), time.process_time()
                vn = self.model.get_vec_normalize_env()
                model = self.model

                def act(obs, first):
                    return model.predict(vn.normalize_obs(obs), deterministic=True)[0]

                rmse = tracking_rmse(act, n_eval, eval_seed, reference)
                self.eval_wall += time.perf_counter() - w
                self.eval_cpu += time.process_time() - c
                self.history.append((self.num_timesteps, wall, rmse))
                print(f"  {self.num_timesteps:>9d} steps  {wall / 60:6.2f} wall min  {cpu / 60:6.2f} CPU min  "
                      f"RMSE {rmse * 1e3:8.4f} mm  (PID {pid_rmse * 1e3:.4f} mm)", flush=True)
                if rmse <= pid_rmse:
                    self.reached = (self.num_timesteps, wall, cpu, rmse)
                    return False
            return wall < 60.0 * budget_min

    race = Race()
    # constant learning rate (the horizon is open); train on the references it is measured on
    hp = {"learning_rate": 3.0e-4 if algo == "ppo" else 7.3e-4, "env_kwargs": {"reference": reference}}
    with tempfile.TemporaryDirectory() as tmp:
        run = train(ENV_ID, algo, hyperparams=hp, timesteps=10**9, seed=seed, randomize=False,
                    out=out or tmp, n_eval_episodes=0, progress_bar=False, callbacks=[race])
        if out:
            print(f"run folder: {run}")
    if race.reached:
        n, wall, cpu, rmse = race.reached
        print(f"{algo.upper()} reached PID's RMSE ({rmse * 1e3:.4f} <= {pid_rmse * 1e3:.4f} mm) after {n} steps: "
              f"{wall / 60:.2f} wall minutes, {cpu / 60:.2f} process-CPU minutes (all threads), evaluation excluded")
    else:
        best = min(race.history, key=lambda h: h[2]) if race.history else None
        tail = (f"; best RMSE {best[2] * 1e3:.4f} mm at {best[0]} steps" if best else "")
        print(f"{algo.upper()} did not reach PID's RMSE {pid_rmse * 1e3:.4f} mm within {budget_min:g} wall "
              f"minutes of training{tail}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--time-to-pid", action="store_true")
    p.add_argument("--algo", choices=("ppo", "sac"), default="ppo")
    p.add_argument("--budget-min", type=float, default=10.0, help="wall minutes of training (time-to-pid)")
    p.add_argument("--eval-every", type=int, default=None, help="timesteps between RMSE evaluations")
    p.add_argument("--n-eval", type=int, default=8)
    p.add_argument("--eval-seed", type=int, default=1_000_000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--reference", default="mixed", help="reference kind of training and evaluation (time-to-pid; "
                   "steps | smooth | sine | chirp | mixed)")
    p.add_argument("--out", help="keep the time-to-pid run folder under this directory")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--torch-threads", type=int, default=1)
    a = p.parse_args(argv)
    hydro_envs.apply_openmp_spin()
    import torch

    torch.set_num_threads(a.torch_threads)
    if a.time_to_pid:
        every = a.eval_every or (65_536 if a.algo == "ppo" else 10_000)
        time_to_pid(a.algo, a.budget_min, every, a.n_eval, a.eval_seed, a.seed, a.out, a.reference)
    else:
        throughput(a.repeats, a.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
