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
   may carry its unit in square brackets, ``x [m]``; if given it must equal the registered
   unit exactly (case-sensitive: ``mPa`` is not ``MPa``). No unit: the registered one is
   assumed. Columns that are not channels of the plant are rejected (unless the reader
   passes ``allow_extra=True``).
3. Then one row per sample, same number of cells as the header, every cell a finite
   decimal number (``1``, ``-2.5``, ``3e-4``; no NaN, inf, empty cells or thousands
   separators). Time is strictly increasing. At least 2 rows. Blank lines are allowed only
   at the end of the file. Nothing is dropped or repaired on reading.
4. Values are SI as registered for the plant (pressures absolute in Pa, positions in m,
   valve commands in V). Writers use Python's shortest round-trip ``repr`` of each float,
   so a write/read cycle is bit-exact.

Parquet (suffix ``.parquet`` or ``.pq``, needs ``pyarrow``): the same column names, float64
(integers are accepted on reading), no nulls; the units are stored as JSON under the
schema-metadata key ``hydro_envs.units`` and the ``# key: value`` metadata (including
``plant``) as JSON under ``hydro_envs.metadata``. The same validation applies.

Every problem raises :class:`MeasuredDataError` (a ``ValueError``) whose message names the
file, the line (CSV, 1-based physical line) or data row (parquet, 1-based), the column, and
what is allowed.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hydro_envs.data.channels import TIME_CHANNEL, Channel, channels_for, known_plants

__all__ = [
    "MeasuredData",
    "MeasuredDataError",
    "load_measured",
    "write_measured",
    "PARQUET_SUFFIXES",
]

PARQUET_SUFFIXES = (".parquet", ".pq")
_META_UNITS = b"hydro_envs.units"
_META_META = b"hydro_envs.metadata"

_KEY_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_META_LINE_RE = re.compile(r"([A-Za-z_][A-Za-z0-9_.\-]*)\s*:\s*(.*)")
_HEADER_CELL_RE = re.compile(r"([^\s\[\]]+)\s*(?:\[([^\[\]]*)\])?")
_NUMBER_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_ALLOWED_NUMBERS = "finite decimal numbers such as 1, -2.5 or 3e-4"


class MeasuredDataError(ValueError):
    """A measured-data file (or data to be written) violates the format.

    Attributes ``path``, ``line`` (CSV physical line or parquet data row, 1-based) and
    ``column`` locate the problem when known.
    """

    def __init__(
        self,
        path: str | os.PathLike[str] | None,
        message: str,
        *,
        line: int | None = None,
        column: str | None = None,
    ) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        self.column = column
        prefix = f"{self.path}: " if self.path is not None else ""
        super().__init__(prefix + message)


