"""``hydro identify METHOD ...``: identification from measured-data files.

A registry of methods: each entry names a method, adds its arguments to its own sub-parser and
runs it, returning a result mapping with ``parameters``, ``std_errors``, ``units`` and
``metrics`` (plus anything else worth printing). The common driver prints a table or, with
``--json``, one JSON object. Adding a method is one :func:`register_method` call::

    register_method("arx", "ARX model from input/output data", _arx_arguments, _arx_run)

This module imports only the standard library at import time (``hydro --help`` stays fast);
each method imports numpy/scipy and the identification modules when it runs.

Errors follow the command line's convention (:mod:`hydro_envs.cli_errors`): one line, no
traceback. Exit codes: 0 success, 1 the data cannot give the model (too few points,
unidentifiable parameters; the message says why), 2 bad input or usage (an argument, a record
refused by its plant's plausibility checks, an output that would overwrite an input or an
existing file without ``--force``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from hydro_envs.cli_errors import CliError

__all__ = ["Method", "METHODS", "register_method", "add_identify_parser", "main"]

EXIT_OK = 0
EXIT_FAIL = 1
EXIT_USAGE = 2


@dataclass(frozen=True)
class Method:
    """One ``hydro identify`` method."""

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], Mapping[str, Any]]
    description: str = ""


#: name -> method, in registration order (the order of ``hydro identify --help``)
METHODS: dict[str, Method] = {}


def register_method(
    name: str,
    help: str,
    add_arguments: Callable[[argparse.ArgumentParser], None],
    run: Callable[[argparse.Namespace], Mapping[str, Any]],
    description: str = "",
) -> Method:
    """Register (or replace) a method of ``hydro identify``."""
    m = Method(name, help, add_arguments, run, description or help)
    METHODS[name] = m
    return m


# ======================================================================================
# driver
# ======================================================================================


def add_identify_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``identify`` (with one sub-command per registered method) to ``hydro``'s parser."""
    p = subparsers.add_parser(
        "identify",
        help="identify model parameters from a measured-data file (" + ", ".join(METHODS) + ")",
        description="Fit a model to measured data and print its parameters with standard "
        "errors and fit metrics (NRMSE, E = mean absolute error). Methods: "
        + ", ".join(f"{m.name} ({m.help})" for m in METHODS.values()),
    )
    _add_methods(p)
    p.set_defaults(func=_cmd_identify)
    return p


