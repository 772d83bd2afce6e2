"""``make demo-diagnose``: hide an effect in simulated rig data and let the workflow find it.

One case per plant folder whose diagnosis settings name a demo (hidden effect, seed): Stribeck
friction hidden in the servo cylinder (base model: Coulomb + viscous friction), and the
modified-IFAS stiffness dip hidden in the shaking table (base model: IFAS bulk modulus). For
each, the closed-loop records are written as measured-data files and the base model as a preset
(``base.yaml``), the equivalent ``hydro diagnose`` command is printed, the workflow runs with
progress and writes its report (markdown + figures) under ``--out``.

    python -m identification.diagnosis.demo [--out runs/diagnosis-demo] [--seconds 10]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from hydro_envs.data.measured import write_measured
from identification.diagnosis.cli import summary_text
from identification.diagnosis.plants import demo_cases, diagnosis_plant
from identification.diagnosis.report import write_report
from identification.diagnosis.synthetic import hidden_effect_records
from identification.diagnosis.workflow import diagnose
from identification.ranges import preset_mapping, write_preset

CASES = demo_cases()  # (base, hidden effect, seed)


def _write(path: Path, rec, spec) -> None:
    t = rec.dt * np.arange(rec.n)
    chans = {c: rec.inputs[:, j] for j, c in enumerate(spec.inputs)} | rec.channels
    write_measured(path, t, chans, plant=spec.name, metadata={"name": path.stem, "source": "simulated, hidden effect"})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="runs/diagnosis-demo")
    ap.add_argument("--seconds", type=float, default=10.0, help="fit record length (held-out: half)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    ok = True
    for plant, hidden, seed in CASES:
        spec = diagnosis_plant(plant)
        print(f"\n=== {plant}: hiding '{hidden}' (seed {seed}) ===", flush=True)
        case = hidden_effect_records(plant, hidden, seed, duration=a.seconds)
        print("hidden parameters: " + ", ".join(f"{k} = {v:.4g}" for k, v in case.drawn.items()))
        d = out / plant
        d.mkdir(parents=True, exist_ok=True)
        _write(d / "fit.csv", case.fit, spec)
        _write(d / "holdout.csv", case.holdout, spec)
        write_preset(d / "base.yaml", preset_mapping(case.base.params, f"{plant} base model",
                                                     "the demo's base model (the hidden effect absent)"))
        print(f"equivalent command: hydro diagnose --plant {plant} --data {d / 'fit.csv'} "
              f"--holdout {d / 'holdout.csv'} --base {d / 'base.yaml'} --out {d / 'report'}")
        t0 = time.perf_counter()
        res = diagnose(spec, [case.fit], [case.holdout], base=case.base.params, progress=lambda m: print(m, flush=True))
        print(summary_text(res))
        md = write_report(res, spec, [case.fit], [case.holdout], d / "report")
        print(f"report: {md}  ({time.perf_counter() - t0:.1f} s)")
        found = [e["name"] for e in res.effects]
        ok &= bool(found) and found[0] == hidden
        print("FOUND the hidden effect" if found and found[0] == hidden else f"did NOT find {hidden}: {found}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
