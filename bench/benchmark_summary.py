"""Print the summary tables of docs/benchmarks/README.md from the benchmark CSV files.

For every env, one row per controller: RMSE mean [95 % CI] on nominal / in / out, the paired
RMSE / PID ratio on each set, and on ``out`` the CVaR10 RMSE, failure rate and
pressure-violation steps. RMSE is shown in the unit of the README (servo and rodless mm, load
sensing mm/s, table m/s^2, force actuator N). Usage::

    python bench/benchmark_summary.py [--dir docs/benchmarks]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

PLANTS = (  # file tag, unit, scale from SI
    ("servo_cylinder", "mm", 1e3),
    ("shaking_table", "m/s^2", 1.0),
    ("force_actuator", "N", 1.0),
    ("load_sensing", "mm/s", 1e3),
    ("rodless_cylinder", "mm", 1e3),
)
SETS = ("nominal", "in", "out")


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


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", default=str(Path(__file__).resolve().parents[1] / "docs" / "benchmarks"))
    a = p.parse_args()
    for tag, unit, scale in PLANTS:
        print(table(Path(a.dir), tag, unit, scale))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
