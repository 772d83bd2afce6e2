"""Validation shared by the format-v1 reader and writer: plant, columns, values."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hydro_envs.data.channels import TIME_CHANNEL, Channel, channels_for, known_plants
from hydro_envs.data.record import MeasuredData, MeasuredDataError

PARQUET_SUFFIXES = (".parquet", ".pq")
_META_UNITS = b"hydro_envs.units"
_META_META = b"hydro_envs.metadata"

_KEY_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_META_LINE_RE = re.compile(r"([A-Za-z_][A-Za-z0-9_.\-]*)\s*:\s*(.*)")
_HEADER_CELL_RE = re.compile(r"([^\s\[\]]+)\s*(?:\[([^\[\]]*)\])?")
_NUMBER_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_ALLOWED_NUMBERS = "finite decimal numbers such as 1, -2.5 or 3e-4"


def _plant_table(path: Any, plant: str) -> tuple[Channel, ...]:
    try:
        return channels_for(plant)
    except KeyError:
        known = ", ".join(known_plants()) or "(none registered)"
        raise MeasuredDataError(
            path, f"unknown plant {plant!r}; known plants: {known}"
        ) from None


def _resolve_plant(path: Any, plant_arg: str | None, meta_plant: str | None) -> str:
    if plant_arg is not None and meta_plant is not None and plant_arg != meta_plant:
        raise MeasuredDataError(
            path,
            f"plant {plant_arg!r} was requested but the file says '# plant: {meta_plant}'",
        )
    plant = plant_arg if plant_arg is not None else meta_plant
    if plant is None:
        known = ", ".join(known_plants()) or "(none registered)"
        raise MeasuredDataError(
            path,
            "no plant given: pass plant=NAME or add a '# plant: NAME' line before the "
            f"header; known plants: {known}",
        )
    return plant


def _check_columns(
    path: Any,
    plant: str,
    names: Sequence[str],
    header_units: Sequence[str | None],
    required: Iterable[str] | None,
    allow_extra: bool,
    where: Callable[[int], str],
    conversions: dict[str, Any] | None = None,
) -> tuple[dict[str, str], list[str]]:
    """Validate the column list; return units per column and the canonical column order.

    ``where(j)`` describes column ``j`` (0-based) for messages. With ``conversions`` (a dict
    filled here: column -> :class:`hydro_envs.data.units.Conversion`), a header unit that
    converts to the registered one (``x [mm]``, ``p1 [bar]``, ``t [ms]``) is accepted and its
    conversion recorded; without it (the writer) the unit must be the registered one.
    """
    table = _plant_table(path, plant)
    registered = {c.name: c for c in table}
    allowed = ", ".join(c.name for c in table)

    if not names:
        raise MeasuredDataError(path, "no columns; the first column must be 't'")
    if names[0] != TIME_CHANNEL.name:
        hint = ""
        if any(sep in names[0] for sep in (";", "\t", " ")):
            hint = " (columns must be separated by ',')"
        raise MeasuredDataError(
            path,
            f"{where(0)}: first column must be 't' (time in s), found {names[0]!r}{hint}",
            column=names[0],
        )
    first_pos: dict[str, int] = {}
    for j, name in enumerate(names):
        if name in first_pos:
            raise MeasuredDataError(
                path,
                f"duplicate column {name!r} (columns {first_pos[name] + 1} and {j + 1}); "
                "each channel may appear only once",
                column=name,
            )
        first_pos[name] = j

    units: dict[str, str] = {}
    for j, (name, unit) in enumerate(zip(names, header_units)):
        if name == TIME_CHANNEL.name:
            expected: str | None = TIME_CHANNEL.unit
        elif name in registered:
            expected = registered[name].unit
        else:
            if not allow_extra:
                raise MeasuredDataError(
                    path,
                    f"{where(j)}: {name!r} is not a channel of plant {plant!r}; "
                    f"allowed columns: t, {allowed}",
                    column=name,
                )
            if not _NAME_RE.fullmatch(name):
                raise MeasuredDataError(
                    path,
                    f"{where(j)}: column name {name!r} is invalid; use letters, digits "
                    "and '_'",
                    column=name,
                )
            expected = None
        if unit is not None and expected is not None and unit != expected and conversions is not None:
            from hydro_envs.data.units import UnitError, conversion

            meaning = registered[name].meaning if name in registered else ""
            try:
                conversions[name] = conversion(unit, expected, column=name,
                                               gauge_channel="gauge" in (name + " " + meaning).lower())
            except UnitError as exc:
                raise MeasuredDataError(path, f"{where(j)}: {exc}", column=name) from None
        elif unit is not None and expected is not None and unit != expected:
            raise MeasuredDataError(
                path,
                f"{where(j)}: column {name!r} is given in [{unit}] but "
                + (
                    "time is in [s]"
                    if name == TIME_CHANNEL.name
                    else f"channel {name!r} of plant {plant!r} is in [{expected}]"
                )
                + f"; convert the values to {expected} and write '{name} [{expected}]' "
                f"or '{name}'",
                column=name,
            )
        units[name] = expected if expected is not None else (unit or "")

    if required is None:
        req = [c.name for c in table]
    else:
        req = [required] if isinstance(required, str) else list(required)
        for r in req:
            if r != TIME_CHANNEL.name and r not in registered and not allow_extra:
                raise MeasuredDataError(
                    path,
                    f"required channel {r!r} is not a channel of plant {plant!r}; "
                    f"allowed: {allowed}",
                    column=r,
                )
    missing = [r for r in req if r not in first_pos]
    if missing:
        raise MeasuredDataError(
            path,
            f"missing required column(s) {', '.join(repr(m) for m in missing)} for plant "
            f"{plant!r}; the file has: {', '.join(names)}; required: "
            f"{', '.join(req) or '(none)'}",
            column=missing[0],
        )

    order = [c.name for c in table if c.name in first_pos]
    order += [n for n in names[1:] if n not in registered]
    return units, order


def _check_values(
    path: Any,
    names: Sequence[str],
    columns: Sequence[np.ndarray],
    row_label: Callable[[int], tuple[str, int | None]],
) -> None:
    """Finite values, strictly increasing time, at least 2 rows.

    ``row_label(i)`` gives (text, number) locating data row ``i`` (0-based).
    """
    n = int(columns[0].shape[0]) if columns else 0
    if n < 2:
        raise MeasuredDataError(
            path, f"has {n} data row(s); at least 2 are needed (time + channels per row)"
        )
    # first non-finite cell in row order, then column order
    bad_rows = [np.flatnonzero(~np.isfinite(c)) for c in columns]
    firsts = [(int(b[0]), j) for j, b in enumerate(bad_rows) if b.size]
    if firsts:
        i, j = min(firsts)
        text, num = row_label(i)
        raise MeasuredDataError(
            path,
            f"{text}, column {names[j]!r}: value {float(columns[j][i])!r} is not finite; "
            f"all cells must be {_ALLOWED_NUMBERS}",
            line=num,
            column=names[j],
        )
    t = columns[0]
    dt = np.diff(t)
    bad = np.flatnonzero(~(dt > 0))
    if bad.size:
        i = int(bad[0]) + 1
        text, num = row_label(i)
        prev_text, _ = row_label(i - 1)
        kind = "duplicate time" if t[i] == t[i - 1] else "time goes backwards"
        raise MeasuredDataError(
            path,
            f"{text}, column 't': {kind}: t = {float(t[i])!r} is not greater than "
            f"t = {float(t[i - 1])!r} at {prev_text}; time must be strictly increasing",
            line=num,
            column="t",
        )


def _build(
    path: Any,
    plant: str,
    names: Sequence[str],
    columns: Sequence[np.ndarray],
    units: dict[str, str],
    order: Sequence[str],
    metadata: dict[str, str],
) -> MeasuredData:
    idx = {n: j for j, n in enumerate(names)}
    return MeasuredData(
        plant=plant,
        t=columns[0],
        channels={n: columns[idx[n]] for n in order},
        units={"t": units["t"], **{n: units[n] for n in order}},
        metadata=metadata,
    )


def _is_parquet(path: Path) -> bool:
    return path.suffix.lower() in PARQUET_SUFFIXES


def _import_pyarrow(path: Any):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise MeasuredDataError(
            path,
            "parquet files need pyarrow (pip install 'hydro-envs[parquet]'); "
            "use a .csv file otherwise",
        ) from None
    return pa, pq

