"""Print the summary tables of docs/benchmarks/README.md from the benchmark CSV files.

For every env, one row per controller: RMSE mean [95 % CI] on nominal / in / out, the paired
RMSE / PID ratio on each set, and on ``out`` the CVaR10 RMSE, failure rate and
pressure-violation steps. RMSE is shown in the unit of the README (servo and rodless mm, load
sensing mm/s, table m/s^2, force actuator N). Usage::

    python bench/benchmark_summary.py [--dir docs/benchmarks] [--friction]

``--friction``: the friction tasks' tables (:data:`FRICTION_TASKS`) on their ``in`` draws.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

PLANTS = (  # file tag, unit, scale from SI
    ("servo_cylinder", "mm", 1e3),
    ("shaking_table", "m/s^2", 1.0),
    ("force_actuator", "N", 1.0),
    ("load_sensing", "mm/s", 1e3),
    ("rodless_cylinder", "mm", 1e3),
)
SETS = ("nominal", "in", "out")
#: friction tasks (file tag, unit, scale from SI, {friction-aware controller: its blind twin})
FRICTION_TASKS = (
    ("ServoCylinderSlowSine_v0", "um", 1e6, {"pid_vff_stribeck": "pid_vff", "pid_vff_lugre": "pid_vff",
                                             "pid_vff_lugre_observer": "pid_vff", "pid_vff_dob": "pid_vff",
                                             "pid_vff_neural": "pid_vff", "pid_vff_rbf": "pid_vff"}),
    ("ServoCylinderMicroPosition_v0", "um", 1e6, {"pid_vff_stribeck": "pid_vff", "pid_ff_stribeck": "pid"}),
    ("RodlessCylinderSlowSine_v0", "um", 1e6, {"pid_dp_stribeck": "pid_dp", "pid_dp_stribeck_cal": "pid_dp",
                                               "pid_dp_lugre": "pid_dp", "pid_dp_dob": "pid_dp",
                                               "pid_dp_neural": "pid_dp", "pid_dp_rbf": "pid_dp"}),
    ("RodlessCylinderMicroPosition_v0", "um", 1e6, {"pid_dp_stiction": "pid_dp", "pid_dp_stribeck": "pid_dp",
                                                    "pid_dp_neural": "pid_dp"}),
    ("ForceActuatorSmallForce_v0", "N", 1.0, {"pid_dahl": "pid", "pid_stribeck": "pid"}),
    ("ShakingTableLowFrequency_v0", "m/s^2", 1.0, {"flow_fb_lugre": "flow_fb", "flow_fb_stribeck": "flow_fb",
                                                    "pid_ff_stribeck": "pid"}),
)


def _read(path: Path) -> dict[tuple[str, str], tuple[float, float, float, str]]:
    out = {}
    with path.open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            out[(row["controller"], row["metric"])] = (float(row["value"]), float(row["ci_low"]),
                                                       float(row["ci_high"]), row["seeds"])
    return out


def _g(x: float) -> str:
    return "n/a" if x != x else f"{x:.3g}"


def table(directory: Path, tag: str, unit: str, scale: float) -> str:
    data = {s: _read(directory / f"{tag}_{s}.csv") for s in SETS}
    controllers = list(dict.fromkeys(c for (c, _) in data["nominal"]))
    lines = [f"#### {tag}: RMSE [{unit}] mean [95 % CI]; RMSE/PID paired mean; out: CVaR10 RMSE, failure rate, "
             "pressure-violation steps", "",
             "| controller | nominal RMSE | in RMSE | out RMSE | RMSE/PID nom / in / out | out CVaR10 | out failures | "
             "out p-viol. |", "|---|---|---|---|---|---|---|---|"]
    for c in controllers:
        seeds = data["nominal"][(c, "rmse")][3]
        name = c if seeds in ("", "1") else f"{c} ({seeds} seeds)"
        cells = [name]
        for s in SETS:
            m, lo, hi, _ = data[s][(c, "rmse")]
            cells.append(f"{_g(m * scale)} [{_g(lo * scale)}, {_g(hi * scale)}]")
        cells.append(" / ".join(f"{data[s][(c, 'rmse_rel_pid')][0]:.2f}" for s in SETS))
        cells.append(_g(data["out"][(c, "cvar10_rmse")][0] * scale))
        cells.append(f"{data['out'][(c, 'failed')][0]:.2f}")
        cells.append(_g(data["out"][(c, "pressure_violations")][0]))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _ci(v: tuple[float, float, float, str], scale: float = 1.0, fmt: str = ".3g") -> str:
    m, lo, hi, _ = v
    return "n/a" if m != m else f"{m * scale:{fmt}} [{lo * scale:{fmt}}, {hi * scale:{fmt}}]"


def friction_table(directory: Path, tag: str, unit: str, scale: float, twins: dict[str, str]) -> str:
    """One friction task on its ``in`` draws: RMSE, RMSE / PID (paired), the PID's
    friction_share, and each friction-aware controller against its blind twin (ratio of the
    two paired RMSE / PID means)."""
    d = _read(directory / f"{tag}_in.csv")
    controllers = list(dict.fromkeys(c for (c, _) in d))
    share = d[("pid", "friction_share")]
    rel = {c: d[(c, "rmse_rel_pid")][0] for c in controllers}
    lines = [f"#### {tag}, `in` draws: PID friction_share {_ci(share, fmt='.3f')}"
             f"{' (friction-critical)' if share[0] >= 0.5 else ' (not friction-critical)'}", "",
             f"| controller | RMSE [{unit}] | RMSE / PID (paired) | reversal excess [{unit}] | vs blind twin |",
             "|---|---|---|---|---|"]
    for c in controllers:
        twin = twins.get(c)
        vs = f"{rel[c] / rel[twin]:.2f} x {twin}" if twin in rel else ""
        lines.append(f"| {c} | {_ci(d[(c, 'rmse')], scale)} | {_ci(d[(c, 'rmse_rel_pid')], fmt='.3f')} | "
                     f"{_ci(d.get((c, 'reversal_excess'), (math.nan,) * 3 + ('',)), scale)} | {vs} |")
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", default=str(Path(__file__).resolve().parents[1] / "docs" / "benchmarks"))
    p.add_argument("--friction", action="store_true", help="the friction tasks' tables instead")
    a = p.parse_args()
    missing = sorted({f"{tag}_{s}.csv" for tag, *_ in (FRICTION_TASKS if a.friction else PLANTS)
                      for s in (("in",) if a.friction else SETS) if not (Path(a.dir) / f"{tag}_{s}.csv").is_file()})
    if missing:
        p.exit(2, f"benchmark_summary: error: --dir {a.dir}: no {', '.join(missing[:3])}"
                  f"{' ...' if len(missing) > 3 else ''}; make them with hydro benchmark --config <task> --out {a.dir}\n")
    if a.friction:
        for tag, unit, scale, twins in FRICTION_TASKS:
            print(friction_table(Path(a.dir), tag, unit, scale, twins))
        return 0
    for tag, unit, scale in PLANTS:
        print(table(Path(a.dir), tag, unit, scale))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
