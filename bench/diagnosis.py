"""Diagnosis bench: hidden-effect confusion matrix, top-1 / none / shrink rates, and the time of
a diagnosis at 20 s + 10 s held out (``--speed``).

    python bench/diagnosis.py [--plants slider,servo_cylinder,...] [--seeds 3]
                              [--duration 8] [--max-effects 1] [--speed]
                              [--backend serial|ray] [--ray-address ADDR] [--num-cpus N]

For every plant, every applicable catalogue effect and ``--seeds`` seeds it draws the effect's
parameters inside the catalogue's draw range, records closed-loop data with realistic sensor
noise (identification.diagnosis.synthetic), runs the workflow from the base model and prints
the confusion matrix (true effect x named effect), the relative error of every fitted effect
parameter against its drawn value (cases where the effect was named) and the three rates:
top-1 (hidden effect named first), none (effect-free data -> "none") and shrink (held-out
NRMSE falls by >= 50 % when an effect is named; over the channels the effect acts on, see
identification.diagnosis.residuals.effect_channels).

``--backend ray`` runs every case as one Ray core task (agents/backend.py; a cluster by
``--ray-address`` or ``$RAY_ADDRESS``, else a local Ray); rows, matrix and rates are the same.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

# the package, not bench/identification.py: drop this folder from the path (Ray would also put
# it first on its workers' path) and put the repository root first
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents.backend import add_backend_args, import_ray  # noqa: E402
from identification.diagnosis import diagnose, effects_for  # noqa: E402
from identification.diagnosis.plants import PLANTS  # noqa: E402
from identification.diagnosis.synthetic import hidden_effect_records  # noqa: E402


def run_case(plant: str, eff: str | None, seed: int, duration: float, max_effects: int,
             candidates: tuple[str, ...] | None = None) -> dict:
    case = hidden_effect_records(plant, eff, seed, duration=duration)
    t0 = time.perf_counter()
    res = diagnose(plant, [case.fit], [case.holdout], base=case.base.params, max_effects=max_effects, maps=False,
                   effects=None if candidates is None else list(candidates))
    # the first effect named (also under an unexplained verdict); else the verdict
    named = res.effects[0]["name"] if res.effects else res.verdict
    shrink = res.effects[0]["shrink"] if res.effects else float("nan")
    # the final model's values of the hidden effect's parameters, when it was named
    hit = [e for e in res.effects if e["name"] == eff]
    fitted = {k: float(v) for k, v in hit[0]["final_parameters"].items()} if hit else {}
    floors = max(res.residual[-1]["floors"].values(), default=float("nan")) if res.residual else float("nan")
    return {"plant": plant, "true": eff or "none", "named": named, "shrink": shrink, "verdict": res.verdict,
            "floors": floors, "seconds": time.perf_counter() - t0, "detail": res.ambiguous, "drawn": case.drawn,
            "fitted": fitted}


def case_row(plant: str, eff: str | None, seed: int, duration: float, max_effects: int,
             candidates: tuple[str, ...] | None = None) -> dict:
    """:func:`run_case`, with a crash recorded as the row's result (it is a result of the bench,
    not its end). Module level, so a Ray task can run it."""
    try:
        return run_case(plant, eff, seed, duration, max_effects, candidates)
    except Exception as err:  # noqa: BLE001
        return {"plant": plant, "true": eff or "none", "named": "error", "shrink": float("nan"),
                "seconds": 0.0, "detail": f"{type(err).__name__}: {err}", "drawn": {}, "fitted": {}}


def cases(plants, seeds, seed0=0) -> list[tuple[str, str | None, int]]:
    """``(plant, effect, seed)`` of every case: each diagnosable effect ``seeds`` times and
    effect-free data twice as often; the seed depends on the effect's position, not on the run."""
    out = []
    for plant in plants:
        effs = [e.name for e in effects_for(plant, diagnosable_only=True)] + [None]
        for eff in effs:
            for s in range(seed0, seed0 + (seeds if eff else 2 * seeds)):
                out.append((plant, eff, 1000 * (effs.index(eff) + 1) + s))
    return out


