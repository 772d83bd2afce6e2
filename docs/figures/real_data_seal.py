"""The figure of docs/real-data.md: measured seal friction of the shipped O-ring record.

Left: the friction force ``F_load - p A`` over time with the steady stroke windows the fit uses.
Right: one point per window against its speed, the fitted Coulomb levels (per direction and
symmetric) and the reference level (half the friction-force range per stroke).

    python docs/figures/real_data_seal.py [--data FILE] [--bore M] [--out PNG]
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "seal_friction_oring" / "O-ring_5bar_3cycles.csv"


def half_range(path: Path, bore: float, drop_rows: int = 15) -> float:
    """Half the mean friction-force range per stroke pair (the record's reference level) [N].

    The author's definition: friction ``p A - F_loadcell``; split the trace at its mean into
    alternating runs above (retracting) and below (extending), each at least 100 samples; the
    range of a pair is the difference of the two runs' means; half its mean over the pairs is
    the mean Coulomb level.
    """
    a = np.loadtxt(path)[drop_rows:]
    f = a[:, 5] * 1e5 * (math.pi * bore**2 / 4.0) - a[:, 6]
    mean, ranges, i = f.mean(), [], 0
    while i < f.size - 1:
        hi, lo = [], []
        while i < f.size and (len(hi) < 100 or f[i] > mean):
            hi.append(f[i])
            i += 1
        while i < f.size and (len(lo) < 100 or f[i] < mean):
            lo.append(f[i])
            i += 1
        if hi and lo:
            ranges.append(np.mean(hi) - np.mean(lo))
    return float(np.mean(ranges)) / 2.0


def main(argv: list[str] | None = None) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from identification.friction import fit_friction
    from identification.seal_friction import load_seal_friction, seal_friction_points

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--bore", type=float, default=0.025, help="bore [m] (default 0.025)")
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("real_data_seal.png"))
    args = ap.parse_args(argv)

    rec = load_seal_friction(args.data, bore=args.bore)
    area = float(rec.metadata["piston_area"])
    pts = seal_friction_points(rec)
    sym = fit_friction(pts, model="coulomb")
    asym = fit_friction(pts, model="coulomb", asymmetric=True)
    ref = half_range(args.data, args.bore)

    plt.rcParams.update({"font.size": 10})
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11.0, 4.2), dpi=120, gridspec_kw={"width_ratios": [1.6, 1]})
    f = rec["F_load"] - rec["p_gauge"] * area
    ax1.plot(rec.t, f, lw=0.8, color="0.45", label="friction $F_{load} - p\\,A$")
    for k in range(len(pts)):
        sel = (rec.t >= pts.t_start[k]) & (rec.t <= pts.t_end[k])
        ax1.plot(rec.t[sel], f[sel], lw=2.0, color="tab:blue" if pts.v[k] > 0 else "tab:orange",
                 label=("steady window, extending" if pts.v[k] > 0 else "steady window, retracting")
                 if k < 2 else None)
    ax1.set_xlabel("time t [s]")
    ax1.set_ylabel("friction force [N]")
    ax1.set_title(f"{args.data.name}: O-ring, 25 mm bore, 5 bar")
    ax1.grid(alpha=0.3)
    ax1.legend(loc="center right", fontsize=9)

    v_mm = 1e3 * pts.v
    ax2.plot(v_mm, pts.force, "o", color="k", label="one point per stroke window")
    p = asym.parameters
    ax2.hlines([p["F_c_pos"], -p["F_c_neg"]], [0, v_mm.min() * 1.2], [v_mm.max() * 1.2, 0], colors="tab:red",
               label=f"Coulomb per direction: {p['F_c_pos']:.2f} / {p['F_c_neg']:.2f} N")
    ax2.hlines([sym.parameters["F_c"], -sym.parameters["F_c"]], [0, v_mm.min() * 1.2], [v_mm.max() * 1.2, 0],
               colors="tab:green", linestyles="--", label=f"Coulomb, symmetric: {sym.parameters['F_c']:.2f} N")
    ax2.hlines([ref, -ref], [0, v_mm.min() * 1.2], [v_mm.max() * 1.2, 0], colors="tab:purple", linestyles=":",
               label=f"half the range per stroke: {ref:.2f} N")
    ax2.axhline(0.0, color="0.6", lw=0.8)
    ax2.axvline(0.0, color="0.6", lw=0.8)
    ax2.set_xlabel("rod speed v [mm/s]")
    ax2.set_ylabel("friction force [N]")
    ax2.set_title("friction against speed")
    ax2.grid(alpha=0.3)
    ax2.legend(loc="upper left", fontsize=9)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    plt.close(fig)
    print(f"wrote {os.path.relpath(args.out)} ({int(fig.get_figwidth() * fig.dpi)} x {int(fig.get_figheight() * fig.dpi)} px)")
    return args.out


if __name__ == "__main__":
    main()
