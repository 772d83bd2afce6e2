"""Reading format-v1 measured-data files (CSV and parquet); see :mod:`hydro_envs.data.measured`."""

from __future__ import annotations

import csv
import io
import json
import math
import re
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from hydro_envs.data.record import MeasuredData, MeasuredDataError
from hydro_envs.data.v1_common import (
    _ALLOWED_NUMBERS,
    _HEADER_CELL_RE,
    _META_LINE_RE,
    _META_META,
    _META_UNITS,
    _NUMBER_RE,
    _build,
    _check_columns,
    _check_values,
    _import_pyarrow,
    _resolve_plant,
)


def _parse_header_cell(path: Path, lineno: int, j: int, cell: str) -> tuple[str, str | None]:
    s = cell.strip()
    if not s:
        raise MeasuredDataError(
            path,
            f"line {lineno}: header column {j + 1} is empty; every column needs a name",
            line=lineno,
        )
    m = _HEADER_CELL_RE.fullmatch(s)
    if m is None:
        raise MeasuredDataError(
            path,
            f"line {lineno}: header column {j + 1} {s!r} is malformed; expected 'name' or "
            "'name [unit]'",
            line=lineno,
        )
    unit = m.group(2)
    return m.group(1), (unit.strip() if unit is not None else None)


def _cell_error(path: Path, lineno: int, column: str, cell: str) -> MeasuredDataError:
    s = cell.strip()
    if not s:
        what = "empty cell (missing value)"
    else:
        try:
            v = float(s)
        except ValueError:
            v = None
        if v is not None and not math.isfinite(v):
            what = f"value {s!r} is not finite"
        else:
            what = f"{s!r} is not a number"
    return MeasuredDataError(
        path,
        f"line {lineno}, column {column!r}: {what}; all cells must be {_ALLOWED_NUMBERS}",
        line=lineno,
        column=column,
    )


def _load_csv(
    path: Path, plant: str | None, required: Iterable[str] | None, allow_extra: bool
) -> MeasuredData:
    raw = path.read_bytes()
    if not raw.strip():
        raise MeasuredDataError(path, "file is empty; expected a header row starting with 't'")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasuredDataError(
            path, f"not valid UTF-8 (byte offset {e.start}); save the file as UTF-8"
        ) from None
    lines = text.split("\n")
    lines = [ln[:-1] if ln.endswith("\r") else ln for ln in lines]
    for k, ln in enumerate(lines):  # the csv module rejects a lone CR inside a field
        if "\r" in ln:
            raise MeasuredDataError(
                path,
                f"line {k + 1}: carriage return (CR) inside the line; lines must end with LF or "
                "CRLF (old Mac 'CR only' files: convert the line ends)",
                line=k + 1,
            )

    # --- comments / metadata ---------------------------------------------------------
    metadata: dict[str, str] = {}
    comments: list[str] = []
    meta_line: dict[str, int] = {}
    h = None
    for k, ln in enumerate(lines):
        s = ln.strip()
        if not s:
            continue
        if not s.startswith("#"):
            h = k
            break
        body = s[1:].strip()
        if not body:
            continue
        m = _META_LINE_RE.fullmatch(body)
        if m is None:
            comments.append(body)
            continue
        key, value = m.group(1), m.group(2).strip()
        if key == "comment":
            comments.append(value)
            continue
        if key in metadata:
            raise MeasuredDataError(
                path,
                f"line {k + 1}: metadata key {key!r} repeats line {meta_line[key]}; each "
                "key may appear once (use '# comment: ...' for repeated notes)",
                line=k + 1,
            )
        metadata[key] = value
        meta_line[key] = k + 1
    if comments:
        metadata["comment"] = "\n".join(comments)
    if h is None:
        raise MeasuredDataError(
            path,
            "no header row: the file has only comment lines; expected a header such as "
            "'t [s],u [V],...' after the comments",
        )

    # --- header ----------------------------------------------------------------------
    hline = h + 1
    try:
        header = next(csv.reader([lines[h]]))
    except csv.Error as e:
        raise MeasuredDataError(path, f"line {hline}: unreadable header ({e})", line=hline) from None
    if header and _NUMBER_RE.fullmatch(header[0].strip()):
        raise MeasuredDataError(
            path,
            f"line {hline}: no header row: this line looks like data; the first "
            "non-comment line must be the header, starting with 't' (e.g. "
            "'t [s],u [V],x [m]')",
            line=hline,
        )
    parsed = [_parse_header_cell(path, hline, j, c) for j, c in enumerate(header)]
    names = [n for n, _ in parsed]
    hunits = [u for _, u in parsed]

    plant_name = _resolve_plant(path, plant, metadata.pop("plant", None))
    conversions: dict = {}
    units, order = _check_columns(
        path,
        plant_name,
        names,
        hunits,
        required,
        allow_extra,
        lambda j: f"line {hline}, header column {j + 1}",
        conversions,
    )
    assumed = tuple(f"{n} [{units[n]}]" for n, u in zip(names, hunits) if u is None and units.get(n))

    # --- data rows -------------------------------------------------------------------
    ncol = len(names)
    data_lines = lines[h + 1 :]
    while data_lines and not data_lines[-1].strip():
        data_lines.pop()  # trailing blank lines
    row_re = _row_regex(ncol)
    if all(row_re.fullmatch(ln) for ln in data_lines):
        # fast path: every line is a well-formed numeric row (checked above), parse in C
        if data_lines:
            arr = np.loadtxt(
                io.StringIO("\n".join(data_lines)),
                delimiter=",",
                dtype=np.float64,
                ndmin=2,
                comments=None,
            )
        else:
            arr = np.empty((0, ncol))
        linenos = list(range(hline + 1, hline + 1 + len(data_lines)))
    else:
        arr, linenos = _parse_rows_slow(path, data_lines, hline, names)
    columns = _convert(names, [np.ascontiguousarray(arr[:, j]) for j in range(ncol)], conversions, metadata)
    _check_values(
        path,
        names,
        columns,
        lambda i: (f"line {linenos[i]}", linenos[i]),
    )
    out = _build(path, plant_name, names, columns, units, order, metadata)
    out.units_assumed = assumed  # said, not silent: readers report it (identify notes)
    return out