def print_row(r: dict) -> None:
    print(f"{r['plant']:15s} {r['true']:20s} -> {r['named']:20s} shrink {r['shrink']:+.2f} "
          f"{r.get('verdict', ''):11s} {r.get('floors', float('nan')):6.1f} floors {r['seconds']:5.1f} s {r['detail']}",
          flush=True)


def run_cases(case_list, duration, max_effects, *, candidates=None, backend="serial", address=None,
              num_cpus=None, verbose=True) -> list[dict]:
    """One row per case, in order (``candidates``: restrict the catalogue to these effects).
    ``backend="ray"``: one Ray core task per case (a case takes seconds, far above a task's
    overhead, and cases differ in cost, so single cases balance best); the rows are the same as
    serial ones except ``seconds``."""
    from agents.backend import run_tasks

    cand = None if candidates is None else tuple(candidates)
    calls = [(plant, eff, seed, duration, max_effects, cand) for plant, eff, seed in case_list]
    return run_tasks(case_row, calls, backend=backend, address=address, num_cpus=num_cpus,
                     on_result=(lambda i, r: print_row(r)) if verbose else None)


def matrix(plants, seeds, duration, max_effects, seed0=0, *, backend="serial", address=None, num_cpus=None):
    return run_cases(cases(plants, seeds, seed0), duration, max_effects, backend=backend, address=address,
                     num_cpus=num_cpus)


def summary(rows) -> dict:
    eff_rows = [r for r in rows if r["true"] != "none"]
    none_rows = [r for r in rows if r["true"] == "none"]
    named_rows = [r for r in rows if r["named"] not in ("none", "ambiguous", "unexplained", "error")]
    top1 = np.mean([r["named"] == r["true"] for r in eff_rows]) if eff_rows else float("nan")
    none = np.mean([r["named"] == "none" for r in none_rows]) if none_rows else float("nan")
    shrink = np.mean([r["shrink"] >= 0.5 for r in named_rows]) if named_rows else float("nan")
    return {"top1": float(top1), "none": float(none), "shrink": float(shrink), "n_effect": len(eff_rows),
            "n_none": len(none_rows), "n_named": len(named_rows)}


def print_confusion(rows) -> None:
    for plant in sorted({r["plant"] for r in rows}):
        pr = [r for r in rows if r["plant"] == plant]
        labels = [e.name for e in effects_for(plant, diagnosable_only=True)] + ["none"]
        cols = labels + ["ambiguous", "unexplained"]
        print(f"\nconfusion matrix, {plant} (rows: hidden effect, columns: named)")
        w = max(len(c) for c in cols) + 1
        print(" " * w + "".join(f"{c[:10]:>11s}" for c in cols))
        for t in labels:
            cnt = [sum(1 for r in pr if r["true"] == t and r["named"] == c) for c in cols]
            print(f"{t:{w}s}" + "".join(f"{c:11d}" for c in cnt))


#: the unbiasedness target of the fitted effect parameters: within this fraction of the truth
BIAS_TOL = 0.15


def fitted_errors(rows) -> list[dict]:
    """One row per (plant, effect, parameter) over the cases whose hidden effect was named: the
    number of cases, the median and the largest relative error of the final model's value
    against the drawn one, and how many lie within ``BIAS_TOL``."""
    acc: dict[tuple[str, str, str], list[float]] = {}
    for r in rows:
        for k, truth in r.get("drawn", {}).items():
            if k in r.get("fitted", {}) and truth != 0:
                acc.setdefault((r["plant"], r["true"], k), []).append(r["fitted"][k] / truth - 1.0)
    out = []
    for (plant, eff, k), errs in sorted(acc.items()):
        e = np.array(errs)
        out.append({"plant": plant, "effect": eff, "parameter": k, "n": e.size, "median": float(np.median(e)),
                    "worst": float(e[np.argmax(np.abs(e))]), "within": int(np.sum(np.abs(e) <= BIAS_TOL))})
    return out


