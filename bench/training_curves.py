"""Plot the training curves of the shipped policies from their ``evaluations.csv``.

Each pretrained folder (``agents/pretrained/<plant>/<name>_s<seed>``) keeps the periodic
evaluation of its run (:mod:`agents.train`: deterministic episodes on a fixed seeded set of
randomised draws every tenth of the budget). One panel per plant, one line per seed, mean raw
reward per step against training steps; prints the final value and the wall time of each run::

    python bench/training_curves.py [--name ppo_residual] [--out docs/figures/training_curves.png]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "agents" / "pretrained"


def curves(name: str) -> dict[str, dict[str, list[tuple[float, float, float]]]]:
    """plant -> folder -> [(timesteps, mean step reward, wall time s)]."""
    out: dict[str, dict[str, list[tuple[float, float, float]]]] = {}
    for f in sorted(ROOT.glob(f"*/{name}_s[0-9]*/evaluations.csv")):
        with f.open(newline="") as fh:
            rows = [(float(r["timesteps"]), float(r["mean_step_reward"]), float(r["wall_time_s"]))
                    for r in csv.DictReader(fh)]
        if rows:
            out.setdefault(f.parent.parent.name, {})[f.parent.name] = rows
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--name", default="ppo_residual", help="policy name (folders <name>_s<seed>)")
    ap.add_argument("--out", default="docs/figures/training_curves.png")
    a = ap.parse_args()
    data = curves(a.name)
    if not data:
        raise SystemExit(f"no {a.name}_s*/evaluations.csv under {ROOT}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 11})
    fig, axes = plt.subplots(1, len(data), figsize=(13, 3.6), dpi=100, squeeze=False)
    for ax, (plant, runs) in zip(axes[0], data.items()):
        for folder, rows in runs.items():
            ax.plot([r[0] / 1e6 for r in rows], [r[1] for r in rows], marker="o", ms=3, label=folder)
            print(f"{plant:18s} {folder:18s} steps {rows[-1][0]:.0f}  final mean step reward {rows[-1][1]:.4g}  "
                  f"wall {rows[-1][2]:.0f} s")
        ax.set_title(plant)
        ax.set_xlabel("training steps [M]")
        ax.set_ylabel("mean reward per step [-]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=9)
    fig.suptitle(f"{a.name}: periodic evaluation on fixed randomised draws")
    fig.tight_layout()
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(a.out)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