def _add_methods(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="method", metavar="METHOD", title="methods")
    for m in METHODS.values():
        mp = sub.add_parser(m.name, help=m.help, description=m.description,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
        m.add_arguments(mp)
        _add_record_options(mp)
        _add_ranges_options(mp)
        mp.add_argument("--json", action="store_true",
                        help="print one JSON object with parameters, std_errors, units, metrics "
                        "(and, for arx, frf and greybox, the fit-quality flag 'quality')")
        mp.add_argument("--force", action="store_true",
                        help="replace an existing --emit-ranges file (an input file is never replaced)")


def _add_ranges_options(mp: argparse.ArgumentParser) -> None:
    """``--emit-ranges`` and its options: the fit as a randomisation spec of an env's plant."""
    g = mp.add_argument_group("randomisation spec from the fit")
    g.add_argument("--emit-ranges", default=None, metavar="FILE",
                   help="write a randomisation spec (YAML, the schema of a plant's randomization.yaml) "
                   "with ranges = estimate +- K standard errors, clipped to each parameter's allowed "
                   "values; a nominal outside a range widens it (noted in the entry's source). Load it "
                   "with gym.make(ENV_ID, randomization=FILE). See identification.ranges")
    g.add_argument("--ranges-k", type=float, default=2.0, metavar="K",
                   help="--emit-ranges half-width in standard errors (default 2)")
    g.add_argument("--ranges-plant", default=None, metavar="PLANT",
                   help="plant whose parameters the spec sets (default: --plant; required when the "
                   "record's plant has no env: its friction then calibrates the cylinder plant named)")
    g.add_argument("--ranges-map", action="append", default=[], metavar="NAME=FIELD",
                   help="map a fitted parameter to a field of the plant's parameters (repeatable), "
                   "e.g. mass=platform_mass for an FRF fit whose input is a force [N]")


def _emit_ranges(name: str, args: argparse.Namespace, res: dict[str, Any]) -> None:
    """Write ``--emit-ranges`` (if given) from the result and note it in ``res``."""
    path = getattr(args, "emit_ranges", None)
    if not path:
        return
    from identification import ranges

    if name == "friction" and getattr(args, "asymmetric", False):
        raise ValueError("--emit-ranges needs a symmetric friction fit (the plants' friction parameters "
                         "are the same in both directions)")
    plant = args.ranges_plant or getattr(args, "plant", None)
    if not args.ranges_plant:
        from hydro_envs import registry

        if not registry.get(plant).envs:
            with_env = [s.name for s in registry.specs() if s.envs]
            raise ValueError(f"--emit-ranges: plant {plant!r} has no env; name the plant whose parameters "
                             f"the fit calibrates with --ranges-plant (one of {', '.join(with_env)})")
    fmap = {}
    for item in args.ranges_map:
        if "=" not in item:
            raise ValueError(f"--ranges-map {item!r}: expected NAME=FIELD")
        a, b = item.split("=", 1)
        fmap[a.strip()] = b.strip()
    desc = f"hydro identify {name}" + (f" --model {args.model}" if name == "friction" else "") \
        + (" (weighted)" if res.get("weighted") else "")
    out = ranges.write_spec_from_result(path, res, plant, method=name, field_map=fmap or None,  # atomic
                                        k=args.ranges_k, data_file=str(args.data), fit_description=desc)
    res["ranges_file"] = str(out)
    res["ranges_plant"] = plant
    res.setdefault("notes", [])
    res["notes"] = list(res["notes"]) + [f"randomisation spec of plant {plant} written to {out} "
                                         "(gym.make(ENV_ID, randomization=FILE))"]


def _add_record_options(mp: argparse.ArgumentParser) -> None:
    """The loader's options (--map, --units, --delimiter, --allow-gaps, ...) plus --map-file."""
    from hydro_envs.data.cli_args import add_record_arguments

    add_record_arguments(mp)
    mp.add_argument("--map-file", dest="record_map_file", default=None, metavar="YAML",
                    help="YAML file with the column map (same content as --map; --map wins)")


def _record_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of ``load_measured`` from the parsed loader options: every record, in
    every format, is checked against its plant's registry entry before a fit."""
    from hydro_envs.data.cli_args import record_kwargs

    kw = record_kwargs(args)
    if kw.get("column_map") is None and getattr(args, "record_map_file", None):
        kw["column_map"] = args.record_map_file
    return kw


def _check_outputs(args: argparse.Namespace) -> None:
    """``--emit-ranges`` checked before the work: a YAML file that is no input and, without
    ``--force``, does not exist yet."""
    path = getattr(args, "emit_ranges", None)
    if not path:
        return
    from hydro_envs.outputs import check_output_file

    inputs = [getattr(args, "data", None), getattr(args, "record_map_file", None), getattr(args, "record_map", None)]
    check_output_file(path, flag="--emit-ranges", inputs=[i for i in inputs if i], force=bool(getattr(args, "force", False)),
                      suffixes=(".yaml", ".yml"))


def _contiguous(data: Any, args: argparse.Namespace) -> Any:
    """:func:`_longest_segment` with its note kept in ``args.record_notes`` for the report."""
    notes: list[str] = []
    out = _longest_segment(data, notes)
    args.record_notes = notes + units_note(data)
    return out


def units_note(data: Any) -> list[str]:
    """The reader's notes: a header without units read in the registered (SI) units, a sidecar
    beside the file that was not used."""
    assumed = getattr(data, "units_assumed", ())
    out = [f"the header gives no unit for {len(assumed)} column(s); read as the registered SI "
           f"units: {', '.join(assumed)}"] if assumed else []
    return out + list(getattr(data, "notes", ()))


def _longest_segment(data: Any, notes: list[str]) -> Any:
    """The longest gap-free segment of a record split by ``--allow-gaps`` (a note says so).

    Methods that need one contiguous uniform record (arx, frf, slider, greybox) use it; a gap
    is never interpolated.
    """
    import dataclasses

    segs = getattr(data, "segments", None)
    if not segs:
        return data
    a, b = max(segs, key=lambda s: s[1] - s[0])
    notes.append(f"record has {len(segs)} gap-separated segments; the longest (samples {a}..{b - 1}, "
                 f"t = {data.t[a]:.6g}..{data.t[b - 1]:.6g} s) is used")
    return dataclasses.replace(data, t=data.t[a:b], channels={k: v[a:b] for k, v in data.channels.items()},
                               segments=None)


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.6g}" if math.isfinite(v) else str(v)
    return str(v)


def _print_text(res: Mapping[str, Any]) -> None:
    head = [f"{k}: {res[k]}" for k in ("method", "plant", "model", "data") if k in res]
    print("  ".join(head))
    params = res.get("parameters", {})
    se = res.get("std_errors", {})
    units = res.get("units", {})
    if params:
        rows = [[k, _fmt(v), _fmt(se[k]) if k in se else "-", units.get(k, "")]
                for k, v in params.items()]
        widths = [max(len(r[i]) for r in rows + [["parameter", "value", "std error", "unit"]])
                  for i in range(4)]
        print()
        for r in [["parameter", "value", "std error", "unit"], ["-" * w for w in widths]] + rows:
            print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    dirp = res.get("direction_parameters") or {}
    if dirp:
        dse = res.get("direction_std_errors") or {}
        print()
        print("per direction of motion:")
        for k, v in dirp.items():
            print(f"  {k} = {_fmt(v)} +- {_fmt(dse.get(k, float('nan')))}")
    metrics = res.get("metrics", {})
    if metrics:
        print()
        print("metrics: " + ", ".join(f"{k} = {_fmt(v)}" for k, v in metrics.items()))
    for note in res.get("notes", []):
        print(f"note: {note}")
    if "quality" in res:
        from identification.quality import warning_lines

        for line in warning_lines(res["quality"]):
            print(line)