def _convert(names: Sequence[str], columns: list[np.ndarray], conversions: dict, metadata: dict[str, str]) -> list[np.ndarray]:
    """Columns converted to SI where the header declared another unit (noted as ``unit.NAME``)."""
    for j, name in enumerate(names):
        conv = conversions.get(name)
        if conv is not None:
            columns[j] = np.asarray(conv.apply(columns[j]), dtype=np.float64)
            if conv.note:
                metadata[f"unit.{name}"] = conv.note
    return columns


def _row_regex(ncol: int) -> re.Pattern[str]:
    cell = r"[ \t]*" + _NUMBER_RE.pattern + r"[ \t]*"
    return re.compile(cell + (r"," + cell) * (ncol - 1), re.ASCII)


def _parse_rows_slow(
    path: Path, data_lines: list[str], hline: int, names: Sequence[str]
) -> tuple[np.ndarray, list[int]]:
    """Cell-by-cell parse that locates the first malformed row/cell."""
    ncol = len(names)
    rows: list[list[float]] = []
    linenos: list[int] = []
    blank_at: int | None = None
    number = _NUMBER_RE.fullmatch
    reader = csv.reader(data_lines)
    for cells in reader:
        lineno = hline + reader.line_num
        if not cells or (len(cells) == 1 and not cells[0].strip()):
            if blank_at is None:
                blank_at = lineno
            continue
        if blank_at is not None:
            raise MeasuredDataError(
                path,
                f"line {blank_at}: blank line inside the data; blank lines are only "
                "allowed at the end of the file",
                line=blank_at,
            )
        if cells[0].lstrip().startswith("#"):
            raise MeasuredDataError(
                path,
                f"line {lineno}: comment line after the header; comments are only "
                "allowed before the header",
                line=lineno,
            )
        if len(cells) != ncol:
            raise MeasuredDataError(
                path,
                f"line {lineno}: has {len(cells)} cells, expected {ncol} (one per header "
                f"column: {', '.join(names)})",
                line=lineno,
            )
        row = []
        for j, c in enumerate(cells):
            s = c.strip()
            if number(s) is None:
                raise _cell_error(path, lineno, names[j], c)
            row.append(float(s))
        rows.append(row)
        linenos.append(lineno)
    return np.array(rows, dtype=np.float64).reshape(len(rows), ncol), linenos


def _load_parquet(
    path: Path, plant: str | None, required: Iterable[str] | None, allow_extra: bool
) -> MeasuredData:
    pa, pq = _import_pyarrow(path)
    if path.stat().st_size == 0:
        raise MeasuredDataError(path, "file is empty")
    try:
        table = pq.read_table(path)
    except Exception as e:  # pyarrow raises several types for corrupt files
        raise MeasuredDataError(path, f"cannot read parquet file: {e}") from None
    schema_meta = table.schema.metadata or {}

    def _json(key: bytes) -> dict[str, str]:
        if key not in schema_meta:
            return {}
        try:
            val = json.loads(schema_meta[key].decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            raise MeasuredDataError(
                path, f"schema metadata {key.decode()!r} is not valid JSON: {e}"
            ) from None
        if not isinstance(val, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in val.items()
        ):
            raise MeasuredDataError(
                path,
                f"schema metadata {key.decode()!r} must be a JSON object of strings",
            )
        return val

    file_units = _json(_META_UNITS)
    metadata = _json(_META_META)
    names = list(table.column_names)
    unknown_units = [k for k in file_units if k not in names]
    if unknown_units:
        raise MeasuredDataError(
            path,
            f"units given for column(s) not in the file: {', '.join(unknown_units)}",
            column=unknown_units[0],
        )
    hunits = [file_units.get(n) for n in names]
    plant_name = _resolve_plant(path, plant, metadata.pop("plant", None))
    conversions: dict = {}
    units, order = _check_columns(
        path,
        plant_name,
        names,
        hunits,
        required,
        allow_extra,
        lambda j: f"column {j + 1}",
        conversions,
    )
    columns = []
    for j, name in enumerate(names):
        col = table.column(j)
        typ = col.type
        if not (pa.types.is_floating(typ) or pa.types.is_integer(typ)):
            raise MeasuredDataError(
                path,
                f"column {name!r} has type {typ}; columns must be numeric (float64)",
                column=name,
            )
        if col.null_count:
            i = int(np.flatnonzero(col.is_null().to_numpy(zero_copy_only=False))[0])
            raise MeasuredDataError(
                path,
                f"data row {i + 1}, column {name!r}: missing value (null); all cells must "
                f"be {_ALLOWED_NUMBERS}",
                line=i + 1,
                column=name,
            )
        columns.append(np.asarray(col.to_numpy(), dtype=np.float64))
    columns = _convert(names, columns, conversions, metadata)
    _check_values(path, names, columns, lambda i: (f"data row {i + 1}", i + 1))
    out = _build(path, plant_name, names, columns, units, order, metadata)
    out.units_assumed = tuple(f"{n} [{units[n]}]" for n, u in zip(names, hunits) if u is None and units.get(n))
    return out
