"""The ``hydro`` command line.

Subcommands::

    hydro channels [PLANT] [--json]           channels (name, unit, meaning) of a plant
    hydro simulate ENV_ID --steps N --out F   run an env, record its sensor channels
    hydro validate [--json]                   reproduce published figures, pass/fail
    hydro compile [--only NAME,...]           fill numba's disk cache (envs, diagnosis)

plus the subcommands other installed packages register under the ``hydro_envs.commands``
entry points (``identify`` and ``diagnose`` from :mod:`identification`, ``benchmark`` and
``demo`` from :mod:`agents`). Heavy imports (numpy, gymnasium, numba, the envs) happen inside
the subcommands so that ``hydro --help`` stays fast.

Every subcommand follows one error convention (:mod:`hydro_envs.cli_errors`): a one-line
``hydro <command>: error: ...`` on stderr, never a traceback; exit 0 success, 1 a failed check,
2 bad input or usage.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

__all__ = ["main", "build_parser", "warmups"]

EXIT_OK = 0
EXIT_FAIL = 1
EXIT_USAGE = 2

_DESCRIPTION = """\
hydro-envs: Gymnasium environments for friction-aware control of fluid-power actuators
(servo-hydraulic cylinders and related plants), with the measured-data format and the
identification tools that calibrate them.
"""

_EPILOG = """\
examples:
  hydro channels                  (the plants)
  hydro channels PLANT --json
  hydro simulate hydro_envs/ServoCylinderPosition-v0 --steps 1000 --policy random \\
        --seed 0 --out run.csv
  hydro validate --json
"""


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("hydro-envs")
    except Exception:  # not installed (e.g. run from a source tree)
        return "unknown (not installed)"


def build_parser() -> argparse.ArgumentParser:
    from hydro_envs.cli_errors import Parser

    parser = Parser(
        prog="hydro",
        description=_DESCRIPTION,
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"hydro-envs {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")

    p = sub.add_parser(
        "channels",
        help="list a plant's measured channels (name, unit, meaning)",
        description="Print the channels of PLANT as stored in measured-data files "
        "(time 't' first), its inputs, states and envs. Without PLANT, list the plants.",
    )
    p.add_argument("plant", nargs="?", metavar="PLANT", help="plant name (`hydro channels` lists them)")
    p.add_argument("--json", action="store_true", help="print the plant (or every plant) as one JSON object")
    p.set_defaults(func=_cmd_channels)

    p = sub.add_parser(
        "simulate",
        help="run an environment's plant under an input signal and record its channels",
        description="Make ENV_ID, reset it with --seed and drive its plant for --steps control "
        "periods with the --policy input signal (in the normalised action range), then write t, "
        "the inputs and the sensor channels to --out (CSV, or parquet by suffix). Sample-and-hold "
        "convention: row k holds the sensors sampled at t_k and the input applied over "
        "[t_k, t_k+1); the last row repeats the last input. Runs are not capped at one episode. "
        "The header records the env, seed, policy and every parameter value used "
        "('# param.NAME: VALUE [UNIT]').",
    )
    p.add_argument("env_id", metavar="ENV_ID", help="e.g. hydro_envs/ServoCylinderPosition-v0")
    p.add_argument("--steps", type=_positive_int, required=True, metavar="N",
                   help="number of control periods (rows written = N + 1)")
    p.add_argument("--policy", choices=POLICIES, default="zero",
                   help="input signal: zero, random (uniform, held one period), prbs, multisine or "
                   "chirp (log sweep f0 -> f1) (default: zero)")
    p.add_argument("--amplitude", type=_fraction, default=0.5, metavar="A",
                   help="peak of prbs/multisine/chirp/random as a fraction of the action range (default 0.5)")
    p.add_argument("--f0", type=_positive_float, default=None, metavar="HZ",
                   help="lowest frequency of multisine/chirp [Hz] (default: 2 cycles in the record)")
    p.add_argument("--f1", type=_positive_float, default=None, metavar="HZ",
                   help="highest frequency of multisine/chirp [Hz] (default: a tenth of the sample rate)")
    p.add_argument("--hold", type=_positive_int, default=20, metavar="K",
                   help="prbs clock: control periods per bit (default 20)")
    p.add_argument("--nominal", action="store_true",
                   help="nominal parameters (no domain randomisation)")
    p.add_argument("--params", metavar="FILE", default=None,
                   help="parameter file with units for an env that reads one (gym.make(ENV_ID, params=FILE)): "
                   "its rig is the nominal set, randomised around unless --nominal")
    p.add_argument("--seed", type=int, default=0, metavar="S",
                   help="seed for reset() and the input signal (default: 0)")
    p.add_argument("--out", required=True, metavar="FILE",
                   help="output file (.csv, or .parquet / .pq with pyarrow); an existing file is replaced "
                   "only with --force")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "validate",
        help="reproduce published results and compare within tolerance",
        description="Compute every validation row (independent: a printed or measured number "
        "reproduced by simulating the plant through another route; table: arithmetic on the seeds' "
        "tables; consistency: the model against its own linearisation, inputs or calibration) and "
        "print them grouped by kind. Exit code 0 if every row passed, 1 otherwise.",
    )
    p.add_argument("--json", action="store_true",
                   help='print one JSON object {"rows": [...] grouped by kind, "kinds": {...}, "passed": '
                   'bool, "independent": n}; passed is the AND of every row')
    p.add_argument("--markdown", metavar="FILE",
                   help="write the documentation page (every row with its kind and source) to FILE")
    p.set_defaults(func=_cmd_validate)

    p = sub.add_parser(
        "compile",
        help="compile the numba kernels into the on-disk cache (run after install or an edit)",
        description="Run every env id once (single and two-copy vector env) and every warm-up the "
        "installed packages register (diagnosis: one short diagnosis per plant), so that their "
        "compiled kernels are stored in numba's on-disk cache and later processes load them "
        "instead of compiling. The cache is dropped when a source file changes: run again after "
        "an edit. `make install` runs it.",
    )
    p.add_argument("--only", metavar="NAME,...",
                   help="comma-separated warm-ups to run (default: all; `envs` and those registered)")
    p.set_defaults(func=_cmd_compile)

    _add_plugin_commands(sub)
    return parser


#: entry-point group of the subcommands other packages add (identify, diagnose, benchmark, demo):
#: each entry point is a function ``add(subparsers)`` that adds its parser and sets ``func``
COMMAND_GROUP = "hydro_envs.commands"


def _entry_points(group: str) -> list[tuple[str, Any]]:
    """(name, loaded object) of the installed packages' entry points in ``group``, by name; the
    object is the ``ModuleNotFoundError`` where the package's optional dependencies are missing."""
    from importlib.metadata import entry_points

    out: list[tuple[str, Any]] = []
    for ep in sorted(entry_points(group=group), key=lambda e: e.name):
        try:
            out.append((ep.name, ep.load()))
        except ModuleNotFoundError as e:
            out.append((ep.name, e))
    return out


