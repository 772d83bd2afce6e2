"""``hydro diagnose``: run the diagnosis workflow on measured-data files.

    hydro diagnose --plant P --data FILE [--data FILE2 ...] [--holdout FILE]
                   [--base CONFIG | --params FILE | --nominal-geometry]
                   [--effects a,b] [--max-effects N] [--out DIR] [--json]

``--base`` is a YAML preset (``plant:`` and ``parameters:``, each ``{value, unit, source}``, as
:func:`identification.ranges.write_preset` writes them) that lists at least the rig's geometry
(``PhysicalParams.geometry``: areas, stroke, volumes -- a record cannot reveal them); with
``--nominal-geometry`` and no ``--base``, the plant's nominal parameters (the seed rig) with every
catalogue effect at its null value. ``--params FILE`` takes a preset as ``--base`` does or the
plant's data sheet where its contract reads one (:mod:`identification.params_file`).
``--out`` is checked before the work: a folder (created), empty unless ``--force``, never a file.
Errors follow the command line's convention (:mod:`hydro_envs.cli_errors`): one line, no
traceback. Exit codes: 0 done (any verdict: named, none, ambiguous, unexplained), 1 the data
cannot support a conclusion or the base model cannot be fitted to them, 2 usage / bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

EXIT_OK, EXIT_DATA, EXIT_USAGE = 0, 1, 2


def add_diagnose_parser(subparsers: Any) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "diagnose",
        help="find where model and measured data disagree and name the missing physical effect",
        description="Fit the base model, locate the residual, propose catalogue effects, refit each, "
        "score on held-out data, accept the best only if it clearly wins (see identification/diagnosis).",
    )
    from identification.diagnosis.plants import PLANTS

    p.add_argument("--plant", required=True, help=f"plant (base model) name ({', '.join(PLANTS)})")
    p.add_argument("--data", required=True, action="append", metavar="FILE",
                   help="measured record (CSV, Parquet or MATLAB .mat; see --map); repeat for several records")
    p.add_argument("--holdout", action="append", metavar="FILE",
                   help="held-out record(s) for scoring (default: the last 30 %% of every --data record)")
    p.add_argument("--base", metavar="CONFIG", help="YAML parameter preset of the base model (it must list the "
                   "rig's geometry: areas, stroke, volumes)")
    p.add_argument("--params", metavar="FILE", help="parameter file with units of the base model: a preset as "
                   "--base takes or the plant's data sheet where it reads one (not both flags)")
    p.add_argument("--nominal-geometry", action="store_true",
                   help="without --base: the plant's nominal parameters, the seed rig's geometry (printed); "
                   "with --base: geometry fields the preset does not list from the seed rig")
    p.add_argument("--effects", help="comma-separated catalogue effects to consider (default: all applicable)")
    p.add_argument("--max-effects", type=int, default=3, metavar="N")
    p.add_argument("--out", metavar="DIR", help="write a report (markdown + PNG figures) into this folder "
                   "(created; an existing non-empty folder only with --force)")
    p.add_argument("--force", action="store_true", help="write into a non-empty --out folder")
    p.add_argument("--json", action="store_true", help="print one JSON object (verdict, effects, candidates)")
    from hydro_envs.data.cli_args import add_record_arguments

    add_record_arguments(p)
    p.set_defaults(func=_cmd_diagnose)
    return p


def _load_base(args: argparse.Namespace):
    """The base model's parameters: the ``--base`` preset (listing the rig's geometry unless
    ``--nominal-geometry``), or ``None`` (the nominal base) when the geometry is the seed rig's on
    purpose or the plant has none; else a one-line error naming both flags."""
    from hydro_envs.params import geometry_text, missing_geometry_error
    from identification.diagnosis.plants import diagnosis_plant
    from identification.ranges import load_preset

    cls = diagnosis_plant(args.plant).params_cls
    if args.params:
        from hydro_envs.cli_errors import CliError
        from identification.params_file import load_params_file

        if args.base:
            raise CliError(f"give --base ({args.base}) or --params ({args.params}), not both")
        return load_params_file(args.plant, args.params, require=() if args.nominal_geometry else cls.geometry)
    if args.base:
        return load_preset(args.base, cls, require=() if args.nominal_geometry else cls.geometry)
    if not cls.geometry:
        return None
    if not args.nominal_geometry:
        raise missing_geometry_error(cls, (), f"hydro diagnose --plant {args.plant}",
                                     "give --base PRESET.yaml listing them", "--nominal-geometry")
    print(f"hydro diagnose: note: --nominal-geometry: the seed rig's {geometry_text(cls())}", file=sys.stderr)
    return None


def _cmd_diagnose(args: argparse.Namespace) -> int:
    """Run the diagnosis; an error is one line (and, with ``--json``, a JSON object with it)."""
    try:
        return _diagnose(args)
    except Exception as e:
        if args.json:
            from hydro_envs.cli_errors import exit_code_for

            msg = " ".join(str(e).split())
            if exit_code_for(e) == EXIT_DATA and not msg.startswith("the data"):
                msg = f"the data cannot support a conclusion: {msg}"
            print(json.dumps({"verdict": None, "error": msg}))
        raise


def _diagnose(args: argparse.Namespace) -> int:
    from hydro_envs.data.cli_args import record_kwargs
    from hydro_envs.data.measured import load_measured
    from hydro_envs.outputs import check_output_dir
    from identification.diagnosis import diagnose, diagnosis_plant, record_from_measured

    spec = diagnosis_plant(args.plant)
    base = _load_base(args)
    if args.out:
        check_output_dir(args.out, force=bool(args.force), inputs=[*args.data, *(args.holdout or [])])
    import hydro_envs.plants  # noqa: F401  (registers the plants' channels)

    def load(path):
        data = load_measured(path, plant=args.plant, required=spec.required, **record_kwargs(args))
        for note in data.notes:
            print(f"hydro diagnose: note: {note}", file=sys.stderr)
        return record_from_measured(data, spec)

    records = [load(p) for p in args.data]
    holdout = [load(p) for p in args.holdout] if args.holdout else None
    effects = [e.strip() for e in args.effects.split(",")] if args.effects else None
    progress = None if args.json else (lambda m: print(m, flush=True))
    res = diagnose(spec, records, holdout, base=base, effects=effects, max_effects=args.max_effects,
                   progress=progress)
    if args.out:
        from identification.diagnosis.report import write_report

        path = write_report(res, spec, records, holdout, args.out)
        if not args.json:
            print(f"report: {path}")
    if args.json:
        print(json.dumps(res.to_json_dict(), allow_nan=False))
    else:
        print(summary_text(res))
    return EXIT_OK


def _fmt(values: dict, floor: dict) -> str:
    return ", ".join(f"{k} {v:.3g} {floor.get(k, {}).get('unit', '')}".rstrip() for k, v in values.items())


def threshold_words(channel: str, fl: dict, minimum: float) -> str:
    """One channel's threshold of ``unexplained`` and what it used (its factor in floors, the
    residual a correct model is expected to leave and its parts, the noise spread)."""
    fac = fl.get("factor", minimum)
    out = f"{channel} {fl.get('threshold', fac * fl['floor']):.3g} {fl.get('unit', '')}".rstrip() + f" = {fac:.3g} floors"
    if "expected" in fl:
        out += (f" [{'plant minimum' if fac <= fl['minimum_factor'] else '2 x expected x spread'}; expected "
                f"{fl['expected']:.3g} floors (start state {fl['start_state'] / fl['floor'] if fl['floor'] else 0:.2g}, "
                f"mains lines {fl['lines'] / fl['floor'] if fl['floor'] else 0:.2g}"
                + (f" at {', '.join(f'{f:g}' for f in fl['lines_hz'])} Hz" if fl.get("lines_hz") else "")
                + f"), spread {fl['spread']:.3g} over N_eff {fl['n_eff']:.0f}]")
    return out


def summary_text(res) -> str:
    """The verdict, its reason, the noise floor, the held-out residual after each step (channel
    units and noise floors), the effects found and the final model."""
    lines = [f"verdict: {res.verdict}" + (f" ({res.ambiguous})" if res.ambiguous else "")]
    if res.reason:
        lines.append(f"  reason: {res.reason}")
    if res.noise_floor:
        lines.append("  noise floor (held-out, in the score band): " + _fmt(
            {k: v["floor"] for k, v in res.noise_floor.items()}, res.noise_floor))
        lines.append(f"  threshold of 'unexplained' (per channel, at least {res.unexplained_factor:g} floors): " + ", ".join(
            threshold_words(k, v, res.unexplained_factor) for k, v in res.noise_floor.items()))
        est = next((v["estimator"] for v in res.noise_floor.values() if v.get("estimator")), "")
        if est:
            lines.append(f"  noise levels: {est}")
    for r in res.residual:
        lines.append(f"  held-out residual RMS, {r['step']}: {_fmt(r['rms'], res.noise_floor)} ("
                     + ", ".join(f"{k} {v:.2f}" for k, v in r["floors"].items()) + " noise floors)")
    for e in res.effects:
        fin = e.get("final_parameters", {})
        ps = ", ".join(f"{k} = {v:.4g} +- {e['std_errors'].get(k, float('nan')):.2g}"
                       + (f" (final model: {fin[k]:.4g})" if k in fin and abs(fin[k] - v) > 1e-3 * max(abs(v), 1e-12)
                          else "") for k, v in e["parameters"].items())
        lines.append(f"  {e['name']}: {ps}; held-out NRMSE {e['nrmse_before']:.4f} -> {e['nrmse_after']:.4f} "
                     f"(gap shrink {e['shrink']:.0%} on {', '.join(e['shrink_channels'])}"
                     + (f"; named with {e['pair']}: neither alone lowered it" if e.get("pair") else "") + ")")
    if res.final_model_table:
        from identification.diagnosis.final_model import final_model_lines

        lines.append("  final model (value +- standard error):")
        lines += [f"    {line}" for line in final_model_lines(res.final_model_table)]
    for n in res.notes:
        lines.append(f"  note: {n}")
    lines.append(f"  run time: {res.seconds:.1f} s")
    return "\n".join(lines)