#: methods whose result carries the fit-quality flag (identification.quality)
_GATED = ("arx", "frf", "greybox")


def _cmd_identify(args: argparse.Namespace) -> int:
    """Run the chosen method; errors propagate to the command line's one-line convention
    (:func:`hydro_envs.cli_errors.guarded`)."""

    name = getattr(args, "method", None)
    if name is None:
        raise CliError("choose a method: " + ", ".join(METHODS))
    method = METHODS[name]
    _check_outputs(args)
    res = dict(method.run(args))
    res.setdefault("method", name)
    record_notes = getattr(args, "record_notes", None)
    if record_notes:
        res["notes"] = list(res.get("notes") or []) + list(record_notes)
    if name in _GATED:
        from identification.quality import assess

        res["quality"] = assess(res, name)
    try:
        _emit_ranges(name, args, res)
    except ValueError as e:  # RangesError, RandomizationError
        raise CliError(f"--emit-ranges: {e}") from None
    if getattr(args, "json", False):
        from hydro_envs.jsonutil import to_jsonable

        print(json.dumps(to_jsonable(res), allow_nan=False))
    else:
        _print_text(res)
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    """Standalone entry point: ``python -m identification.cli METHOD ...``."""
    from hydro_envs.cli_errors import Parser, guarded

    parser = Parser(prog="python -m identification.cli", description="identification methods of hydro-envs")
    _add_methods(parser)
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:
        code = e.code
        return code if isinstance(code, int) else (EXIT_OK if code is None else EXIT_USAGE)
    if getattr(args, "method", None) is None:
        parser.print_help()
        return EXIT_USAGE
    return guarded("python -m identification.cli", _cmd_identify, args)


# ======================================================================================
# method: friction
# ======================================================================================

def _friction_tests() -> dict[str, str]:
    """Plant -> its friction test (``PlantSpec.friction_test``: annulus, two_areas, strokes), registry order."""
    from hydro_envs import registry

    return {s.name: s.friction_test for s in registry.specs() if s.friction_test is not None}


def _friction_plants(test: str) -> list[str]:
    return [n for n, t in _friction_tests().items() if t == test]


_FRICTION_MODELS = ("stribeck", "stribeck_gaussian", "coulomb_viscous", "coulomb", "neural_ff",
                    "neural_rbf")


def _friction_arguments(p: argparse.ArgumentParser) -> None:
    annulus, two, strokes = (", ".join(_friction_plants(t)) for t in ("annulus", "two_areas", "strokes"))
    p.add_argument("--plant", required=True, choices=list(_friction_tests()),
                   help=f"{annulus}: square-wave constant-velocity test (002 sec. 4; "
                   f"channels u, x, p1, p2); {strokes}: constant-speed strokes (original "
                   f"whitespace files or measured-data CSV); {two}: the square wave of a "
                   "single-rod cylinder, F = A1 p1 - A2 p2 (gauge), its areas from --bore/--rod, --params "
                   "or the file's param.bore/param.rod metadata")
    p.add_argument("--data", required=True, metavar="FILE", help="measured-data file")
    p.add_argument("--params", default=None, metavar="FILE",
                   help=f"{two}: parameter file with units giving bore and rod")
    p.add_argument("--model", default="stribeck", choices=_FRICTION_MODELS,
                   help="stribeck (002 eq (1)), stribeck_gaussian (003 eq (11)), "
                   "coulomb_viscous, coulomb, neural_ff / neural_rbf (002 sec. 5); "
                   "default stribeck")
    p.add_argument("--asymmetric", action="store_true",
                   help="fit each direction separately (static models)")
    p.add_argument("--pressure-dependent", action="store_true",
                   help="add k_p * p to the Coulomb/static level (static models)")
    p.add_argument("--area", type=float, default=None, metavar="M2",
                   help=f"piston area [m^2] that the pressure acts on ({annulus}: the annulus). "
                   "Geometry is never assumed: --area, --bore or the file's piston_area metadata is required")
    p.add_argument("--bore", type=float, default=None, metavar="M",
                   help=f"cylinder bore [m]: area = pi bore^2 / 4 ({strokes}, e.g. 0.025 or 0.0257 for the "
                   f"EvaZillen rigs) or pi (bore^2 - rod^2) / 4 with --rod ({annulus}, a double-rod cylinder). "
                   "The seal bench's irregular clock (10-17 ms steps, pauses) is accepted: each stroke window is "
                   "fitted on its own time stamps")
    p.add_argument("--rod", type=float, default=None, metavar="M",
                   help=f"{annulus} with --bore: piston rod diameter [m]")
    p.add_argument("--sign-velocity", type=float, default=0.0, metavar="V",
                   help="fit tanh(v/V) instead of sign(v) (match a simulator's regularisation)")
    p.add_argument("--unweighted", action="store_true",
                   help="equal weights (default: each point weighted by the standard error of "
                   "its window mean; seal_friction strokes always get equal weights: the scatter "
                   "within a stroke says nothing of the stroke-to-stroke variation of its mean)")
    p.add_argument("--seed", type=int, default=0, help="seed of the neural nets (default 0)")
    p.add_argument("--drop-rows", type=int, default=15, metavar="N",
                   help="seal_friction, original format: leading rows to drop (default 15, as "
                   "the original analysis; 5 for the every-third-row test subset)")


