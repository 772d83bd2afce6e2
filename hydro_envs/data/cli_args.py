"""Command-line options of the measured-record loader, shared by every command that reads one.

``add_record_arguments(parser)`` adds ``--map``, ``--units``, ``--delimiter``, ``--allow-gaps``,
``--max-jitter`` and ``--stroke``; ``record_kwargs(args)`` turns the parsed values into keyword
arguments of :func:`hydro_envs.data.load_measured`.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_record_arguments", "record_kwargs"]


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the loader's options to ``parser`` (an ``argparse`` parser or argument group)."""
    g = parser.add_argument_group("measured record")
    g.add_argument("--map", dest="record_map", default=None, metavar="MAP",
                   help="column map 'channel=expr[unit],...' (e.g. 't=time[ms],x=qm[m],f=gtau*vir[N]') "
                        "or a YAML sidecar file; default: the file's own columns (a FILE.yaml beside the data is used only "
                        "when named here or with --map-file; a note says it was not)")
    g.add_argument("--units", dest="record_units", default=None, metavar="UNITS",
                   help="units of the file's columns 'channel=unit,...' (e.g. 'x=mm,p1=bar(g)'); "
                        "converted once to SI on loading")
    g.add_argument("--delimiter", dest="record_delimiter", default=None,
                   choices=("comma", "semicolon", "tab", "whitespace"),
                   help="column separator of a text file (default: sniffed)")
    g.add_argument("--allow-gaps", dest="record_allow_gaps", action="store_true",
                   help="split a record with time gaps into segments instead of refusing it "
                        "(gaps are never interpolated)")
    g.add_argument("--max-jitter", dest="record_max_jitter", type=float, default=None, metavar="REL",
                   help="accepted relative sample-time irregularity (default 1e-3)")
    g.add_argument("--stroke", dest="record_stroke", type=float, default=None, metavar="M",
                   help="the rig's stroke [m] for the position check (default: the plant's stroke parameter, or the "
                        "registry's largest stroke of a bench without one, 1 m for the seal-friction bench)")


def record_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`hydro_envs.data.load_measured` from parsed options.

    The plausibility checks are always on for a command that fits or diagnoses a record.
    """
    return {
        "column_map": getattr(args, "record_map", None),
        "units": getattr(args, "record_units", None),
        "delimiter": getattr(args, "record_delimiter", None),
        "allow_gaps": bool(getattr(args, "record_allow_gaps", False)),
        "max_jitter": getattr(args, "record_max_jitter", None),
        "stroke": getattr(args, "record_stroke", None),
        "check": True,
    }
