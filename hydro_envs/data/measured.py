"""Measured-data files: one format for recorded rig data and simulated runs.

File format (version 1)
=======================

CSV (any suffix except ``.parquet`` / ``.pq``), UTF-8 (a byte-order mark is accepted)::

    # plant: servo_cylinder
    # source: rig B, run 17
    # license: CC-BY-4.0
    # sample_rate: 1000
    # Free text lines (no "key:" prefix) are kept as metadata["comment"].
    t [s],u [V],x [m],p1 [Pa],p2 [Pa]
    0.0,0.5,0.1,5000000.0,4800000.0
    0.001,0.5,0.10002,5001000.0,4799000.0

1. Optional leading comment lines starting with ``#``, only before the header. A line
   ``# key: value`` (key = letters, digits, ``_ . -``, case-sensitive) is metadata; a key
   may appear once, except ``comment``, whose lines are joined with newlines. Other
   non-empty comment lines are free text and are appended to ``metadata["comment"]``.
   ``# plant: NAME`` names the plant whose channels the file holds (see
   :mod:`hydro_envs.data.channels`); ``source``, ``license``, ``sample_rate`` are
   customary. Blank lines before the header are ignored.
2. Exactly one header row, comma-separated. The first column is ``t`` (time in s); the
   others are channel names of the plant, each at most once, in any order. A header cell
   may carry its unit in square brackets, ``x [m]``: the registered unit, or one that
   converts to it (``x [mm]``, ``p1 [bar]``, ``t [ms]``; :mod:`hydro_envs.data.units`,
   case-sensitive: ``mPa`` is not ``MPa``), converted once on reading and noted in the
   metadata as ``unit.NAME``; an unknown unit or one of another dimension is refused. No
   unit: the registered one is assumed (readers say so). Writers write the registered units.
   Columns that are not channels of the plant are rejected (unless the reader passes
   ``allow_extra=True``).
3. Then one row per sample, same number of cells as the header, every cell a finite
   decimal number (``1``, ``-2.5``, ``3e-4``; no NaN, inf, empty cells or thousands
   separators). Time is strictly increasing. At least 2 rows. Blank lines are allowed only
   at the end of the file. Nothing is dropped or repaired on reading.
4. Values are in the header's units, SI as registered where none is given (pressures
   absolute in Pa, positions in m, valve commands in V). Writers use Python's shortest
   round-trip ``repr`` of each float, so a write/read cycle is bit-exact.
5. Every record read is checked against its plant's registry entry before it is returned
   (:mod:`hydro_envs.data.checks`: positions within the stroke, pressures in a plausible band,
   the sample time against ``# sample_rate:`` and the plant's dynamics, gaps, bounds on
   forces and velocities), whatever its format.

Parquet (suffix ``.parquet`` or ``.pq``, needs ``pyarrow``): the same column names, float64
(integers are accepted on reading), no nulls; the units are stored as JSON under the
schema-metadata key ``hydro_envs.units`` and the ``# key: value`` metadata (including
``plant``) as JSON under ``hydro_envs.metadata``. The same validation applies.

Other layouts (any delimiter, whitespace, MATLAB ``.mat``, a column map, units to convert)
are read by :mod:`hydro_envs.data.foreign`; units are converted by
:mod:`hydro_envs.data.units`; :mod:`hydro_envs.data.checks` holds the plausibility checks
against the plant's registry entry. The modules: :mod:`~hydro_envs.data.record` (the record),
:mod:`~hydro_envs.data.v1_read` / :mod:`~hydro_envs.data.v1_write` (format v1).

Every problem raises :class:`MeasuredDataError` (a ``ValueError``) whose message names the
file, the line (CSV, 1-based physical line) or data row (parquet, 1-based), the column, and
what is allowed.
"""


from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from hydro_envs.data.record import MeasuredData, MeasuredDataError
from hydro_envs.data.v1_common import PARQUET_SUFFIXES, _is_parquet, _plant_table, _resolve_plant
from hydro_envs.data.v1_read import _load_csv, _load_parquet
from hydro_envs.data.v1_write import write_measured

__all__ = [
    "MeasuredData",
    "MeasuredDataError",
    "load_measured",
    "write_measured",
    "PARQUET_SUFFIXES",
    "MAT_SUFFIXES",
]

MAT_SUFFIXES = (".mat",)


