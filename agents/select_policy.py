r"""Pick one policy out of several training seeds on validation draws the benchmark never scores.

Command line::

    python -m agents.select_policy --config force_actuator --family ppo_residual \
        [--seed 1] [--n 20] [--params in] [--dry-run]

The members are the run folders of the config's ``policies`` whose name is ``<family>_s<k>``.
Each is evaluated as its own controller, beside the PID, on ``n`` draws of ``params`` with
``seed``: validation draws, disjoint from the benchmark's own (the configs score ``seed: 0``;
the default validation seed 1 draws other parameter sets and episode seeds). Rule: among the
members with no more failed episodes than the PID, the lowest mean paired RMSE / PID; ties go
to the first member. The chosen folder is copied to ``<family>_selected`` beside the members
(weights, normalisation, config and training curve), with ``selection.json``: the validation
set, every member's paired ratio (bootstrap interval) and failure rate, and the choice. The
benchmark scores ``<family>_selected`` on its own draws as one more row; the pooled row of
all seeds stays in the table.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.benchmark import PAIRED_REFERENCE, _SEED_SUFFIX, run_benchmark
from agents.benchmark_cli import _policy_path, load_config

__all__ = ["choose", "select_policy", "main"]

SELECTED_SUFFIX = "_selected"


def choose(scores: dict[str, dict[str, float]], pid_failure: float) -> str:
    """The member with the lowest ``ratio`` among those failing no more often than the PID
    (``scores``: member -> ``{"ratio", "failure"}``, in member order); ValueError if none."""
    ok = [m for m, s in scores.items() if s["failure"] <= pid_failure + 1e-12]
    if not ok:
        raise ValueError(f"no member fails as rarely as the PID ({pid_failure:.2f}): "
                         + ", ".join(f"{m} {s['failure']:.2f}" for m, s in scores.items()))
    return min(ok, key=lambda m: (scores[m]["ratio"], ok.index(m)))


def _members(policies: Sequence[str], family: str) -> list[Path]:
    runs = [Path(_policy_path(str(p))) for p in policies]
    out = [r for r in runs if _SEED_SUFFIX.sub("", r.name) == family and r.name != family]
    if len(out) < 2:
        raise ValueError(f"--family {family!r}: the config names {len(out)} run folder(s) "
                         f"{family}_s<k>; need at least 2 to choose from")
    return out


def select_policy(config: str, family: str, seed: int = 1, n: int = 20, params: str = "in",
                  dry_run: bool = False, progress: Any = None) -> dict[str, Any]:
    """Evaluate the family's members on validation draws, choose one (module docstring) and,
    unless ``dry_run``, copy it to ``<family>_selected``; returns the selection record."""
    cfg = load_config(config)
    if int(cfg.get("seed", 0)) == seed:
        raise ValueError(f"--seed {seed} is the benchmark's own seed in {config}; validation needs other draws")
    members = _members(list(cfg.get("policies") or []), family)
    specs = [PAIRED_REFERENCE] + [f"{m.name}=sb3:{m}" for m in members]
    res = run_benchmark(cfg["env"], specs, params, n, seed, None, episode_steps=cfg.get("episode_steps"),
                        reference=cfg.get("reference"), step_reference=cfg.get("step_reference", "auto"),
                        figures=False, progress=progress)
    scores = {}
    for m in members:
        r, lo, hi, _ = res.summary[m.name]["rmse_rel_pid"]
        scores[m.name] = {"ratio": r, "ratio_ci": [lo, hi], "failure": res.summary[m.name]["failed"][0]}
    pid_failure = res.summary[PAIRED_REFERENCE]["failed"][0]
    chosen = choose(scores, pid_failure)
    record = {"env": cfg["env"], "family": family, "chosen": chosen,
              "validation": {"params": params, "n": n, "seed": seed, "benchmark_seed": int(cfg.get("seed", 0))},
              "pid_failure": pid_failure, "members": scores,
              "rule": "lowest mean paired RMSE / PID among members failing no more often than the PID"}
    if not dry_run:
        src = next(m for m in members if m.name == chosen)
        dst = src.parent / f"{family}{SELECTED_SUFFIX}"
        if dst.exists():
            shutil.rmtree(dst)
        shutil.copytree(src, dst, ignore=shutil.ignore_patterns("tb", "*.zip", "*.pkl", "__pycache__"))
        (dst / "selection.json").write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        record["folder"] = str(dst)
    return record


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m agents.select_policy", description=__doc__.split("\n\n")[0])
    p.add_argument("--config", required=True, help="benchmark config (name or file) listing the members")
    p.add_argument("--family", required=True, help="policy name without the _s<k> suffix, e.g. ppo_residual")
    p.add_argument("--seed", type=int, default=1, help="seed of the validation draws (not the benchmark's)")
    p.add_argument("--n", type=int, default=20, help="number of validation draws")
    p.add_argument("--params", default="in", help="parameter set of the validation draws")
    p.add_argument("--dry-run", action="store_true", help="evaluate and choose, copy nothing")
    a = p.parse_args(argv)
    try:
        rec = select_policy(a.config, a.family, a.seed, a.n, a.params, a.dry_run,
                            progress=lambda msg: print(msg, file=sys.stderr, flush=True))
    except (ValueError, OSError) as e:
        print(f"select_policy: error: {e}", file=sys.stderr)
        return 2
    for m, s in rec["members"].items():
        lo, hi = s["ratio_ci"]
        print(f"{m}: RMSE / PID {s['ratio']:.3f} [{lo:.3f}, {hi:.3f}], failures {s['failure']:.2f}"
              + ("  <- chosen" if m == rec["chosen"] else ""))
    print(f"PID failures {rec['pid_failure']:.2f}; " + (f"wrote {rec['folder']}" if "folder" in rec else "dry run"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