def print_fitted_errors(rows) -> None:
    table = fitted_errors(rows)
    if not table:
        return
    print(f"\nfitted effect parameters against the drawn truth (cases where the effect was named; target: "
          f"within {BIAS_TOL:.0%})")
    print(f"{'plant':20s} {'effect':20s} {'parameter':30s} {'n':>3s} {'median':>8s} {'worst':>8s} within")
    for t in table:
        print(f"{t['plant']:20s} {t['effect']:20s} {t['parameter']:30s} {t['n']:3d} {t['median']:+8.1%} "
              f"{t['worst']:+8.1%} {t['within']}/{t['n']}")
    n = sum(t["n"] for t in table)
    print(f"within {BIAS_TOL:.0%}: {sum(t['within'] for t in table)} of {n} fitted values")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--plants", default=",".join(PLANTS), help="comma-separated (default: every diagnosis plant)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--duration", type=float, default=8.0)
    ap.add_argument("--max-effects", type=int, default=1,
                    help="rounds per case (the rates concern the first effect named; 2 also checks that "
                    "nothing more is named after it)")
    ap.add_argument("--speed", action="store_true",
                    help="also time every effect and an effect-free record at 20 s + 10 s held out (--seeds 0: only that)")
    add_backend_args(ap)
    a = ap.parse_args(argv)
    if a.backend == "ray":
        try:
            import_ray()
        except ImportError as err:
            ap.error(str(err))
    if a.seeds > 0:
        t0 = time.perf_counter()
        rows = matrix(a.plants.split(","), a.seeds, a.duration, a.max_effects, backend=a.backend,
                      address=a.ray_address, num_cpus=a.num_cpus)
        wall = time.perf_counter() - t0
        print_confusion(rows)
        print_fitted_errors(rows)
        s = summary(rows)
        print(f"\ntop-1 named: {s['top1']:.1%} of {s['n_effect']} hidden-effect cases (target >= 95 %)")
        print(f"none on effect-free data: {s['none']:.1%} of {s['n_none']} (target >= 95 %)")
        print(f"held-out NRMSE shrink >= 50 %: {s['shrink']:.1%} of {s['n_named']} named (target: all)")
        print(f"mean time per case: {np.mean([r['seconds'] for r in rows]):.1f} s; "
              f"sweep wall time ({a.backend}): {wall:.1f} s")
    if a.speed:
        speed(a.plants.split(","))


def speed(plants) -> None:
    """Time ``diagnose`` (default rounds and report maps) at the size the 60 s target is set for:
    a 20 s record plus 10 s held out at the plant's sample rate, every diagnosable effect of each
    plant hidden once (seed 3000 + its index) and one effect-free record."""
    worst = 0.0
    for plant in plants:
        names = [e.name for e in effects_for(plant, diagnosable_only=True)] + [None]
        for i, eff in enumerate(names):
            case = hidden_effect_records(plant, eff, 3000 + i, duration=20.0, holdout_duration=10.0)
            t0 = time.perf_counter()
            res = diagnose(plant, [case.fit], [case.holdout], base=case.base.params)
            dt = time.perf_counter() - t0
            worst = max(worst, dt)
            named = [e["name"] for e in res.effects]
            right = named[:1] == [eff] if eff else res.verdict == "none"
            print(f"speed {plant:20s} {eff or 'none':20s} {dt:6.1f} s  {res.verdict:11s} "
                  f"{','.join(named) or '-':28s} {'right' if right else 'WRONG'}", flush=True)
    print(f"slowest record: {worst:.1f} s (20 s + 10 s held out; target <= 60 s)")


if __name__ == "__main__":
    main()