def load_measured(
    path: str | os.PathLike[str],
    plant: str | None = None,
    required: Iterable[str] | None = None,
    *,
    allow_extra: bool = False,
    column_map: str | Mapping[str, Any] | os.PathLike[str] | None = None,
    units: str | Mapping[str, str] | None = None,
    delimiter: str | None = None,
    check: bool = True,
    allow_gaps: bool = False,
    stroke: float | None = None,
    max_jitter: float | None = None,
) -> MeasuredData:
    """Read, convert to SI and validate a record of ``plant``.

    A format-v1 file (CSV with a ``t`` header, or parquet; see the module docstring) is read
    strictly when neither ``column_map``, ``units`` nor ``delimiter`` is given. Otherwise, and
    always for ``.mat`` files, the file is read as a foreign record
    (:mod:`hydro_envs.data.foreign`): ``column_map`` is a string ``"t=time,x=qm[mm],f=gtau*vir"``,
    a mapping, or the path of a YAML sidecar; ``units`` a string ``"x=mm,p1=bar(g)"`` or a
    mapping; ``delimiter`` one of ``comma``, ``semicolon``, ``tab``, ``whitespace`` (sniffed by
    default). Units are converted once to the plant's SI units; foreign records need a unit for
    every channel.

    A sidecar is used only when named: a ``<file>.yaml`` lying beside the data is not read, and
    :attr:`MeasuredData.notes` says that it was not (pass it as ``column_map`` to use it).

    ``plant`` defaults to the file's ``# plant:`` metadata. ``required`` lists the channels
    that must be present (default: all the plant's channels). The plausibility checks of
    :mod:`hydro_envs.data.checks` run on every record, whatever its format (``check=False``
    skips them: for tests of the file format itself, never before a fit); ``allow_gaps`` turns
    gaps into :attr:`MeasuredData.segments` instead of an error; ``max_jitter`` (relative,
    default ``1e-3``) is the accepted sample-time irregularity; ``stroke`` [m] overrides the
    plant's default stroke in the position check. Raises :class:`MeasuredDataError` on any
    violation.
    """
    p = Path(path)
    if not p.exists():
        raise MeasuredDataError(p, "file not found")
    if not p.is_file():
        raise MeasuredDataError(p, "not a regular file")
    sidecar = None
    notes: list[str] = []
    if isinstance(column_map, (str, os.PathLike)) and str(column_map).lower().endswith((".yaml", ".yml")):
        sidecar = Path(column_map)
        if not sidecar.is_file():
            raise MeasuredDataError(sidecar, "column-map sidecar not found")
        column_map = None
    elif column_map is None:
        for cand in (p.with_suffix(".yaml"), p.with_suffix(".yml")):
            if cand.is_file() and cand != p:
                notes.append(f"{cand} lies beside the data and was not used (a column map is used only when "
                             f"named: --map-file {cand.name})")
                break
    suffix = p.suffix.lower()
    foreign = suffix in MAT_SUFFIXES or column_map is not None or units is not None or sidecar is not None \
        or delimiter is not None
    try:
        if not foreign:
            data = _load_parquet(p, plant, required, allow_extra) if _is_parquet(p) else _load_csv(p, plant, required, allow_extra)
        else:
            if _is_parquet(p):
                raise MeasuredDataError(p, "a column map or units are not supported for parquet files; write them in format v1")
            data = _load_foreign(p, plant, required, allow_extra, column_map, units, delimiter, sidecar)
    except MeasuredDataError as exc:
        if notes and not foreign:
            raise MeasuredDataError(exc.path, f"{str(exc).removeprefix(f'{exc.path}: ')} (note: {notes[0]})",
                                    line=exc.line, column=exc.column) from None
        raise
    data.notes = tuple(notes)
    if check:
        from hydro_envs.data.checks import JITTER_TOL, check_record
        from hydro_envs.registry import get

        segs = check_record(data, get(data.plant), allow_gaps=allow_gaps, stroke=stroke, path=p,
                            max_jitter=JITTER_TOL if max_jitter is None else max_jitter)
        data.segments = segs if len(segs) > 1 else None
    return data


def _load_foreign(p, plant, required, allow_extra, column_map, units, delimiter, sidecar) -> MeasuredData:
    from hydro_envs.data import foreign as fx

    doc: dict[str, Any] = fx.load_sidecar(sidecar) if sidecar is not None else {}
    cmap = fx.parse_column_map(column_map if column_map is not None else doc.get("map"), p)
    umap = fx.parse_units(doc.get("units"), sidecar)
    umap.update(fx.parse_units(units, p))
    metadata: dict[str, str] = {}
    if p.suffix.lower() in MAT_SUFFIXES:
        cols, consts = fx.read_mat(p)
        hunits: dict[str, str | None] = {}
        if "t" in cmap and cmap["t"]["from"].strip() in cols:
            n = len(cols[cmap["t"]["from"].strip()])
            named = {f.strip() for e in cmap.values() for f in e["from"].split("*")}
            cols = {k: v for k, v in cols.items() if len(v) == n or k in named}
    else:
        names, hu, arr, metadata = fx.read_table(p, doc.get("columns"), delimiter or doc.get("delimiter"))
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise MeasuredDataError(p, f"duplicate column name(s) {', '.join(map(repr, dup))} in the file", column=dup[0])
        cols = {n: arr[:, j] for j, n in enumerate(names)}
        hunits = dict(zip(names, hu))
        consts = {}
    plant_name = _resolve_plant(p, plant, metadata.pop("plant", None))
    table = _plant_table(p, plant_name)
    metadata["source_file"] = p.name
    return fx.apply_map(p, plant_name, table, cols, hunits, consts, cmap, umap, required, allow_extra, metadata)
