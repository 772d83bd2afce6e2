"""The ``hydro`` command line.

Subcommands::

    hydro channels [PLANT] [--json]           channels (name, unit, meaning) of a plant
    hydro simulate ENV_ID --steps N --out F   run an env, record its sensor channels
    hydro validate [--json]                   reproduce published figures, pass/fail

plus the subcommands other installed packages register under the ``hydro_envs.commands``
entry points (``identify`` and ``diagnose`` from :mod:`identification`, ``benchmark`` and
``demo`` from :mod:`agents`). Heavy imports (numpy, gymnasium, numba, the envs) happen inside
the subcommands so that ``hydro --help`` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

__all__ = ["main", "build_parser"]

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
    parser = argparse.ArgumentParser(
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
        help="run an environment and record its channels to a measured-data file",
        description="Make ENV_ID, reset it with --seed, run --steps steps with zero or "
        "random actions and write t plus the plant's sensor channels (one row per "
        "step, including the state after reset) to --out (CSV, or parquet by suffix). "
        "If the episode ends early the run stops there (no auto-reset) and this is "
        "reported.",
    )
    p.add_argument("env_id", metavar="ENV_ID", help="e.g. hydro_envs/ServoCylinderPosition-v0")
    p.add_argument("--steps", type=_positive_int, required=True, metavar="N",
                   help="number of env steps (rows written = N + 1)")
    p.add_argument("--policy", choices=("zero", "random"), default="zero",
                   help="zero actions, or action_space.sample() (default: zero)")
    p.add_argument("--seed", type=int, default=0, metavar="S",
                   help="seed for reset() and the action space (default: 0)")
    p.add_argument("--out", required=True, metavar="FILE",
                   help="output file (.csv, or .parquet with pyarrow)")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser(
        "validate",
        help="reproduce published results and compare within tolerance",
        description="Compute every validation row (independent: a printed or measured number "
        "reproduced by another route; consistency: the model against its own linearisation or "
        "inputs) and print them grouped by kind. Exit code 0 if every row passed, 1 otherwise.",
    )
    p.add_argument("--json", action="store_true",
                   help='print one JSON object {"rows": [...], "passed": bool, "independent": n}; '
                   "passed is the AND of every row")
    p.add_argument("--markdown", metavar="FILE",
                   help="write the documentation page (every row with its kind and source) to FILE")
    p.set_defaults(func=_cmd_validate)

    _add_plugin_commands(sub)
    return parser


#: entry-point group of the subcommands other packages add (identify, diagnose, benchmark, demo):
#: each entry point is a function ``add(subparsers)`` that adds its parser and sets ``func``
COMMAND_GROUP = "hydro_envs.commands"


def _add_plugin_commands(sub: Any) -> None:
    """Subcommands of the installed packages, found through their entry points."""
    from importlib.metadata import entry_points

    for ep in sorted(entry_points(group=COMMAND_GROUP), key=lambda e: e.name):
        try:
            add = ep.load()
        except ModuleNotFoundError as e:  # its package's optional dependencies are missing
            sub.add_parser(ep.name, help=f"(unavailable: {e})")
            continue
        add(sub)


def _positive_int(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {n}")
    return n


def _err(msg: str) -> None:
    print(f"hydro: error: {msg}", file=sys.stderr)


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
        _err(str(e))
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


def _zero_action(space: Any) -> Any:
    import numpy as np
    from gymnasium import spaces

    if isinstance(space, spaces.Box):
        return np.clip(np.zeros(space.shape, dtype=space.dtype), space.low, space.high)
    if isinstance(space, spaces.Discrete):
        return space.start
    if isinstance(space, spaces.MultiDiscrete):
        return np.asarray(space.start, dtype=space.dtype).copy()
    if isinstance(space, spaces.MultiBinary):
        return np.zeros(space.shape, dtype=space.dtype)
    raise TypeError(f"no zero action defined for action space {space}")


def _cmd_simulate(args: argparse.Namespace) -> int:
    import gymnasium as gym
    import numpy as np

    import hydro_envs  # noqa: F401  (registers the environments)
    from hydro_envs.data.measured import MeasuredDataError, write_measured

    try:
        env = gym.make(args.env_id)
    except gym.error.Error as e:  # NameNotFound, NamespaceNotFound, VersionNotFound, ...
        ours = sorted(k for k in gym.registry if k.startswith("hydro_envs/"))
        _err(f"cannot make {args.env_id!r}: {e}; registered hydro_envs envs: "
             + (", ".join(ours) or "(none)"))
        return EXIT_USAGE
    try:
        base = env.unwrapped
        for attr in ("dt", "plant_name", "channel_values"):
            if not hasattr(base, attr):
                _err(f"{args.env_id}: env has no attribute {attr!r}; `hydro simulate` needs "
                     "dt, plant_name and channel_values()")
                return EXIT_FAIL
        dt = float(base.dt)
        env.reset(seed=args.seed)
        env.action_space.seed(args.seed)

        names: list[str] | None = None
        cols: dict[str, list[float]] = {}

        def record(k: int) -> None:
            nonlocal names
            vals = base.channel_values()
            if names is None:
                names = list(vals)
                for n in names:
                    cols[n] = []
            elif list(vals) != names:
                raise RuntimeError(
                    f"channel_values() changed its channels at step {k}: "
                    f"{list(vals)} vs {names}"
                )
            for n in names:
                cols[n].append(float(vals[n]))

        record(0)
        steps_done = 0
        ended = None
        for k in range(1, args.steps + 1):
            if args.policy == "zero":
                action = _zero_action(env.action_space)
            else:
                action = env.action_space.sample()
            _, _, terminated, truncated, _ = env.step(action)
            record(k)
            steps_done = k
            if terminated or truncated:
                if k < args.steps:
                    ended = "terminated" if terminated else "truncated"
                break
        t = np.arange(steps_done + 1, dtype=np.float64) * dt
        path = write_measured(
            args.out,
            t,
            {n: np.asarray(v) for n, v in cols.items()},
            plant=str(base.plant_name),
            metadata={
                "env_id": args.env_id,
                "seed": args.seed,
                "policy": args.policy,
                "steps": steps_done,
                "dt": repr(dt),
                "source": "hydro simulate",
            },
        )
    except (MeasuredDataError, OSError) as e:
        _err(str(e))
        return EXIT_FAIL
    finally:
        env.close()
    rows = steps_done + 1
    print(f"wrote {rows} rows ({steps_done} steps, {steps_done * dt:.6g} s) to {path}")
    if ended is not None:
        print(
            f"hydro: note: episode {ended} after {steps_done} of {args.steps} steps; "
            "stopped there (no auto-reset)",
            file=sys.stderr,
        )
    return EXIT_OK


# --- validate --------------------------------------------------------------------------


def _cmd_validate(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from hydro_envs.jsonutil import to_jsonable
    from hydro_envs.validation import format_markdown, format_table, run_validation

    rows = list(run_validation())
    all_ok = bool(rows) and all(r.passed for r in rows)
    if args.markdown:
        out = Path(args.markdown)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(format_markdown(rows) + "\n", encoding="utf-8")
        print(f"wrote {out} ({len(rows)} rows)", file=sys.stderr)
    if args.json:
        payload = {"rows": [to_jsonable(r.as_dict()) for r in rows], "passed": all_ok,
                   "independent": sum(r.kind == "independent" for r in rows)}
        print(json.dumps(payload, allow_nan=False))
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
    return int(args.func(args))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
