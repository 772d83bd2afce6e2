"""Cold first step of every env: a fresh process with an empty numba cache.

For each registered env id a new Python process gets its own empty ``NUMBA_CACHE_DIR`` and
times ``import hydro_envs``, ``gym.make``, ``reset`` and the first ``step`` (where the plant's
kernels compile), then the same again in another fresh process that reuses the now filled
cache (warm). Prints seconds per phase; the target for the cold total is 5 s.

With ``--repeats N`` each env is measured N times, each with a new empty cache, and the run
with the smallest cold total is printed with the range of the N cold totals beside it: on a
shared virtual machine other tenants only ever add time (the same reasoning as ``timeit``'s
minimum), and the range shows how much they added.

Usage: ``python bench/cold_start.py [--env ID ...] [--repeats N]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import gymnasium as gym
import hydro_envs
t1 = time.perf_counter()
env = gym.make(sys.argv[1])
t2 = time.perf_counter()
env.reset(seed=0)
t3 = time.perf_counter()
env.step(env.action_space.sample())
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "make": t2 - t1, "reset": t3 - t2, "step": t4 - t3, "total": t4 - t0}))
"""


def run(env_id: str, cache_dir: str) -> dict[str, float]:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    out = subprocess.run([sys.executable, "-c", _CHILD, env_id], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    import hydro_envs  # noqa: F401
    from hydro_envs import registry

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", nargs="+", default=[e.id for _, e in registry.env_entries()])
    p.add_argument("--repeats", type=int, default=1, help="cold/warm pairs per env; the fastest cold run is shown")
    args = p.parse_args()
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    print(f"{'env':40s} {'phase':6s} {'import':>7s} {'make':>6s} {'reset':>6s} {'step':>6s} {'total':>6s}  "
          f"[cold target <= 5 s]")
    worst = 0.0
    for env_id in args.env:
        runs = []
        for _ in range(args.repeats):
            with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
                runs.append({phase: run(env_id, cache) for phase in ("cold", "warm")})
        best = min(runs, key=lambda r: r["cold"]["total"])
        colds = [r["cold"]["total"] for r in runs]
        worst = max(worst, best["cold"]["total"])
        for phase in ("cold", "warm"):
            r = best[phase]
            spread = f"  (cold totals of {len(colds)} runs: {min(colds):.2f}-{max(colds):.2f})" if (
                phase == "cold" and len(colds) > 1) else ""
            print(f"{env_id:40s} {phase:6s} {r['import']:7.2f} {r['make']:6.2f} {r['reset']:6.2f} "
                  f"{r['step']:6.2f} {r['total']:6.2f}{spread}")
    print(f"slowest cold first step: {worst:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