def _add_plugin_commands(sub: Any) -> None:
    """Subcommands of the installed packages, found through their entry points."""
    for name, add in _entry_points(COMMAND_GROUP):
        if isinstance(add, ModuleNotFoundError):
            sub.add_parser(name, help=f"(unavailable: {add})")
        else:
            add(sub)


def warmups() -> dict[str, Any]:
    """The warm-ups ``hydro compile`` runs, by name: ``envs``
    (:func:`hydro_envs.warmup.compile_env_kernels`) first, then those the installed packages
    register under :data:`hydro_envs.warmup.WARMUP_GROUP` (missing optional dependencies: left out)."""
    from hydro_envs.warmup import WARMUP_GROUP, compile_env_kernels

    out: dict[str, Any] = {"envs": compile_env_kernels}
    out.update((n, f) for n, f in _entry_points(WARMUP_GROUP) if not isinstance(f, ModuleNotFoundError))
    return out


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {n}")
    return n


def _err(msg: str, command: str = "hydro") -> None:
    print(f"{command}: error: {msg}", file=sys.stderr)


def _table(rows: Sequence[Sequence[str]], header: Sequence[str]) -> str:
    widths = [len(h) for h in header]
    for r in rows:
        widths = [max(w, len(c)) for w, c in zip(widths, r)]
    fmt = lambda r: "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip()  # noqa: E731
    out = [fmt(header), fmt(["-" * w for w in widths])]
    out += [fmt(r) for r in rows]
    return "\n".join(out)


# --- channels --------------------------------------------------------------------------


