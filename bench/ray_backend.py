"""Ray backend vs serial: wall time and identical results for the benchmark and the diagnosis
sweep on this machine.

    python bench/ray_backend.py [--num-cpus N] [--n 20] [--plants slider] [--seeds 1]
                                [--skip-benchmark] [--skip-diagnosis]

Benchmark: the servo cylinder, every classical controller, ``in`` draws, ``--n`` draws,
registered episode length. Diagnosis: every case of ``bench/diagnosis.py`` for ``--plants`` and
``--seeds``. Each runs serially, then on a local Ray twice: "cold" includes starting Ray and the
workers' first imports and numba cache loads (what one command-line run pays), "warm" reuses
them (a long-lived session or a cluster). Prints the times and checks the results are equal.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

# the package, not bench/identification.py: drop this folder from the path (Ray would also put
# it first on its workers' path) and put the repository root first
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from agents import benchmark as bm  # noqa: E402
from agents.backend import ensure_ray  # noqa: E402
from agents.controllers import controller_names  # noqa: E402

SERVO = "hydro_envs/ServoCylinderPosition-v0"


def _equal_benchmark(a: bm.BenchmarkResult, b: bm.BenchmarkResult) -> bool:
    return a.markdown() == b.markdown() and all(
        np.array_equal(a.episodes[c][k], b.episodes[c][k], equal_nan=True) for c in a.episodes for k in a.episodes[c])


def _rows_text(rows) -> str:
    """The rows without their run times, as text (NaN equals NaN; floats to the last bit)."""
    return repr([{k: v for k, v in r.items() if k != "seconds"} for r in rows])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--num-cpus", type=int, default=os.cpu_count())
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--plants", default="slider")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--duration", type=float, default=8.0)
    ap.add_argument("--skip-benchmark", action="store_true")
    ap.add_argument("--skip-diagnosis", action="store_true")
    a = ap.parse_args(argv)
    print(f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; local Ray with {a.num_cpus} CPUs")
    ctrls = list(controller_names(SERVO))
    rows = []
    t = time.perf_counter()
    ensure_ray(num_cpus=a.num_cpus)
    rows.append(("ray.init (local)", time.perf_counter() - t, ""))
    if not a.skip_benchmark:
        kw = dict(params="in", n=a.n, seed=0, figures=False)
        t = time.perf_counter()
        ser = bm.run_benchmark(SERVO, ctrls, **kw)
        rows.append((f"benchmark serial ({len(ctrls)} controllers x {a.n} draws)", time.perf_counter() - t, ""))
        for label in ("cold", "warm"):
            t = time.perf_counter()
            par = bm.run_benchmark(SERVO, ctrls, backend="ray", **kw)
            rows.append((f"benchmark ray, {label}", time.perf_counter() - t,
                         "identical" if _equal_benchmark(ser, par) else "DIFFERENT"))
    if not a.skip_diagnosis:
        import bench.diagnosis as bd

        cases = bd.cases(a.plants.split(","), a.seeds)
        t = time.perf_counter()
        ser_rows = bd.run_cases(cases, a.duration, 2, verbose=False)
        rows.append((f"diagnosis serial ({len(cases)} cases, {a.plants})", time.perf_counter() - t, ""))
        for label in ("cold", "warm"):
            t = time.perf_counter()
            par_rows = bd.run_cases(cases, a.duration, 2, backend="ray", verbose=False)
            same = _rows_text(par_rows) == _rows_text(ser_rows)
            for r, q in zip(ser_rows, par_rows):
                for k in r:
                    if k != "seconds" and repr(r[k]) != repr(q[k]):
                        print(f"differs: {r['plant']} {r['true']} {k}: serial {r[k]!r}, ray {q[k]!r}")
            rows.append((f"diagnosis ray, {label}", time.perf_counter() - t, "identical" if same else "DIFFERENT"))
    print(f"\n{'':50s} {'wall [s]':>9s}")
    for name, sec, note in rows:
        print(f"{name:50s} {sec:9.1f}  {note}")


if __name__ == "__main__":
    main()
