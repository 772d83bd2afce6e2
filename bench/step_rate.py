"""Step rate, kernel cost, accuracy against Radau and memory of the servo-cylinder env.

Prints (no pass/fail; the targets in brackets):

* for every registered ``hydro_envs/`` env: single-env steps/s through ``gymnasium.make``
  with random actions, as a ratio to CartPole-v1's in the same run  [ratio >= 0.5], and
  1024-copy native vector env env-steps/s beside gymnasium's vectorised CartPole
  [>= 2 M/s]
* servo cylinder: kernel time per RK4 sub-step per copy (serial, and parallel over the batch)
* servo cylinder: position and pressure NRMSE against Radau (rtol 1e-10) over 2 s of random step commands
  with end-stop contact, at the default sub-step               [<= 1e-4, <= 1e-3]
* peak resident memory of a process running the 1024-copy servo env  [< 1 GiB]
* per env id, a profile split of one 1024-copy vector step (``--profile`` prints only this table):
  M env-steps/s, RK4 sub-steps per step (mean over copies), and the share of the step spent in
  the compiled step-and-observe call ("kernel": integration, observation and reward of every
  copy in one parallel region), in ``apply_actions`` ("inputs"; none where that kernel fills the
  inputs itself, as the shaking table's does), and in the remaining Python
  (action checks, info dicts, autoreset), each timed with ``time.perf_counter`` around that
  phase; the core time of one right-hand-side evaluation per copy ("rhs ns", the plant's
  compiled ``derivatives`` at the batch's last states), the kernel's time in such evaluations
  ("rhs/step": four per RK4 sub-step, plus refinement, the kernel's own arithmetic and the
  observation), how many of them fit a 2 M steps/s step beside its inputs and Python time
  ("at 2M"); the stiffness mode that sets most copies' sub-step
  count ("set by") and the mean count the copies would need without it ("next"); the time of one
  copy's reset ("reset us", a reset of all copies divided by their number) and the M env-steps/s
  over whole episodes, each copy reset once per registered episode length ("episodes"); above the
  table, what entering the kernel's parallel region costs under the OpenMP wait settings

``--env-kwarg KEY=VALUE`` (repeatable) passes keyword arguments to every env made for the vector
timings and the profile, e.g. ``--env hydro_envs/ShakingTable-v0 --env-kwarg preset=constant``
(the shaking table's bulk-modulus law); values are read as JSON where they parse, else as text.

Usage: ``python bench/step_rate.py [--quick] [--profile] [--env ID ...] [--env-kwarg KEY=VALUE ...]``.
Timings are the best of ``--repeats`` runs.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

ENV_ID = "hydro_envs/ServoCylinderPosition-v0"


def single_env_rate(env_id: str, steps: int) -> float:
    import gymnasium as gym

    import hydro_envs  # noqa: F401  (registers the envs)

    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    for a in actions[:200]:  # warm-up (compilation, caches)
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    env.reset(seed=0)
    t0 = time.perf_counter()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - t0)


def parse_env_kwargs(items: list[str] | None) -> dict[str, object]:
    """``KEY=VALUE`` strings as keyword arguments (VALUE as JSON where it parses, else text);
    ``ValueError`` naming an item without ``=``."""
    out: dict[str, object] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--env-kwarg must be KEY=VALUE, got {item!r}")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def vector_env_rate(env_id: str, n: int, steps: int, **env_kwargs: object) -> float:
    import gymnasium as gym

    import hydro_envs  # noqa: F401

    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **env_kwargs)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    space = venv.single_action_space
    if hasattr(space, "n"):
        actions = rng.integers(0, space.n, (steps, n))
    else:
        actions = rng.uniform(space.low, space.high, (steps, n) + space.shape).astype(space.dtype)
    for k in range(20):
        venv.step(actions[k])
    t0 = time.perf_counter()
    for k in range(steps):
        venv.step(actions[k])
    return steps * n / (time.perf_counter() - t0)


def profile_split(env_id: str, n: int, steps: int, **env_kwargs: object) -> dict[str, float]:
    """Time the phases of ``steps`` vector steps of ``n`` copies after a warm-up (seconds per step)."""
    import gymnasium as gym

    import hydro_envs  # noqa: F401

    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **env_kwargs)
    venv.reset(seed=0)
    b = venv.unwrapped.batch
    rng = np.random.default_rng(0)
    space = venv.single_action_space
    actions = rng.uniform(space.low, space.high, (steps,) + (n,) + space.shape).astype(space.dtype)
    for k in range(20):
        venv.step(actions[k])
    spent = {"kernel": 0.0, "inputs": 0.0}

    def timed(fn, key):
        def wrapper(*args):
            inputs = spent["inputs"]
            t = time.perf_counter()
            fn(*args)
            nested = spent["inputs"] - inputs if key != "inputs" else 0.0  # apply_actions called within
            spent[key] += time.perf_counter() - t - nested
        return wrapper

    b.step_and_observe = timed(b.step_and_observe, "kernel")
    b.observe = timed(b.observe, "kernel")  # after autoresets
    b.apply_actions = timed(b.apply_actions, "inputs")
    t0 = time.perf_counter()
    for k in range(steps):
        venv.step(actions[k])
    total = time.perf_counter() - t0
    t0 = time.perf_counter()
    venv.reset(seed=1)  # every copy once, as each is once per episode
    reset = time.perf_counter() - t0
    episode = venv.unwrapped.max_episode_steps
    return {
        "rate": steps * n / total,
        "reset": reset / n,
        "episode_rate": n / (total / steps + reset / episode),
        "step": total / steps,
        "kernel": spent["kernel"] / steps,
        "inputs": spent["inputs"] / steps,
        "python": (total - spent["kernel"] - spent["inputs"]) / steps,
        "n_sub": float(np.mean(b.NSUB)),
        "rhs": rhs_time(b),
        **_substep_modes(b),
    }


def rhs_time(b, evaluations: int = 200, repeats: int = 3) -> float:
    """Wall time [s] of one right-hand-side evaluation of every copy of batch ``b`` at its
    current states and inputs, in parallel as the step kernel runs (the plant's compiled
    ``derivatives`` over ``evaluations`` copies of each state; best of ``repeats``)."""
    X = np.ascontiguousarray(np.repeat(b.Y[:, None, :], evaluations, axis=1))
    U = np.ascontiguousarray(b.U[:, None, :])
    out = np.empty_like(X)
    derivatives = b.plant_spec.kernels.derivatives
    derivatives(X[:, :2], U, b.P, out[:, :2])  # compiled before timing
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        derivatives(X, U, b.P, out)
        best = min(best, time.perf_counter() - t)
    return best / evaluations


def _substep_modes(b) -> dict[str, object]:
    """The stiffness mode that sets most copies' sub-step count, and the mean sub-step count
    the copies would need without their setting mode (what treating it otherwise could save)."""
    from collections import Counter

    from hydro_envs.sim.stiffness import substeps_from_stiffness

    names, without = Counter(), []
    for p in b.params:
        modes = dict(b.plant.stiffness_modes(p))
        _, _, name = substeps_from_stiffness(modes, b.dt, b.safety)
        names[name] += 1
        modes.pop(name)
        without.append(substeps_from_stiffness(modes, b.dt, b.safety)[0] if modes else 1)
    return {"set_by": names.most_common(1)[0][0], "n_sub_next": float(np.mean(without))}


def parallel_call_times(gaps: list[float], calls: int = 300) -> list[float]:
    """Wall time [s] of a call of an empty parallel kernel (a ``prange`` over 64 blocks, as
    :func:`hydro_envs.sim.rk4.in_blocks` makes) when each of ``gaps`` seconds of other work
    separates the calls, as observation, reward and Python separate two vector-env steps: what
    entering a parallel region costs under the OpenMP wait settings in force (median of
    ``calls`` per gap)."""
    import numba

    @numba.njit(parallel=True)
    def empty(x):
        for c in numba.prange(64):
            x[c] += 0.0

    x = np.zeros(64)
    empty(x)
    result = []
    for gap in gaps:
        spent = []
        for _ in range(calls):
            t = time.perf_counter()
            while time.perf_counter() - t < gap:
                pass
            t = time.perf_counter()
            empty(x)
            spent.append(time.perf_counter() - t)
        result.append(float(np.median(spent)))
    return result


def print_profile(env_ids: list[str], n: int, steps: int, repeats: int, **env_kwargs: object) -> None:
    made = f", env kwargs {env_kwargs}" if env_kwargs else ""
    print(f"profile of one {n}-copy vector step (best of {repeats}, {steps} steps after warm-up{made})")
    near, far = parallel_call_times([50e-6, 200e-6])
    print(f"an empty parallel kernel call 50 / 200 us after the last: {near * 1e6:.1f} / {far * 1e6:.1f} us")
    head = (f"{'env id':<42} {'M steps/s':>9} {'sub-steps':>9} {'step us':>7} {'kernel':>6} {'inputs':>7} "
            f"{'python':>6} {'rhs ns':>6} {'rhs/step':>8} {'at 2M':>5}  {'set by':<12} {'next':>4} "
            f"{'reset us':>8} {'episodes':>8}")
    print(head)
    import numba

    cores = numba.get_num_threads()

    def budget(r: dict[str, float]) -> float:
        """Right-hand-side evaluations per step that fit a 2 M steps/s step beside the step's
        inputs and Python time."""
        return (n / 2e6 - r["inputs"] - r["python"]) / r["rhs"]

    for env_id in env_ids:
        r = min((profile_split(env_id, n, steps, **env_kwargs) for _ in range(repeats)), key=lambda r: r["step"])
        print(f"{env_id:<42} {r['rate'] / 1e6:>9.2f} {r['n_sub']:>9.2f} {r['step'] * 1e6:>7.0f} "
              f"{r['kernel'] / r['step']:>6.0%} {r['inputs'] / r['step']:>7.0%} {r['python'] / r['step']:>6.0%} "
              f"{r['rhs'] * cores / n * 1e9:>6.0f} {r['kernel'] / r['rhs']:>8.1f} {budget(r):>5.1f}  "
              f"{r['set_by']:<12} {r['n_sub_next']:>4.1f} {r['reset'] * 1e6:>8.0f} {r['episode_rate'] / 1e6:>8.2f}")


def kernel_time_per_substep(n: int, steps: int) -> tuple[float, float]:
    from hydro_envs import registry
    from hydro_envs.plants.servo_cylinder import model as sc

    kernels = registry.get("servo_cylinder").kernels
    p = sc.ServoCylinderParams()
    P = np.tile(p.to_array(), (n, 1))
    rng = np.random.default_rng(0)
    result = []
    for kernel in (kernels.step_serial, kernels.step_parallel):
        Y = np.zeros((n, sc.N_STATES))
        Y[:, sc.X] = rng.uniform(0.2, 0.8, n) * p.stroke
        Y[:, sc.P1] = Y[:, sc.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
        U = rng.uniform(-3, 3, (n, 1))
        W = np.zeros((n, 5, sc.N_STATES))
        c = np.zeros(n, dtype=np.int64)
        nsub = np.full(n, 3, dtype=np.int64)
        kernel(Y, U, P, 1e-3, nsub, W, c)
        t0 = time.perf_counter()
        for _ in range(steps):
            kernel(Y, U, P, 1e-3, nsub, W, c)
        result.append((time.perf_counter() - t0) / (steps * n * 3))
    return result[0], result[1]


def radau_nrmse(seconds: float = 2.0, seed: int = 3) -> dict[str, float]:
    from hydro_envs import registry
    from hydro_envs.plants.servo_cylinder import model as sc
    from hydro_envs.sim.reference import reference_rollout
    from hydro_envs.sim.simulate import simulate
    from hydro_envs.sim.stiffness import substeps_from_stiffness

    spec = registry.get("servo_cylinder")
    p = sc.ServoCylinderParams()
    dt = 1e-3
    n = int(round(seconds / dt))
    rng = np.random.default_rng(seed)
    cmds = np.repeat(rng.uniform(-p.command_max, p.command_max, n // 150 + 1), 150)[:n]
    y0 = np.zeros(sc.N_STATES)
    y0[sc.X] = 0.5 * p.stroke
    y0[sc.P1] = y0[sc.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
    n_sub = substeps_from_stiffness(sc.stiffness_modes(p), dt)[0]
    fixed = simulate(spec, p, cmds[:, None], y0, dt)
    atol = np.array([1e-13, 1e-10, 1e-3, 1e-3, 1e-15, 1e-11])
    t0 = time.perf_counter()
    ref = reference_rollout(spec, y0, cmds[:, None], p.to_array(), dt, rtol=1e-10, atol=atol)
    t_ref = time.perf_counter() - t0

    def nrmse(a, b):
        return float(np.sqrt(np.mean((a - b) ** 2)) / (b.max() - b.min()))

    return {
        "n_sub": n_sub,
        "position": nrmse(fixed[:, sc.X], ref[:, sc.X]),
        "pressure": max(nrmse(fixed[:, sc.P1], ref[:, sc.P1]), nrmse(fixed[:, sc.P2], ref[:, sc.P2])),
        "stop_contacts": int(np.sum(np.diff((ref[:, sc.X] > p.stroke) | (ref[:, sc.X] < 0.0)) == 1)),
        "radau_seconds": t_ref,
    }


def _memory_child(n: int, steps: int) -> None:
    import gymnasium as gym

    import hydro_envs  # noqa: F401

    venv = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    a = np.zeros((n, 1), dtype=np.float32)
    for _ in range(steps):
        venv.step(a)
    print(_peak_rss_kib())


def _peak_rss_kib() -> int:
    """Peak resident set size of this process [KiB]: ``VmHWM`` of ``/proc/self/status``.

    ``getrusage`` is no substitute in a child: Linux carries the parent's peak at ``fork`` into
    the child's ``ru_maxrss``, so a child of a large parent reports the parent's peak.
    """
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS


def peak_rss_mib(n: int, steps: int) -> float:
    out = subprocess.run(
        [sys.executable, __file__, "--memory-child", str(n), str(steps)],
        check=True, capture_output=True, text=True,
    )
    return int(out.stdout.strip().splitlines()[-1]) / 1024.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer steps (smoke run)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--env", action="append", help="env id to time (repeatable; default: all hydro_envs ids)")
    ap.add_argument("--profile", action="store_true", help="print only the per-env profile table")
    ap.add_argument("--env-kwarg", action="append", metavar="KEY=VALUE",
                    help="keyword argument of the vector envs timed (repeatable), e.g. preset=constant")
    ap.add_argument("--memory-child", nargs=2, type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    try:
        env_kwargs = parse_env_kwargs(args.env_kwarg)
    except ValueError as exc:
        ap.error(str(exc))
    if args.memory_child:
        _memory_child(*args.memory_child)
        return

    import gymnasium as gym

    import hydro_envs  # noqa: F401
    from hydro_envs._openmp import set_spin_time

    set_spin_time()  # as the first vector env made does; before numba starts its threads below
    import numba

    single_steps = 5_000 if args.quick else 30_000
    vec_steps = 100 if args.quick else 1_000
    n = 1024
    print(f"machine: {os.cpu_count()} CPUs, numba {numba.__version__} ({numba.get_num_threads()} threads), "
          f"gymnasium {gym.__version__}, numpy {np.__version__}, OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}, "
          f"GOMP_SPINCOUNT={os.environ.get('GOMP_SPINCOUNT')}")

    best = lambda f: max(f() for _ in range(args.repeats))  # noqa: E731
    env_ids = args.env or sorted(k for k in gym.registry if k.startswith("hydro_envs/"))
    if args.profile:
        print_profile(env_ids, n, vec_steps, args.repeats, **env_kwargs)
        return
    cart = best(lambda: single_env_rate("CartPole-v1", single_steps))
    vcart = best(lambda: vector_env_rate("CartPole-v1", n, vec_steps))
    print(f"CartPole-v1: single {cart:,.0f} steps/s, vector ({n} copies) {vcart / 1e6:.2f} M env-steps/s")
    for env_id in env_ids:
        single = best(lambda: single_env_rate(env_id, single_steps))
        vec = best(lambda: vector_env_rate(env_id, n, vec_steps, **env_kwargs))
        sub = gym.make(env_id).unwrapped
        sub.reset(seed=0)
        print(f"{env_id}: single (gym.make, random actions) {single:,.0f} steps/s = {single / cart:.2f}x "
              f"CartPole [target >= 0.5]; vector ({n} copies) {vec / 1e6:.2f} M env-steps/s "
              f"[target >= 2 M/s]; {sub.n_substeps} RK4 sub-steps per {sub.dt * 1e3:g} ms step")

    print_profile(env_ids, n, vec_steps, args.repeats, **env_kwargs)

    ser, par = min((kernel_time_per_substep(n, 200 if not args.quick else 20) for _ in range(args.repeats)),
                   key=lambda t: t[1])
    print(f"kernel: {ser * 1e9:.0f} ns per RK4 sub-step per copy serial, {par * 1e9:.0f} ns parallel "
          f"({n} copies, {numba.get_num_threads()} threads)")

    acc = radau_nrmse()
    print(f"accuracy vs Radau (rtol 1e-10), 2 s random steps, {acc['stop_contacts']} stop contacts, "
          f"default {acc['n_sub']} sub-steps/ms: position NRMSE {acc['position']:.2e} [<= 1e-4], "
          f"pressure NRMSE {acc['pressure']:.2e} [<= 1e-3]  (Radau took {acc['radau_seconds']:.1f} s)")

    rss = peak_rss_mib(n, 200 if args.quick else 2000)
    print(f"peak resident memory of the {n}-copy run: {rss:.0f} MiB  [< 1024 MiB]")


if __name__ == "__main__":
    main()
