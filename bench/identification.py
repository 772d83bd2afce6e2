"""Fit times of the identification tools (and the virtual experiment that feeds them).

Prints (no pass/fail; the targets in brackets):

* the 150 s constant-velocity test of 002 sec. 4 on the servo cylinder: simulation, sensor
  model, and extraction of the 136 constant-velocity points
* static friction fits on those points: Stribeck exponential / Gaussian      [< 0.1 s]
* neural friction nets of 002 sec. 5: feed-forward (LM, 5 restarts), RBF (50) [< 5 s]
  with their error E (eq (11)) beside the paper's 3.08 / 2.48 N
* Dahl and LuGre fits on 4-6 s force records at 1 kHz
* grey-box model fits: a slot for the lead (see ``BENCHES`` at the bottom)

Usage: ``python bench/identification.py [--repeats N]``. Each time is the best of ``--repeats``
runs after one warm-up run (numba compilation and caches excluded).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def best_time(fn: Callable[[], object], repeats: int) -> tuple[float, object]:
    out = fn()  # warm-up
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench_experiment(ctx: dict, repeats: int) -> list[tuple[str, float, str]]:
    from hydro_envs.data.sensors import SensorModel
    from hydro_envs.plants.servo_cylinder.friction_test import run_friction_experiment
    from identification.constant_velocity import friction_points_from_square_wave

    t_run, run = best_time(
        lambda: run_friction_experiment(sensors=SensorModel.realistic(), seed=0), repeats)
    t_pts, pts = best_time(lambda: friction_points_from_square_wave(run.data), repeats)
    ctx["points"] = pts
    return [
        (f"virtual 002 test ({run.schedule.duration:.0f} s, {run.data.n_samples} samples)", t_run, ""),
        (f"extract {len(pts)} constant-velocity points", t_pts, ""),
    ]


def bench_static(ctx: dict, repeats: int) -> list[tuple[str, float, str]]:
    from identification.friction import fit_friction

    pts = ctx["points"]
    sigma = pts.force_std / np.sqrt(pts.n_samples)
    rows = []
    for model in ("stribeck", "stribeck_gaussian"):
        t, fit = best_time(lambda: fit_friction(pts, model=model, sigma=sigma), repeats)
        rows.append((f"fit {model} ({len(pts)} points)", t, f"E = {fit.metrics['E']:.3f} N  [< 0.1 s]"))
    t, _ = best_time(lambda: fit_friction(pts, model="stribeck", asymmetric=True, sigma=sigma), repeats)
    rows.append(("fit stribeck, per direction", t, ""))
    return rows


def bench_neural(ctx: dict, repeats: int) -> list[tuple[str, float, str]]:
    from identification.neural import PAPER_E, fit_feedforward, fit_rbf

    pts = ctx["points"]
    t_ff, ff = best_time(lambda: fit_feedforward(pts, seed=0), repeats)
    t_rbf, rbf = best_time(lambda: fit_rbf(pts, seed=0), repeats)
    v = np.linspace(-0.25, 0.25, 100_000)
    t_ev, _ = best_time(lambda: ff.predict_numba(v), repeats)
    return [
        ("fit feed-forward net 1-10-1 (LM, 5 restarts)", t_ff,
         f"E = {ff.metrics['E']:.3f} N (paper {PAPER_E['feedforward']})  [< 5 s]"),
        ("fit RBF net (50 units)", t_rbf,
         f"E = {rbf.metrics['E']:.3f} N (paper {PAPER_E['rbf']})  [< 5 s]"),
        ("evaluate feed-forward net, 1e5 velocities (numba)", t_ev, ""),
    ]


def bench_dynamic(ctx: dict, repeats: int) -> list[tuple[str, float, str]]:
    from scipy.integrate import solve_ivp

    from hydro_envs.laws.friction import dahl_friction_rate, lugre_bristle_rate
    from identification.friction import fit_dahl, fit_lugre

    rng = np.random.default_rng(0)
    t = np.arange(0.0, 4.0, 1e-3)
    v = 0.03 * np.sin(2 * np.pi * 0.5 * t) + 0.004 * np.sin(2 * np.pi * 9 * t)
    sol = solve_ivp(lambda tt, y: [dahl_friction_rate(
        0.03 * np.sin(np.pi * tt) + 0.004 * np.sin(18 * np.pi * tt), y[0], 26.0, 67600.0)],
        (0, 4.0), [0.0], t_eval=t, method="LSODA", rtol=1e-10, atol=1e-10, max_step=1e-3)
    f = sol.y[0] + 50.0 * v + rng.normal(0, 0.3, t.size)
    t_dahl, _ = best_time(lambda: fit_dahl(t, v, f), repeats)

    t2 = np.arange(0.0, 6.0, 1e-3)

    def vf(tt):
        return np.where(tt < 4.0, 0.05 * np.sin(np.pi * 0.5 * tt), 0.002 * np.sin(4 * np.pi * (tt - 4.0)))

    sol = solve_ivp(lambda tt, y: [lugre_bristle_rate(float(vf(tt)), y[0], 40.0, 60.0, 0.01, 1e5)],
                    (0, 6.0), [0.0], t_eval=t2, method="LSODA", rtol=1e-10, atol=1e-13, max_step=1e-3)
    v2 = vf(t2)
    z = sol.y[0]
    zd = np.array([lugre_bristle_rate(v2[i], z[i], 40.0, 60.0, 0.01, 1e5) for i in range(t2.size)])
    f2 = 1e5 * z + 300.0 * zd + 250.0 * v2 + rng.normal(0, 0.3, t2.size)
    t_lugre, _ = best_time(lambda: fit_lugre(t2, v2, f2), repeats)
    return [
        ("fit Dahl (001 eq (1)) + viscous, 4000 samples", t_dahl, ""),
        ("fit LuGre (6 parameters + state), 6000 samples", t_lugre, ""),
    ]


def bench_greybox(ctx: dict, repeats: int) -> list[tuple[str, float, str]]:
    """Grey-box fit (``identification.greybox``) of the shaking table on 10 s of 1 kHz data
    (x and a, noisy, modified-IFAS truth; E_0, F_c, F_v from a perturbed start)."""
    import dataclasses

    from hydro_envs.plants.shaking_table import model as st
    from identification import greybox as gb

    truth = st.ShakingTableParams.preset("modified_ifas")
    dt = 1e-3
    t = dt * np.arange(10001)
    u = 3.0 * np.sin(4 * np.pi * t) + 1.0 * np.sin(2 * np.pi * 7.3 * t)
    ch = [c for c in gb.plant_setup("shaking_table")["channels"].values() if c.name in ("x", "a")]
    e = gb.Experiment(dt, u, st.rest_state(truth), {"x": u, "a": u})
    clean = gb.simulate_outputs(truth, [e], ch)[0][0]
    rng = np.random.default_rng(0)
    meas = {"x": clean["x"] + 2e-5 * rng.standard_normal(t.size), "a": clean["a"] + 0.05 * rng.standard_normal(t.size)}
    base = dataclasses.replace(truth, e0=truth.e0 * 1.3, coulomb_friction=460.0, viscous_friction=530.0)
    fit = ["e0", "coulomb_friction", "viscous_friction"]
    sec, res = best_time(lambda: gb.fit_greybox(base, fit,
                                                [gb.Experiment(dt, u, e.y0, meas)], ch), repeats)
    err = ", ".join(f"{n} {100 * (res.values[n] / getattr(truth, n) - 1):+.1f} %" for n in fit)
    return [(f"shaking table, 10 s at 1 kHz, 3 parameters ({res.nfev} fev, {res.njev} jev)", sec,
             f"{err}  [< 60 s]")]


#: sections in print order; add one entry per new identification method
BENCHES: list[tuple[str, Callable[[dict, int], list[tuple[str, float, str]]]]] = [
    ("virtual experiment", bench_experiment),
    ("static friction fits", bench_static),
    ("neural friction models", bench_neural),
    ("dynamic friction fits", bench_dynamic),
    ("grey-box", bench_greybox),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    print(f"identification fit times (best of {args.repeats}; {os.cpu_count()} CPUs)\n")
    ctx: dict = {}
    width = 58
    for title, fn in BENCHES:
        print(f"[{title}]")
        for label, seconds, note in fn(ctx, args.repeats):
            s = "      -  " if not np.isfinite(seconds) else f"{seconds:8.4f} s"
            print(f"  {label:<{width}} {s}  {note}".rstrip())
        print()


if __name__ == "__main__":
    main()
