"""Soak every environment: random actions at and beyond the randomisation extremes.

Runs :func:`hydro_envs.sim.soak.soak_env` (see its module docstring for what is counted and
the exact energy-balance inequality) for each env, one after the other, and prints a table:
env, steps run, steps/s, the count of each breach kind (NaN/inf, pressure/mass/temperature
guard, stroke beyond the end-stop tolerance, energy balance, passivity, replay), the guard
clamps (reported, not a breach) and the draws used. Exit code 1 if any breach.

Usage::

    python bench/soak.py                                # 1e7 steps per env, all five envs
    python bench/soak.py --steps 1e6 --envs ServoCylinderPosition-v0,ShakingTable-v0
    python bench/soak.py --num-envs 512 --factor 2 --json out.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=float, default=1e7, help="env steps per env, summed over copies (default 1e7)")
    p.add_argument("--envs", default="all",
                   help="comma-separated env ids (with or without the 'hydro_envs/' prefix), or 'all'")
    p.add_argument("--num-envs", type=int, default=256, help="copies of the vector env (default 256)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--factor", type=float, default=2.0,
                   help="'beyond' draws: corners of the ranges widened by this factor (default 2)")
    p.add_argument("--beyond-fraction", type=float, default=0.5, help="fraction of beyond draws (default 0.5)")
    p.add_argument("--bang-fraction", type=float, default=0.4,
                   help="fraction of copies driven bang-bang per episode (default 0.4)")
    p.add_argument("--episode-steps", type=int, default=None, help="episode length (default: the env's)")
    p.add_argument("--json", metavar="FILE", help="also write the results (with first-breach examples) as JSON")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)

    import hydro_envs  # noqa: F401  (registers the envs)
    from hydro_envs.soak import SOAK_ENVS, format_table, soak_env

    if args.envs == "all":
        envs = list(SOAK_ENVS)
    else:
        envs = [e if e.startswith("hydro_envs/") else f"hydro_envs/{e}" for e in args.envs.split(",") if e]
        unknown = [e for e in envs if e not in SOAK_ENVS]
        if unknown:
            p.error(f"unknown env(s) {unknown}; known: {', '.join(SOAK_ENVS)}")
    say = None if args.quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    results = []
    for env_id in envs:
        r = soak_env(env_id, int(args.steps), num_envs=args.num_envs, seed=args.seed, factor=args.factor,
                     beyond_fraction=args.beyond_fraction, bang_fraction=args.bang_fraction,
                     episode_steps=args.episode_steps, progress=say)
        results.append(r)
        if say:
            say(f"{env_id}: {r.steps} steps in {r.seconds:.1f} s, breaches {r.counts}")
    print(format_table(results))
    for r in results:
        for kind, ex in r.examples.items():
            print(f"\nfirst {kind} breach in {r.env_id}: {json.dumps(ex)}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump([dataclasses.asdict(r) | {"steps_per_second": r.steps_per_second} for r in results], f,
                      indent=1)
    return 1 if any(r.breaches for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