def _cmd_channels(args: argparse.Namespace) -> int:
    import json

    from hydro_envs import registry
    from hydro_envs.spec import TIME_CHANNEL

    if args.plant is None:
        if args.json:
            print(json.dumps({"plants": [s.as_dict() for s in registry.specs()]}))
        else:
            rows = [[s.name, ", ".join(c.name for c in s.channels), s.title] for s in registry.specs()]
            print(_table(rows, ["plant", "channels", "what it is"]))
        return EXIT_OK
    try:
        spec = registry.get(args.plant)
    except registry.UnknownPlantError as e:
        _err(str(e), "hydro channels")
        return EXIT_USAGE
    if args.json:
        print(json.dumps(spec.as_dict()))
        return EXIT_OK
    rows = [[c.name, f"[{c.unit}]", c.meaning] for c in (TIME_CHANNEL, *spec.channels)]
    print(f"plant {spec.name}: {spec.title} ({spec.source})")
    print(_table(rows, ["channel", "unit", "meaning"]))
    if spec.inputs:
        print(f"inputs: {', '.join(spec.inputs)}")
    if spec.envs:
        print(f"envs: {', '.join(spec.env_ids)}")
    return EXIT_OK


# --- simulate --------------------------------------------------------------------------


POLICIES = ("zero", "random", "prbs", "multisine", "chirp")