@dataclass
class MeasuredData:
    """Time series of one record: time ``t`` and the plant's channels, all in SI units.

    ``units`` maps every column name (including ``"t"``) to its unit; ``metadata`` holds
    the ``# key: value`` lines except ``plant`` (which is the ``plant`` attribute).
    """

    plant: str | None
    t: np.ndarray
    channels: dict[str, np.ndarray]
    units: dict[str, str] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64)
        if self.t.ndim != 1:
            raise MeasuredDataError(None, f"t must be 1-D, got shape {self.t.shape}")
        chans: dict[str, np.ndarray] = {}
        for name, values in dict(self.channels).items():
            arr = np.asarray(values, dtype=np.float64)
            if arr.shape != self.t.shape:
                raise MeasuredDataError(
                    None,
                    f"channel {name!r} has shape {arr.shape}, expected {self.t.shape} "
                    "(one value per time sample)",
                    column=name,
                )
            chans[name] = arr
        self.channels = chans
        self.units = dict(self.units)
        self.metadata = {str(k): str(v) for k, v in dict(self.metadata).items()}

    # --- access -------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """Channel names (time excluded), in column order."""
        return tuple(self.channels)

    def __getitem__(self, name: str) -> np.ndarray:
        if name == TIME_CHANNEL.name:
            return self.t
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(
                f"no channel {name!r}; available: t, {', '.join(self.channels)}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name == TIME_CHANNEL.name or name in self.channels

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def n_samples(self) -> int:
        return len(self)

    @property
    def sample_time(self) -> float:
        """Median time step [s] (NaN with fewer than 2 samples)."""
        if len(self) < 2:
            return float("nan")
        return float(np.median(np.diff(self.t)))

    @property
    def duration(self) -> float:
        """``t[-1] - t[0]`` [s] (0 for fewer than 2 samples)."""
        if len(self) < 2:
            return 0.0
        return float(self.t[-1] - self.t[0])

    def to_array(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Stack columns into an ``(n_samples, len(names))`` float64 array.

        ``names`` defaults to all channels (time excluded); ``"t"`` may be listed.
        """
        if names is None:
            names = self.names
        if isinstance(names, str):
            names = (names,)
        cols = [self[n] for n in names]
        if not cols:
            return np.empty((len(self), 0))
        return np.column_stack(cols)


# ========================================================================================
# shared validation
# ========================================================================================


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
) -> tuple[dict[str, str], list[str]]:
    """Validate the column list; return units per column and the canonical column order.

    ``where(j)`` describes column ``j`` (0-based) for messages.
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
        if unit is not None and expected is not None and unit != expected:
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


# ========================================================================================
# reading
# ========================================================================================


def load_measured(
    path: str | os.PathLike[str],
    plant: str | None = None,
    required: Iterable[str] | None = None,
    *,
    allow_extra: bool = False,
) -> MeasuredData:
    """Read and validate a measured-data file (CSV, or parquet by suffix).

    ``plant`` defaults to the file's ``# plant:`` metadata (if both are given they must
    agree). ``required`` lists the channels that must be present; it defaults to all the
    plant's channels. Registered channels present beyond ``required`` are loaded too.
    Columns that are not channels of the plant are an error unless ``allow_extra``.
    Raises :class:`MeasuredDataError` on any violation of the format.
    """
    p = Path(path)
    if not p.exists():
        raise MeasuredDataError(p, "file not found")
    if not p.is_file():
        raise MeasuredDataError(p, "not a regular file")
    if _is_parquet(p):
        return _load_parquet(p, plant, required, allow_extra)
    return _load_csv(p, plant, required, allow_extra)


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
    units, order = _check_columns(
        path,
        plant_name,
        names,
        hunits,
        required,
        allow_extra,
        lambda j: f"line {hline}, header column {j + 1}",
    )

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
    columns = [np.ascontiguousarray(arr[:, j]) for j in range(ncol)]
    _check_values(
        path,
        names,
        columns,
        lambda i: (f"line {linenos[i]}", linenos[i]),
    )
    return _build(path, plant_name, names, columns, units, order, metadata)


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
    units, order = _check_columns(
        path,
        plant_name,
        names,
        hunits,
        required,
        allow_extra,
        lambda j: f"column {j + 1}",
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
    _check_values(path, names, columns, lambda i: (f"data row {i + 1}", i + 1))
    return _build(path, plant_name, names, columns, units, order, metadata)


# ========================================================================================
# writing
# ========================================================================================


def _clean_metadata(path: Any, metadata: Mapping[str, Any]) -> dict[str, str]:
    out: dict[str, str] = {}
    for k, v in metadata.items():
        if not isinstance(k, str) or not _KEY_RE.fullmatch(k):
            raise MeasuredDataError(
                path,
                f"metadata key {k!r} is invalid; use letters, digits and '_ . -', "
                "starting with a letter or '_'",
            )
        s = str(v)
        if k != "comment" and ("\n" in s or "\r" in s):
            raise MeasuredDataError(
                path,
                f"metadata value of {k!r} contains a line break; only 'comment' may span "
                "several lines",
            )
        if k != "comment" and s != s.strip():
            raise MeasuredDataError(
                path,
                f"metadata value of {k!r} has leading/trailing whitespace, which would "
                "not survive a round trip",
            )
        out[k] = s
    return out


def write_measured(
    path: str | os.PathLike[str],
    data: MeasuredData | np.ndarray | Sequence[float],
    channels: Mapping[str, Any] | None = None,
    *,
    plant: str | None = None,
    metadata: Mapping[str, Any] | None = None,
    units: Mapping[str, str] | None = None,
    allow_extra: bool = False,
) -> Path:
    """Write a measured-data file: CSV, or parquet when the suffix is ``.parquet``/``.pq``.

    Call either ``write_measured(path, measured_data)`` or
    ``write_measured(path, t, {"u": u, "x": x, ...}, plant="servo_cylinder")``.

    ``plant`` (or ``metadata["plant"]`` / ``data.plant``) is required and must be
    registered. Any subset of the plant's channels may be written; they are written in the
    registry's order. ``units`` may restate registered units (they must match) and gives the
    units of extra columns (only with ``allow_extra``). The data are validated with the same
    rules as :func:`load_measured` (finite, strictly increasing time, >= 2 rows), so a file
    written here always loads. The file is written atomically (temp file + rename).
    Returns the path written.
    """
    p = Path(path)
    meta: dict[str, Any] = {}
    unit_over: dict[str, str] = {}
    if isinstance(data, MeasuredData):
        if channels is not None:
            raise TypeError("pass either a MeasuredData or (t, channels), not both")
        t = data.t
        chans: Mapping[str, Any] = data.channels
        meta.update(data.metadata)
        if data.plant is not None:
            meta.setdefault("plant", data.plant)
        unit_over.update({k: v for k, v in data.units.items()})
    else:
        if channels is None:
            raise TypeError("channels (a mapping name -> values) is required with a time array")
        t = data
        chans = channels
    if metadata:
        meta.update(metadata)
    if units:
        unit_over.update(units)
    if plant is not None:
        mp = meta.get("plant")
        if mp is not None and str(mp) != plant:
            raise MeasuredDataError(
                p, f"plant {plant!r} conflicts with metadata plant {str(mp)!r}"
            )
        meta["plant"] = plant
    plant_name = _resolve_plant(p, None, None if meta.get("plant") is None else str(meta["plant"]))
    meta.pop("plant", None)
    meta_clean = _clean_metadata(p, meta)

    t_arr = np.asarray(t, dtype=np.float64)
    if t_arr.ndim != 1:
        raise MeasuredDataError(p, f"t must be 1-D, got shape {t_arr.shape}", column="t")
    if TIME_CHANNEL.name in chans:
        raise MeasuredDataError(
            p, "channels must not contain 't'; pass time separately", column="t"
        )
    in_names = ["t", *chans]
    cols_in = [t_arr]
    for name, values in chans.items():
        try:
            arr = np.asarray(values, dtype=np.float64)
        except (TypeError, ValueError):
            raise MeasuredDataError(
                p, f"channel {name!r} is not numeric", column=str(name)
            ) from None
        if arr.shape != t_arr.shape:
            raise MeasuredDataError(
                p,
                f"channel {name!r} has shape {arr.shape}, expected {t_arr.shape} (one value "
                "per time sample)",
                column=str(name),
            )
        cols_in.append(arr)
    unknown_units = [k for k in unit_over if k not in in_names]
    if unknown_units:
        raise MeasuredDataError(
            p,
            f"units given for column(s) not written: {', '.join(map(str, unknown_units))}",
            column=str(unknown_units[0]),
        )
    hunits = [unit_over.get(n) for n in in_names]
    col_units, order = _check_columns(
        p, plant_name, in_names, hunits, [], allow_extra, lambda j: f"column {in_names[j]!r}"
    )
    _check_values(p, in_names, cols_in, lambda i: (f"sample {i} (0-based)", i))
    idx = {n: j for j, n in enumerate(in_names)}
    out_names = ["t", *order]
    out_cols = [cols_in[idx[n]] for n in out_names]

    if _is_parquet(p):
        _write_parquet(p, plant_name, out_names, out_cols, col_units, meta_clean)
    else:
        _write_csv(p, plant_name, out_names, out_cols, col_units, meta_clean)
    return p


def _atomic_write(path: Path, writer: Callable[[Path], None]) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        writer(tmp)
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except FileNotFoundError:
            pass
        raise


def _write_csv(
    path: Path,
    plant: str,
    names: Sequence[str],
    columns: Sequence[np.ndarray],
    units: Mapping[str, str],
    metadata: Mapping[str, str],
) -> None:
    head = [f"# plant: {plant}"]
    for k, v in metadata.items():
        if k == "comment":
            continue
        head.append(f"# {k}: {v}" if v else f"# {k}:")
    if "comment" in metadata:
        for ln in metadata["comment"].split("\n"):
            head.append(f"# comment: {ln.strip()}")
    header = ",".join(f"{n} [{units[n]}]" if units.get(n) else n for n in names)
    arr = np.column_stack(columns)

    def writer(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            f.write("\n".join(head) + "\n")
            f.write(header + "\n")
            rep = repr
            for row in arr.tolist():
                f.write(",".join([rep(v) for v in row]))
                f.write("\n")

    _atomic_write(path, writer)


def _write_parquet(
    path: Path,
    plant: str,
    names: Sequence[str],
    columns: Sequence[np.ndarray],
    units: Mapping[str, str],
    metadata: Mapping[str, str],
) -> None:
    pa, pq = _import_pyarrow(path)
    meta = {"plant": plant, **metadata}
    schema_meta = {
        _META_UNITS: json.dumps({n: units[n] for n in names}).encode("utf-8"),
        _META_META: json.dumps(meta).encode("utf-8"),
    }
    table = pa.table({n: pa.array(c, type=pa.float64()) for n, c in zip(names, columns)})
    table = table.replace_schema_metadata(schema_meta)
    _atomic_write(path, lambda tmp: pq.write_table(table, tmp))
