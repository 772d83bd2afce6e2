"""Paired step-rate comparison of two source trees of the package (e.g. a commit and its parent).

On a shared virtual machine the speed drifts by up to 2x between runs minutes apart, so two
``bench/step_rate.py`` runs one after the other compare the machine more than the code. Here
each env id gets one worker process per tree (``PYTHONPATH`` set to the tree, its vector env of
``--copies`` copies made, reset and warmed up), and the two workers take turns: 15 rounds, each
timing ``--steps`` steps of random actions in one worker and then in the other (the order
alternating), while the other waits. Printed per env: each tree's median and fastest time per
step and the median of the 15 per-round ratios new/old with their range; a ratio near 1 is no
change, whatever the machine did meanwhile.

Usage: ``python bench/paired_step_rate.py --old DIR --new DIR [--copies N] [--steps K] [--env ID ...]``
(``--copies 1``: the single env through ``gymnasium.make``). A tree is a checkout, e.g.
``git worktree add --detach /tmp/old HEAD~1``; each uses its own numba cache beside its sources.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

_WORKER = r"""
import sys, time
import numpy as np, gymnasium as gym
import hydro_envs
env_id, n = sys.argv[1], int(sys.argv[2])
if n > 1:
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    space = env.single_action_space
    shape = (n,) + space.shape
else:
    env = gym.make(env_id)
    space = env.action_space
    shape = space.shape
env.reset(seed=0)
acts = np.random.default_rng(0).uniform(space.low, space.high, (int(sys.argv[3]),) + shape).astype(space.dtype)
def run(k):
    t0 = time.perf_counter()
    for a in acts[:k]:
        r = env.step(a)
        if n == 1 and (r[2] or r[3]):
            env.reset()
    return (time.perf_counter() - t0) / k
run(min(50, len(acts)))
print("ready", flush=True)
for line in sys.stdin:
    print(run(int(line)), flush=True)
"""

DEFAULT_ENVS = ("hydro_envs/ServoCylinderPosition-v0", "hydro_envs/ForceActuator-v0", "hydro_envs/ShakingTable-v0",
                "hydro_envs/LoadSensing-v0", "hydro_envs/RodlessCylinder-v0",
                "hydro_envs/DifferentialCylinderPosition-v0")


def _worker(tree: str, env_id: str, copies: int, steps: int) -> subprocess.Popen[str]:
    p = subprocess.Popen([sys.executable, "-c", _WORKER, env_id, str(copies), str(steps)], cwd=tree,
                         env={**os.environ, "PYTHONPATH": tree}, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                         text=True)
    assert p.stdout is not None
    if p.stdout.readline().strip() != "ready":
        raise RuntimeError(f"the worker of {env_id} in {tree} did not start")
    return p


def compare(old: str, new: str, env_id: str, copies: int, steps: int, rounds: int = 15) -> str:
    workers = {"old": _worker(old, env_id, copies, steps), "new": _worker(new, env_id, copies, steps)}
    times: dict[str, list[float]] = {"old": [], "new": []}
    for r in range(rounds):
        for tree in ("old", "new") if r % 2 == 0 else ("new", "old"):
            w = workers[tree]
            assert w.stdin is not None and w.stdout is not None
            w.stdin.write(f"{steps}\n")
            w.stdin.flush()
            times[tree].append(float(w.stdout.readline()))
    for w in workers.values():
        assert w.stdin is not None
        w.stdin.close()
        w.wait()
    ratios = [a / b for a, b in zip(times["new"], times["old"])]
    us = {k: (statistics.median(v) * 1e6, min(v) * 1e6) for k, v in times.items()}
    return (f"{env_id} ({copies} copies): old {us['old'][0]:.1f} us per step (fastest {us['old'][1]:.1f}), "
            f"new {us['new'][0]:.1f} ({us['new'][1]:.1f}); new/old paired median {statistics.median(ratios):.3f} "
            f"[{min(ratios):.2f}, {max(ratios):.2f}]")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--old", required=True, help="source tree of the reference code")
    ap.add_argument("--new", required=True, help="source tree of the code compared")
    ap.add_argument("--copies", type=int, default=1024, help="vector env copies (1: the single env)")
    ap.add_argument("--steps", type=int, default=None, help="steps per timing (default 300, single env 3000)")
    ap.add_argument("--env", action="append", help="env id (repeatable; default: one per plant)")
    args = ap.parse_args()
    if args.copies < 1:
        ap.error(f"--copies must be >= 1, got {args.copies}")
    for tree in (args.old, args.new):
        if not os.path.isdir(os.path.join(tree, "hydro_envs")):
            ap.error(f"{tree!r} is not a source tree of the package (no hydro_envs/ in it)")
    steps = args.steps or (300 if args.copies > 1 else 3000)
    for env_id in args.env or DEFAULT_ENVS:
        print(compare(os.path.abspath(args.old), os.path.abspath(args.new), env_id, args.copies, steps), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