#: plausible cylinder bores and rods [m] and piston areas [m^2]: 1 mm to 1 m (a value outside is
#: most likely given in mm or mm^2)
_BORE_RANGE = (1e-3, 1.0)
_AREA_RANGE = (1e-7, 1.0)


def _geometry_value(flag: str, value: float | None, unit: str, lo: float, hi: float) -> float | None:
    """``value`` if it is a plausible bore / rod [m] or area [m^2], else a one-line error naming the
    flag, the value, the allowed range and (for a value in mm or mm^2) the SI value meant."""

    if value is None:
        return None
    if not (math.isfinite(value) and lo <= value <= hi):
        scale, sub = (1e-6, "mm^2") if unit == "m^2" else (1e-3, "mm")
        hint = (f"; given in {sub}? {value:g} {sub} is {value * scale:g} {unit}"
                if math.isfinite(value) and value > hi and lo <= value * scale <= hi else "")
        raise CliError(f"{flag} = {value:g} {unit}; allowed {lo:g} to {hi:g} {unit} (SI units){hint}")
    return value


def _check_geometry_flags(args: argparse.Namespace) -> None:
    """``--area``, ``--bore``, ``--rod``: each plausible, and a consistent combination (before any work)."""

    _geometry_value("--area", args.area, "m^2", *_AREA_RANGE)
    _geometry_value("--bore", args.bore, "m", *_BORE_RANGE)
    _geometry_value("--rod", args.rod, "m", *_BORE_RANGE)
    if args.bore is not None and args.area is not None:
        raise CliError(f"give --bore ({args.bore:g} m) or --area ({args.area:g} m^2), not both")
    test = _friction_tests()[args.plant]
    rod_plants = _friction_plants("annulus") + _friction_plants("two_areas")
    if args.rod is not None and (args.plant not in rod_plants or args.bore is None):
        raise CliError(f"--rod = {args.rod:g} m: only with --bore, for {' or '.join(rod_plants)}")
    if getattr(args, "params", None) is not None and test != "two_areas":
        raise CliError(f"--params: only for --plant {' or '.join(_friction_plants('two_areas'))} (got {args.plant})")
    if test == "two_areas" and args.area is not None:
        raise CliError(f"--area = {args.area:g} m^2: a differential cylinder has two areas; give --bore M and "
                       "--rod M (or --params FILE)")
    if test == "two_areas" and args.bore is not None and args.rod is None:
        raise CliError(f"--bore = {args.bore:g} m: give --rod M too (the rod-side area is pi (bore^2 - rod^2) / 4)")
    if test == "two_areas" and args.bore is not None and not args.rod < args.bore:
        raise CliError(f"--rod = {args.rod:g} m; allowed below --bore = {args.bore:g} m")
    if test == "annulus" and args.bore is not None:
        if args.rod is None:
            raise CliError(f"--bore = {args.bore:g} m: {args.plant} is a double-rod cylinder, the pressure acts on "
                           "the annulus; give --rod M too (or --area M2 of the annulus)")
        if not args.rod < args.bore:
            raise CliError(f"--rod = {args.rod:g} m; allowed below --bore = {args.bore:g} m")


def _param_metadata(data: Any, key: str, where: str) -> float | None:
    """A ``param.NAME`` metadata value (``"VALUE [UNIT]"``, as hydro simulate writes it) in SI, or None."""
    raw = data.metadata.get(key)
    if raw is None:
        return None
    try:
        return float(str(raw).split("[")[0])
    except ValueError:
        raise CliError(f"{where}: metadata {key} = {raw!r}; allowed a number in SI units") from None


def _differential_areas(args: argparse.Namespace, data: Any) -> tuple[float, float, float, str]:
    """Cap- and rod-side areas [m^2], the ambient pressure [Pa] and a note on their source:
    ``--bore``/``--rod``, ``--params FILE`` or the record's ``param.bore``/``param.rod`` metadata."""
    from hydro_envs import registry
    from hydro_envs.data.units import AMBIENT_PRESSURE

    amb = _param_metadata(data, "param.ambient_pressure", str(args.data))
    note = ""
    if args.bore is not None:
        bore, rod = args.bore, args.rod
    elif getattr(args, "params", None) is not None:
        load = registry.get(args.plant).contract.load_params
        if load is None:
            raise CliError(f"--params: plant {args.plant!r} reads no parameter file")
        rig = load(args.params)
        bore, rod, amb, note = rig.bore, rig.rod, rig.ambient_pressure, f"bore and rod from {args.params}"
    else:
        bore = _param_metadata(data, "param.bore", str(args.data))
        rod = _param_metadata(data, "param.rod", str(args.data))
        if bore is None or rod is None:
            raise CliError(f"{args.data}: the cylinder's geometry is unknown -- the record carries no param.bore / "
                           "param.rod metadata; give --bore M and --rod M, or --params FILE")
        note = f"bore {bore:g} m and rod {rod:g} m from the file's metadata"
    _geometry_value("bore", bore, "m", *_BORE_RANGE)
    _geometry_value("rod", rod, "m", *_BORE_RANGE)
    if not rod < bore:
        raise CliError(f"rod = {rod:g} m; allowed below bore = {bore:g} m")
    if amb is None:
        amb = AMBIENT_PRESSURE
        note += ("; " if note else "") + f"ambient pressure {amb:g} Pa (standard atmosphere) on the rod's end"
    return math.pi * bore**2 / 4.0, math.pi * (bore**2 - rod**2) / 4.0, float(amb), note


