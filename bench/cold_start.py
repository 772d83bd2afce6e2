"""Cold first step of every env: a fresh process with an empty numba cache.

For each registered env id a new Python process gets its own empty ``NUMBA_CACHE_DIR`` and
times ``import hydro_envs``, ``gym.make``, ``reset`` and the first ``step`` (where the plant's
kernels compile), then the same again in another fresh process that reuses the now filled
cache (warm). Prints seconds per phase; the target for the cold total is 5 s.

With ``--repeats N`` each env is measured N times, each with a new empty cache, and the run
with the smallest cold total is printed with the range of the N cold totals beside it: on a
shared virtual machine other tenants only ever add time (the same reasoning as ``timeit``'s
minimum), and the range shows how much they added.

What "cold" is here: numba's cache is empty (``NUMBA_CACHE_DIR`` set to a new temporary
folder, so neither the package's ``__pycache__`` nor what ``hydro compile`` stored there is
read, and the stale-cache purge of :mod:`hydro_envs._numba_cache` stands aside): every kernel the
first step needs is typed, lowered and compiled by LLVM in that process. "Warm" reuses the folder
the cold run filled: no function compiles ("nb fns" 0), what is left is imports and loading the
cached kernels. ``cpu`` is the child's CPU time (``time.process_time``): on a machine other jobs
share, the wall-clock total grows with their load, the CPU time less. "nb fns" and "nb s": how
many functions numba compiled and their compile seconds (numba's ``numba:compile`` events,
nested compiles subtracted).

``--profile`` lists, per env, the functions the cold run compiled with their own compile seconds
and the phase (make, reset, step) each compiled in.

Usage: ``python bench/cold_start.py [--env ID ...] [--repeats N] [--profile]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from typing import Any

_CHILD = r"""
import json, sys, time
c0 = time.process_time()
t0 = time.time()
import numba.core.event as ev
recorder = ev.install_recorder("numba:compile")
events = recorder.__enter__()
import gymnasium as gym
import hydro_envs
t1 = time.time()
env = gym.make(sys.argv[1])
t2 = time.time()
env.reset(seed=0)
t3 = time.time()
env.step(env.action_space.sample())
t4 = time.time()
cpu = time.process_time() - c0
recorder.__exit__(None, None, None)
compiled, stack = {}, []
for ts, e in events.buffer:  # (time.time(), event), nested: own seconds = duration - nested ones
    if e.is_start:
        f = getattr((e.data or {}).get("dispatcher"), "py_func", None)
        name = f"{f.__module__}.{f.__qualname__}" if f is not None else "?"
        phase = "import" if ts < t1 else "make" if ts < t2 else "reset" if ts < t3 else "step"
        stack.append([name, phase, ts, 0.0])
    else:
        name, phase, start, nested = stack.pop()
        own = compiled.setdefault(name, [phase, 0.0])
        own[1] += ts - start - nested
        if stack:
            stack[-1][3] += ts - start
print(json.dumps({"import": t1 - t0, "make": t2 - t1, "reset": t3 - t2, "step": t4 - t3, "total": t4 - t0,
                  "cpu": cpu, "compiled": compiled}))
"""


def run(env_id: str, cache_dir: str) -> dict[str, Any]:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    out = subprocess.run([sys.executable, "-c", _CHILD, env_id], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def print_compiled(compiled: dict[str, list[Any]], top: int = 15) -> None:
    """The ``top`` functions with the most own compile seconds, with the phase they compiled in."""
    for name, (phase, own) in sorted(compiled.items(), key=lambda kv: -kv[1][1])[:top]:
        print(f"    {own:6.2f} s  {phase:6s} {name}")


def main() -> int:
    import hydro_envs  # noqa: F401
    from hydro_envs import registry

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", nargs="+", default=[e.id for _, e in registry.env_entries()])
    p.add_argument("--repeats", type=int, default=1, help="cold/warm pairs per env; the fastest cold run is shown")
    p.add_argument("--profile", action="store_true", help="list the functions the cold run compiled, slowest first")
    args = p.parse_args()
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    print(f"{'env':40s} {'phase':6s} {'import':>7s} {'make':>6s} {'reset':>6s} {'step':>6s} {'total':>6s} "
          f"{'cpu':>6s} {'nb fns':>6s} {'nb s':>6s}  [cold target <= 5 s]")
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
            nb_s = sum(own for _, own in r["compiled"].values())
            print(f"{env_id:40s} {phase:6s} {r['import']:7.2f} {r['make']:6.2f} {r['reset']:6.2f} "
                  f"{r['step']:6.2f} {r['total']:6.2f} {r['cpu']:6.2f} {len(r['compiled']):6d} {nb_s:6.2f}{spread}")
        if args.profile:
            print_compiled(best["cold"]["compiled"])
    print(f"slowest cold first step: {worst:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