def _fraction(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number; allowed (0, 1]") from None
    if not (0.0 < v <= 1.0):
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got {text}")
    return v


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number; allowed a finite number > 0") from None
    if not (v > 0.0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return v


#: suffixes ``hydro simulate --out`` writes (:func:`hydro_envs.data.write_measured`)
SIMULATE_SUFFIXES = (".csv", ".parquet", ".pq")


def simulation_actions(policy: str, n: int, dim: int, dt: float, amplitude: float = 0.5,
                       f0: float | None = None, f1: float | None = None, hold: int = 20,
                       seed: int = 0) -> Any:
    """``(n, dim)`` normalised actions in [-1, 1] of one of :data:`POLICIES` (see ``hydro
    simulate --help``); every action dimension gets its own draw."""
    import numpy as np

    from hydro_envs import excitation

    rng = np.random.default_rng(seed)
    if policy == "zero":
        return np.zeros((n, dim))
    if policy == "random":
        return rng.uniform(-amplitude, amplitude, (n, dim))
    if policy == "prbs":
        cols = [excitation.prbs(n * dt, dt, clock_period=hold * dt, amplitude=amplitude,
                                seed=int(rng.integers(1, 2**31)))[1] for _ in range(dim)]
        return np.stack([np.resize(c, n) for c in cols], axis=1)
    nyquist = 0.5 / dt
    lo = f0 if f0 is not None else 2.0 / (n * dt)
    hi = f1 if f1 is not None else 0.1 / dt
    if not (0.0 < lo < hi < nyquist):
        raise ValueError(f"--f0 = {lo:g} Hz and --f1 = {hi:g} Hz: need 0 < f0 < f1 < Nyquist {nyquist:g} Hz")
    if policy == "multisine":
        return np.stack([excitation.multisine(n, dt, lo, hi, amplitude=amplitude, rng=rng) for _ in range(dim)],
                        axis=1)
    if policy == "chirp":
        u = excitation.log_sine_sweep(lo, hi, n * dt, dt, amplitude=amplitude)[1]
        return np.repeat(np.resize(u, n)[:, None], dim, axis=1)
    raise ValueError(f"policy {policy!r}; allowed: {', '.join(POLICIES)}")


def _cmd_simulate(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import numpy as np

    import hydro_envs  # noqa: F401  (registers the environments)
    from hydro_envs import registry
    from hydro_envs.data.measured import write_measured
    from hydro_envs.outputs import check_output_file

    check_output_file(args.out, force=bool(getattr(args, "force", False)), suffixes=SIMULATE_SUFFIXES)
    make_kwargs = {"randomize": not args.nominal}
    if args.params is not None:
        make_kwargs["params"] = args.params
    try:
        env = gym.make(args.env_id, **make_kwargs)
    except (TypeError, ValueError) as e:  # a parameter file the env refuses, or one it cannot read
        _err(f"--params {args.params}: {e}" if args.params is not None else str(e), "hydro simulate")
        return EXIT_USAGE
    except gym.error.Error as e:  # NameNotFound, NamespaceNotFound, VersionNotFound, ...
        ours = sorted(k for k in gym.registry if k.startswith("hydro_envs/"))
        _err(f"cannot make {args.env_id!r}: {e}; registered hydro_envs envs: "
             + (", ".join(ours) or "(none)"), "hydro simulate")
        return EXIT_USAGE
    base = env.unwrapped  # stepped directly: a record is not capped at one episode
    steps_done, ended = 0, None
    try:
        for attr in ("dt", "plant_name", "channel_values", "params"):
            if not hasattr(base, attr):
                _err(f"{args.env_id}: env has no attribute {attr!r}; `hydro simulate` needs "
                     "dt, plant_name, params and channel_values()", "hydro simulate")
                return EXIT_FAIL
        dt = float(base.dt)
        spec = registry.get(str(base.plant_name))
        env.reset(seed=args.seed)
        actions = simulation_actions(args.policy, args.steps, int(np.prod(env.action_space.shape)), dt,
                                     args.amplitude, args.f0, args.f1, args.hold, args.seed)
        first = base.channel_values()
        names = list(first)
        rows = [dict(first)]
        for k in range(args.steps):
            a = actions[k].reshape(env.action_space.shape).astype(env.action_space.dtype)
            _, _, terminated, _, _ = base.step(a)
            now = base.channel_values()
            for name in spec.inputs:  # the input applied over [t_k, t_k+1) belongs to row k
                if name in now:
                    rows[k][name] = now[name]
            rows.append(dict(now))
            steps_done = k + 1
            if terminated:
                ended = "terminated"
                break
        t = np.arange(steps_done + 1, dtype=np.float64) * dt
        params = base.params
        units = {d["name"]: d.get("unit", "") for d in type(params).describe()}
        meta = {
            "env_id": args.env_id,
            "seed": args.seed,
            "policy": args.policy,
            "amplitude": args.amplitude,
            "randomized": not args.nominal,
            **({"params_file": str(args.params)} if args.params is not None else {}),
            "steps": steps_done,
            "dt": repr(dt),
            "convention": "row k: sensors at t_k, input held over [t_k, t_k+1); last row repeats the input",
            "source": "hydro simulate",
        }
        for name, value in params.as_dict().items():
            meta[f"param.{name}"] = f"{value!r} [{units.get(name, '')}]"
        path = write_measured(args.out, t, {n: np.array([r[n] for r in rows]) for n in names},
                              plant=spec.name, metadata=meta)
    except (ValueError, OSError, ArithmeticError) as e:  # the plant's own values, a full disk, a non-finite state
        _err(str(e), "hydro simulate")
        return EXIT_FAIL
    finally:
        env.close()
    print(f"wrote {steps_done + 1} rows ({steps_done} steps, {steps_done * dt:.6g} s) to {path}")
    if ended is not None:
        print(f"hydro: note: the plant terminated after {steps_done} of {args.steps} steps; stopped there",
              file=sys.stderr)
    return EXIT_OK


# --- compile ---------------------------------------------------------------------------


def _cmd_compile(args: argparse.Namespace) -> int:
    import time

    available = warmups()
    names = list(available) if not args.only else [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = [n for n in names if n not in available]
    if unknown:
        _err(f"--only: unknown warm-up(s) {unknown}; available: {sorted(available)}", "hydro compile")
        return EXIT_USAGE
    t0 = time.perf_counter()
    for name in names:
        print(f"compiling: {name}", flush=True)
        available[name](say=lambda msg: print(f"  {msg}", flush=True))
    print(f"compiled in {time.perf_counter() - t0:.0f} s")
    return EXIT_OK


# --- validate --------------------------------------------------------------------------


def _cmd_validate(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from hydro_envs.jsonutil import to_jsonable
    from hydro_envs.validation import format_markdown, format_table, report_dict, run_validation, validation_notes

    rows = list(run_validation())
    all_ok = bool(rows) and all(r.passed for r in rows)
    if args.markdown:
        from hydro_envs.outputs import atomic_write

        out = atomic_write(Path(args.markdown), format_markdown(rows, validation_notes()) + "\n")
        print(f"wrote {out} ({len(rows)} rows)", file=sys.stderr)
    if args.json:
        print(json.dumps(to_jsonable(report_dict(rows)), allow_nan=False))
    elif not args.markdown:
        print(format_table(rows) if rows else "no validation checks were returned")
    return EXIT_OK if all_ok else EXIT_FAIL


# --- entry point -----------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``hydro`` command line; returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help, --version, usage errors
        code = e.code
        return code if isinstance(code, int) else (EXIT_OK if code is None else EXIT_USAGE)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return EXIT_USAGE
    from hydro_envs._numba_cache import ensure_fresh_cache
    from hydro_envs.cli_errors import guarded

    ensure_fresh_cache()  # before any kernel is compiled or loaded from the cache
    return guarded(f"hydro {args.command}", args.func, args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