def _servo_area(args: argparse.Namespace, data: Any) -> tuple[float, str]:
    """The annulus area of a servo-cylinder record and a note on where it came from: ``--area``,
    ``--bore`` with ``--rod``, or the file's ``piston_area`` metadata; never assumed."""

    if args.area is not None:
        return float(args.area), ""
    if args.bore is not None:
        return math.pi * (args.bore**2 - args.rod**2) / 4.0, ""
    if "piston_area" in data.metadata:
        try:
            area = float(data.metadata["piston_area"])
        except ValueError:
            raise CliError(f"{args.data}: metadata piston_area = {data.metadata['piston_area']!r}; allowed a number "
                           "in m^2") from None
        _geometry_value(f"{args.data}: metadata piston_area", area, "m^2", *_AREA_RANGE)
        return area, f"piston area {area:g} m^2 from the file's piston_area metadata"
    raise CliError(f"{args.data}: the piston area is unknown -- the record carries no geometry (no piston_area "
                   "metadata); give --area M2 (the annulus) or --bore M with --rod M")


def _friction_run(args: argparse.Namespace) -> dict[str, Any]:
    import numpy as np


    from identification.constant_velocity import friction_points_from_square_wave
    from identification.seal_friction import load_seal_friction, seal_friction_points
    from identification import friction as fr
    from hydro_envs.data.measured import load_measured

    _check_geometry_flags(args)
    test = _friction_tests()[args.plant]
    if test == "annulus":
        data = load_measured(args.data, plant=args.plant, required=("u", "x", "p1", "p2"),
                             **_record_kwargs(args))
        area, note = _servo_area(args, data)
        args.record_notes = units_note(data) + ([note] if note else [])
        pts = friction_points_from_square_wave(data, area)
    elif test == "two_areas":
        data = load_measured(args.data, plant=args.plant, required=("u", "x", "p1", "p2"), **_record_kwargs(args))
        area, area_2, amb, note = _differential_areas(args, data)
        args.record_notes = units_note(data) + ([note] if note else [])
        pts = friction_points_from_square_wave(data, area, area_2=area_2, ambient_pressure=amb)
    else:
        data = load_seal_friction(args.data, drop_rows=args.drop_rows, bore=args.bore,
                                  stroke=getattr(args, "record_stroke", None))
        args.record_notes = units_note(data)
        if args.area is None and "piston_area" not in data.metadata:
            raise CliError(f"{args.data}: the piston area is unknown -- the file carries no "
                           "geometry; give --bore M (e.g. 0.025) or --area M2")
        if args.area is None:
            _geometry_value("piston_area (file metadata)", float(data.metadata["piston_area"]), "m^2", *_AREA_RANGE)
        pts = seal_friction_points(data, piston_area=args.area)
        area = pts.meta["piston_area"]
    res: dict[str, Any] = {"method": "friction", "plant": args.plant, "model": args.model,
                           "data": str(args.data), "n_points": len(pts), "area": area}
    if pts.meta.get("area_2") is not None:
        res["area_2"] = pts.meta["area_2"]
    if args.model.startswith("neural"):
        from identification import neural

        kind = "feedforward" if args.model == "neural_ff" else "rbf"
        net = neural.fit_neural_friction(pts, kind=kind, seed=args.seed)
        res["parameters"] = ({"n_hidden": net.n_hidden, "n_weights": net.n_weights}
                             if kind == "feedforward" else {"n_units": net.n_units})
        res["std_errors"] = {}
        res["units"] = {}
        res["metrics"] = {k: net.metrics[k] for k in ("nrmse", "E", "rmse", "n_points")}
        res["weights"] = net.to_dict()
        res["notes"] = [f"E of 002 sec. 5 on the paper's rig: {neural.PAPER_E[kind]} N"]
        return res
    sigma = None
    equal = args.unweighted or test == "strokes"
    if not equal and pts.force_std is not None and pts.n_samples is not None:
        se = pts.force_std / np.sqrt(pts.n_samples)
        if np.all(se > 0):
            sigma = se
    fit = fr.fit_friction(pts, model=args.model, asymmetric=args.asymmetric,
                          pressure_dependent=args.pressure_dependent,
                          sign_velocity=args.sign_velocity, sigma=sigma)
    m = fit.metrics
    res["parameters"] = fit.parameters
    res["std_errors"] = fit.std_errors
    res["units"] = fit.units
    res["metrics"] = {"nrmse": m["nrmse"], "E": m["E"], "rmse": m["rmse"],
                      "n_points": m["n_points"]}
    res["weighted"] = sigma is not None
    if _friction_tests()[args.plant] == "strokes":
        _refuse_clamped(fit.parameters, fit.std_errors, fit.units, args.model)
    return res


register_method(
    "friction",
    "static friction curve from constant-velocity data",
    _friction_arguments,
    _friction_run,
    description="Extract constant-velocity friction points (002 sec. 4 / 004 sec. 3.2) from a "
    "measured-data file and fit a friction model: Stribeck by bounded nonlinear least squares "
    "with standard errors from (J^T J)^-1 s^2, or a neural net of 002 sec. 5. Metrics: NRMSE "
    "= ||F - F_model|| / ||F - mean F||, E = mean |F - F_model| (002 eq (11)).",
)


# ======================================================================================
# methods: arx, frf, slider (input/output channels of any plant's measured-data file)
# ======================================================================================


def _refuse_clamped(params: Mapping[str, float], se: Mapping[str, float], units: Mapping[str, str],
                    model: str) -> None:
    """Raise when a friction level or coefficient (F_*, lower bound 0) ends at its bound.

    A value pinned at 0 is the bound, not an estimate: the data do not determine it (in one
    direction of an asymmetric fit, or overall), so no number is reported for it.
    """
    for k, v in params.items():
        if not k.startswith("F_") or v is None:
            continue
        s = se.get(k, float("nan"))
        scale = abs(s) if s is not None and math.isfinite(s) and s > 0 else 1.0
        if abs(v) <= 1e-9 * max(scale, 1.0):
            from identification.friction.data import UnidentifiableError

            raise UnidentifiableError(
                [k],
                f"{k} = {v:.3g} {units.get(k, '')} is clamped at its bound 0 (std error {s:.3g}): "
                f"the data do not determine it; model {model!r} is not supported by these data "
                "-- fit a model without it (e.g. --model coulomb)")


def _io_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--plant", required=True, help="plant of the measured-data file (hydro channels PLANT)")
    p.add_argument("--data", required=True, metavar="FILE", help="measured-data file")
    p.add_argument("--input", required=True, metavar="CH", help="input channel, e.g. u")
    p.add_argument("--output", required=True, metavar="CH", help="output channel, e.g. x")


def _load_io(args: argparse.Namespace):
    import numpy as np

    from hydro_envs.data.measured import load_measured

    data = load_measured(args.data, plant=args.plant, required=(args.input, args.output),
                         **_record_kwargs(args))
    data = _contiguous(data, args)
    u = np.asarray(data[args.input], dtype=float)
    y = np.asarray(data[args.output], dtype=float)
    return data, u, y


def _arx_arguments(p: argparse.ArgumentParser) -> None:
    _io_arguments(p)
    p.add_argument("--orders", nargs=3, type=int, metavar=("NA", "NB", "NK"),
                   help="fixed ARX orders; without it the orders are selected")
    p.add_argument("--criterion", default="bic", choices=("aic", "bic", "fpe"),
                   help="order-selection criterion (default bic)")
    p.add_argument("--max-order", type=int, default=5, help="largest na and nb tried (default 5)")
    p.add_argument("--max-delay", type=int, default=3, help="largest nk tried (default 3)")
    p.add_argument("--estimator", default="ls", choices=("ls", "iv"),
                   help="least squares or instrumental variables (open-loop output noise)")


def _arx_run(args: argparse.Namespace) -> dict[str, Any]:
    from identification.arx import fit_arx, select_arx_order
    from identification.quality import Progress

    data, u, y = _load_io(args)
    u = u - u.mean()  # ARX has no constant term: fit deviations from the mean
    y = y - y.mean()
    dt = data.sample_time
    n_est = int(0.7 * y.size)  # the last 30 % are held out for the free-run fit
    if args.orders:
        model = fit_arx(y[:n_est], u[:n_est], *args.orders, dt=dt, method=args.estimator)
        notes = []
    else:
        prog = Progress("arx order selection", unit="candidate orders")
        sel = select_arx_order(y[:n_est], u[:n_est], range(1, args.max_order + 1),
                               range(1, args.max_order + 1), range(0, args.max_delay + 1), dt,
                               criterion=args.criterion, method=args.estimator, progress=prog)
        prog.close()
        model = sel.best
        notes = [f"orders selected by {args.criterion}: margin over runner-up {sel.margin:.3g}"]
    res = model.to_json_dict(validation=model.validate(y[n_est:], u[n_est:]))
    res.update({"plant": args.plant, "data": str(args.data), "model": f"ARX{(model.na, model.nb, model.nk)}",
                "notes": notes})
    res["metrics"].update({f"heldout_{k}": v for k, v in res.pop("validation").items()})
    return res


def _frf_arguments(p: argparse.ArgumentParser) -> None:
    _io_arguments(p)
    p.add_argument("--fit", default="zoh", choices=("zoh", "magnitude", "continuous"),
                   help="mass-spring-damper fit of the H1 estimate: the sampled (ZOH) model "
                   "(default), magnitude only, or continuous (biased for sampled data)")
    p.add_argument("--derivative", type=int, default=0, choices=(0, 1, 2),
                   help="output is position (0), velocity (1) or acceleration (2)")


def _frf_run(args: argparse.Namespace) -> dict[str, Any]:
    from identification.frf import identify_msd_from_time_series
    from identification.quality import Progress

    data, u, y = _load_io(args)
    prog = Progress("frf fit", unit="model evaluations (at most)")
    fit, est = identify_msd_from_time_series(u, y, 1.0 / data.sample_time, method=args.fit,
                                             derivative=args.derivative, progress=prog)
    prog.close()
    res = fit.to_json_dict()
    res.update({"plant": args.plant, "data": str(args.data), "model": f"mass-spring-damper ({args.fit})"})
    return res


def _slider_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", required=True, metavar="FILE", help="measured-data file of plant slider (f, x)")
    p.add_argument("--plant", default="slider", choices=("slider",), help="slider (default)")
    p.add_argument("--stribeck", default="auto", choices=("auto", "fit", "fixed", "none"),
                   help="Stribeck dip: 'auto' (default; kept only when the data identify it and it "
                        "lowers the BIC), 'fit', 'fixed' or 'none'")
    p.add_argument("--asymmetric", action="store_true",
                   help="Coulomb and viscous friction per direction of motion (printed with standard "
                        "errors); needs --stribeck auto or none")


def _slider_run(args: argparse.Namespace) -> dict[str, Any]:
    from hydro_envs.data.measured import load_measured
    from identification.slider import identify_slider_measured

    data = _contiguous(load_measured(args.data, plant="slider", required=("f", "x"), **_record_kwargs(args)),
                       args)
    ident = identify_slider_measured(data, stribeck=args.stribeck, asymmetric=bool(args.asymmetric))
    res = ident.to_json_dict()
    if ident.direction_params is not None:
        res["direction_parameters"] = dict(ident.direction_params)
        res["direction_std_errors"] = dict(ident.direction_std_errors or {})
    res.update({"plant": "slider", "data": str(args.data), "model": "mass + Stribeck friction + offset"})
    return res


_GATE_NOTE = ("Fit-quality gate (identification.quality): a fit below 50 % or a parameter whose relative "
              "standard error exceeds 100 % prints a 'warning: poor fit' line and sets quality.ok = false "
              "in the JSON.")
register_method("arx", "ARX model with order/delay selection and held-out free-run fit",
                _arx_arguments, _arx_run,
                description="Fit an ARX model on the first 70 % of the record (orders selected by an "
                "information criterion unless --orders) and report the free-run fit on the last 30 %. "
                + _GATE_NOTE)
register_method("frf", "H1 frequency response and a mass-spring-damper fit",
                _frf_arguments, _frf_run,
                description="H1 frequency-response estimate (Welch) of input -> output and a "
                "mass-spring-damper fit to its points of coherence >= 0.9. " + _GATE_NOTE
                + " An FRF fit on fewer than 10 such points is flagged too.")
register_method("slider", "inverse-dynamics least squares of a slider (mass, friction, offset)",
                _slider_arguments, _slider_run)


# ======================================================================================
# method: greybox (nonlinear least squares of a plant's physical parameters)
# ======================================================================================


def _greybox_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--plant", required=True, metavar="PLANT",
                   help="a registry plant whose model declares its sensor outputs and its state at a "
                   "record's first sample (identification.greybox.supported_plants())")
    p.add_argument("--data", required=True, metavar="FILE", help="measured-data file (uniform sampling)")
    p.add_argument("--fit", required=True, metavar="NAME[,NAME...]",
                   help="parameters to fit (field names of the plant's parameter dataclass)")
    p.add_argument("--preset", default=None,
                   help="start from a preset of the plant's parameter class (where it has presets)")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="start from a parameter file with units: a preset YAML (plant:, parameters: NAME: {value, "
                   "unit, source}; it must list the rig's geometry unless --nominal-geometry) or the plant's data "
                   "sheet where it reads one (e.g. bore: 63 mm, rod: 36 mm, ...)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a start/fixed parameter value (repeatable)")
    p.add_argument("--outputs", default=None, metavar="CH[,CH...]",
                   help="output channels to fit (default: every measured one of the plant)")
    p.add_argument("--nominal-geometry", action="store_true",
                   help="take the rig's dimensions (areas, stroke, volumes) not given by --set, --preset "
                   "or the file's metadata from the seed rig (printed); without it they are required")


def _metadata_value(where: str, key: str, text: Any, unit: str) -> float:
    """A number of a record's metadata, ``V`` or ``V [unit]`` (as ``hydro simulate`` writes the
    parameters), in ``unit``; else a one-line error naming the key, the value and the unit."""
    from hydro_envs.data.units import UnitError, conversion

    raw, got = str(text).strip(), unit
    if raw.endswith("]") and "[" in raw:
        raw, got = raw[:-1].split("[", 1)
        got = got.strip()
    try:
        value = float(raw)
    except ValueError:
        raise CliError(f"{where}: metadata {key} = {text!r}; allowed a number in {unit}") from None
    if not math.isfinite(value):
        raise CliError(f"{where}: metadata {key} = {text!r}; allowed a finite number in {unit}")
    if got == unit:
        return value
    try:  # another unit of the same dimension (mm, cm^2): the record reader's own table
        return float(conversion(got, unit, column=f"metadata {key}").apply(value))
    except UnitError as exc:
        raise CliError(f"{where}: {exc}") from None


def _greybox_geometry(args: argparse.Namespace, base: Any, over: dict[str, float], fit: list[str],
                      data: Any) -> Any:
    """``base`` with the record's geometry metadata applied (a field name of the plant's geometry
    in the file's ``#`` metadata, unless ``--set`` gives it), after checking that every geometry
    field is given: by ``--set``, a ``--preset``, the metadata, ``--fit`` -- or ``--nominal-geometry``."""
    from hydro_envs.params import geometry_text, missing_geometry_error

    cls = type(base)
    units = {d["name"]: d.get("unit", "") for d in cls.describe()}
    meta = {}
    for name in cls.geometry:
        key = next((k for k in (name, f"param.{name}") if k in data.metadata), None)
        if key is None or name in over:
            continue
        meta[name] = _metadata_value(str(args.data), key, data.metadata[key], units[name])
    if meta:
        base = cls.from_mapping(meta, base=base)
        print(f"hydro identify: note: geometry from the file's metadata: {geometry_text(base, list(meta))}",
              file=sys.stderr)
    given = [*over, *meta, *fit, *(cls.geometry if args.preset or args.params or args.nominal_geometry else ())]
    err = missing_geometry_error(cls, given, str(args.data), "give each with --set NAME=VALUE (SI units), "
                                 "a --preset or the file's metadata", "--nominal-geometry")
    if err is not None:
        raise err
    if args.nominal_geometry:
        rest = [n for n in cls.geometry if n not in over and n not in meta]
        if rest:
            print(f"hydro identify: note: --nominal-geometry: the seed rig's {geometry_text(base, rest)}",
                  file=sys.stderr)
    return base


def _greybox_run(args: argparse.Namespace) -> dict[str, Any]:
    from hydro_envs.data.measured import load_measured
    from identification import greybox as gb

    setup = gb.plant_setup(args.plant)
    cls = setup["params"]
    if args.preset and not setup["presets"]:
        raise ValueError(f"--preset: plant {args.plant!r} has no presets")
    if args.preset and args.params:
        raise CliError(f"give --preset ({args.preset}) or --params ({args.params}), not both")
    if args.params:
        from identification.params_file import load_params_file

        base = load_params_file(args.plant, args.params, require=() if args.nominal_geometry else cls.geometry)
    else:
        base = cls.preset(args.preset) if args.preset else cls()
    over = {}
    for item in args.set:
        if "=" not in item:
            raise ValueError(f"--set {item!r}: expected NAME=VALUE")
        k, v = item.split("=", 1)
        over[k.strip()] = float(v)
    if over:
        base = cls.from_mapping(over, base=base)
    names = [n.strip() for n in args.fit.split(",") if n.strip()]
    chans = setup["channels"]
    default_out = setup["fit_outputs"]
    from hydro_envs import registry

    data = _contiguous(load_measured(args.data, plant=args.plant, required=tuple(registry.get(args.plant).inputs),
                                     **_record_kwargs(args)), args)
    base = _greybox_geometry(args, base, over, names, data)
    outs = ([c.strip() for c in args.outputs.split(",")] if args.outputs
            else [c for c in default_out if c in data])
    if not outs:
        raise ValueError(f"the file has none of the output channels {list(default_out)}")
    exp = gb.experiment_from_measured(data, args.plant, base, outs)
    from identification.quality import Progress

    prog = Progress("greybox fit", unit="simulations (at most)")
    res = gb.fit_greybox(base, names, [exp], [chans[c] for c in outs], progress=prog)
    prog.close()
    d = res.to_json_dict()
    d.update({"plant": args.plant, "data": str(args.data), "model": type(base).__name__
              + (f" (preset {args.preset})" if args.preset else "")
              + (f" (parameters {args.params})" if args.params else "")})
    return d


register_method(
    "greybox",
    "nonlinear least squares of a plant's physical parameters (batched simulation)",
    _greybox_arguments,
    _greybox_run,
    description="Fit physical parameters of the compiled plant model to a measured record by "
    "bounded nonlinear least squares (trf) on the free-run simulation error, residuals "
    "normalised per channel (noise levels re-estimated after a first fit); the finite-"
    "difference Jacobian simulates all perturbed parameter sets in one batched kernel call. "
    "Prints values, standard errors (s^2 (J^T J)^-1), 95 % intervals, the identifiability "
    "report (scaled condition number, correlated pairs) and NRMSE per channel. " + _GATE_NOTE,
)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
