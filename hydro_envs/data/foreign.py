"""Records in a lab's own layout: delimited text (sniffed), MATLAB ``.mat``, and a column map.

Text files: ``,`` ``;`` or tab delimited, or whitespace separated (sniffed from the first data
line). Leading ``#`` lines are comments (``# key: value`` is metadata). A header row is optional:
its cells are ``name`` or ``name [unit]``; without one the columns are named ``c1``, ``c2``, ...

MATLAB files (``scipy.io.loadmat``, format v4 to v7): every numeric variable with one value per
sample (1-D, ``n x 1`` or ``1 x n``) of the record's length is a column; a scalar variable is a
constant usable in a product. v7.3 files are HDF5 and are refused with a hint to convert them.

The column map says where each channel comes from: ``{"t": "time", "x": "qm [mm]",
"f": "gtau * vir"}``, the same as a string ``"t=time,x=qm[mm],f=gtau*vir"``, or a YAML sidecar::

    columns: [time, v1, v2, v3, disp, p, force]   # names for a file without a header row
    map:
      t: {from: time, unit: ms}
      x: {from: disp, unit: mm}
      p_gauge: {from: p, unit: bar}
      F_load: force
    units: {F_load: N}                            # units per channel (as --units)

A source expression is a column name, or a product of column names and numbers
(``gtau * vir``, ``2 * v``). A channel's unit comes from the map, else from ``units``, else from
the header cell of a single source column; a foreign record without a unit for a channel is an
error. Values are converted once to the plant's SI unit (:mod:`hydro_envs.data.units`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from hydro_envs.data.channels import TIME_CHANNEL
from hydro_envs.data.record import MeasuredData, MeasuredDataError
from hydro_envs.data.units import UnitError, conversion

__all__ = ["parse_column_map", "parse_units", "read_table", "read_mat", "load_sidecar", "apply_map"]

_HEADER_CELL_RE = re.compile(r"\s*([^\s\[\]]+)\s*(?:\[([^\[\]]*)\])?\s*")
_ENTRY_RE = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^\[\]=]+?)\s*(?:\[([^\[\]]*)\])?\s*")
_META_LINE_RE = re.compile(r"([A-Za-z_][A-Za-z0-9_.\-]*)\s*:\s*(.*)")
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _float(s: str) -> float | None:
    try:
        return float(s)
    except ValueError:
        return None


# ---- column map -------------------------------------------------------------------------

def parse_column_map(spec: str | Mapping[str, Any] | None, path: Any = None) -> dict[str, dict[str, Any]]:
    """Normalise a column map to ``{channel: {"from": expr, "unit": u|None, "gauge": b|None}}``.

    ``spec`` is a string ``"t=time,x=qm[mm],f=gtau*vir"`` or a mapping channel -> expression
    (or -> ``{"from": expr, "unit": ..., "gauge": ...}``). A channel given twice is an error.
    """
    if spec is None:
        return {}
    out: dict[str, dict[str, Any]] = {}
    if isinstance(spec, str):
        for part in spec.split(","):
            if not part.strip():
                continue
            m = _ENTRY_RE.fullmatch(part)
            if m is None:
                raise MeasuredDataError(
                    path, f"column map entry {part.strip()!r} is malformed; expected 'channel=expr' or "
                    "'channel=expr[unit]', e.g. 't=time,x=qm[mm],f=gtau*vir'")
            ch, expr, unit = m.group(1), m.group(2), m.group(3)
            if ch in out:
                raise MeasuredDataError(path, f"column map gives channel {ch!r} twice", column=ch)
            out[ch] = {"from": expr, "unit": None if unit is None else unit.strip(), "gauge": None}
        return out
    if not isinstance(spec, Mapping):
        raise MeasuredDataError(path, f"column map must be a string or a mapping, got {type(spec).__name__}")
    for ch, v in spec.items():
        if not isinstance(ch, str) or not _NAME_RE.fullmatch(ch):
            raise MeasuredDataError(path, f"column map: channel name {ch!r} is invalid")
        if isinstance(v, str):
            out[ch] = {"from": v, "unit": None, "gauge": None}
        elif isinstance(v, Mapping):
            bad = set(v) - {"from", "unit", "gauge"}
            if bad or "from" not in v:
                raise MeasuredDataError(
                    path, f"column map entry {ch!r}: keys must be from (required), unit, gauge; got "
                    f"{sorted(map(str, v))}", column=ch)
            g = v.get("gauge")
            if g is not None and not isinstance(g, bool):
                raise MeasuredDataError(path, f"column map entry {ch!r}: gauge must be true or false, got {g!r}", column=ch)
            u = v.get("unit")
            out[ch] = {"from": str(v["from"]), "unit": None if u is None else str(u), "gauge": g}
        else:
            raise MeasuredDataError(path, f"column map entry {ch!r}: expected an expression string, got {v!r}", column=ch)
    return out


def parse_units(spec: str | Mapping[str, str] | None, path: Any = None) -> dict[str, str]:
    """``"x=mm,p1=bar(g)"`` or a mapping -> ``{channel: unit}``."""
    if spec is None:
        return {}
    if isinstance(spec, Mapping):
        return {str(k): str(v) for k, v in spec.items()}
    out: dict[str, str] = {}
    for part in str(spec).split(","):
        if not part.strip():
            continue
        name, sep, unit = part.partition("=")
        name = name.strip()
        if not sep or not _NAME_RE.fullmatch(name):
            raise MeasuredDataError(path, f"units entry {part.strip()!r} is malformed; expected 'channel=unit', e.g. 'x=mm'")
        if name in out:
            raise MeasuredDataError(path, f"units give channel {name!r} twice", column=name)
        out[name] = unit.strip()
    return out


def load_sidecar(path: Path) -> dict[str, Any]:
    """Read a YAML sidecar (``columns``, ``map``, ``units``, ``delimiter``) with :func:`hydro_envs.yamlio.load_yaml`
    (bounded, duplicate keys refused)."""
    from hydro_envs.yamlio import YamlError, load_yaml, short

    try:
        doc = load_yaml(path, what="column-map sidecar")
    except YamlError as e:
        raise MeasuredDataError(None, str(e)) from None
    if not isinstance(doc, dict):
        raise MeasuredDataError(path, "column-map sidecar must be a YAML mapping with keys columns, map, units")
    bad = set(doc) - {"columns", "map", "units", "delimiter"}
    if bad:
        raise MeasuredDataError(path, f"column-map sidecar: unknown key(s) {sorted(map(str, bad))}; allowed: columns, map, units, delimiter")
    cols = doc.get("columns")
    if cols is not None and not (isinstance(cols, list) and all(isinstance(c, str) for c in cols)):
        raise MeasuredDataError(path, f"column-map sidecar: columns = {short(cols)}; allowed a list of names")
    for key in ("map", "units"):
        if doc.get(key) is not None and not isinstance(doc[key], dict):
            raise MeasuredDataError(path, f"column-map sidecar: {key} = {short(doc[key])}; allowed a mapping")
    if doc.get("delimiter") is not None and doc["delimiter"] not in ("comma", "semicolon", "tab", "whitespace",
                                                                      ",", ";", "\t"):
        raise MeasuredDataError(path, f"column-map sidecar: delimiter = {short(doc['delimiter'])}; allowed comma, "
                                "semicolon, tab, whitespace")
    return doc


# ---- readers ----------------------------------------------------------------------------

def _split(line: str, delim: str | None) -> list[str]:
    return line.split() if delim is None else [c.strip() for c in line.split(delim)]


def _sniff(line: str) -> str | None:
    for d in ("\t", ";", ","):
        if d in line:
            return d
    return None  # whitespace


def read_table(path: Path, columns: list[str] | None = None, delimiter: str | None = None):
    """Read a delimited/whitespace text file -> (names, header units, 2-D array, metadata, first data line)."""
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasuredDataError(path, f"not valid UTF-8 text (byte offset {e.start}); save the file as UTF-8") from None
    lines = text.splitlines()
    meta: dict[str, str] = {}
    k = 0
    while k < len(lines) and (not lines[k].strip() or lines[k].lstrip().startswith("#")):
        m = _META_LINE_RE.fullmatch(lines[k].strip().lstrip("#").strip())
        if m is not None:
            meta.setdefault(m.group(1), m.group(2).strip())
        k += 1
    if k >= len(lines):
        raise MeasuredDataError(path, "no data: the file has only comments or blank lines")
    delim = {"whitespace": None, "tab": "\t", "comma": ",", "semicolon": ";"}.get(delimiter or "", delimiter)
    if delimiter is None:
        delim = _sniff(lines[k])
    first = _split(lines[k], delim)
    if delim is None and "[" in lines[k]:  # whitespace header with units: 'x [mm]' is one cell
        first = re.findall(r"[^\s\[\]]+(?:\s*\[[^\[\]]*\])?", lines[k])
    if all(_float(c) is not None for c in first):
        names = [f"c{j + 1}" for j in range(len(first))]
        hunits: list[str | None] = [None] * len(first)
    else:
        names, hunits = [], []
        for j, cell in enumerate(first):
            m = _HEADER_CELL_RE.fullmatch(cell)
            if m is None:
                raise MeasuredDataError(path, f"line {k + 1}: header cell {j + 1} {cell!r} is malformed; expected 'name' or 'name [unit]'", line=k + 1)
            names.append(m.group(1))
            hunits.append(None if m.group(2) is None else m.group(2).strip())
        k += 1
    if columns is not None:
        if len(columns) != len(names):
            raise MeasuredDataError(path, f"the sidecar names {len(columns)} columns but the file has {len(names)}")
        names = list(columns)
    rows = []
    for i in range(k, len(lines)):
        s = lines[i]
        if not s.strip():
            continue
        cells = _split(s, delim)
        if len(cells) != len(names):
            raise MeasuredDataError(path, f"line {i + 1}: has {len(cells)} cells, expected {len(names)} ({', '.join(names)})", line=i + 1)
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            j = next(j for j, c in enumerate(cells) if _float(c) is None)
            raise MeasuredDataError(path, f"line {i + 1}, column {names[j]!r}: {cells[j]!r} is not a number", line=i + 1, column=names[j]) from None
    arr = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    return names, hunits, arr, meta


def read_mat(path: Path) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Read a MATLAB file -> (1-D variables of the most common length, scalar constants)."""
    import scipy.io

    with open(path, "rb") as fh:
        head = fh.read(520)
    hdf5 = head[512:520] == b"\x89HDF\r\n\x1a\n" or head[:8] == b"\x89HDF\r\n\x1a\n"
    try:
        if hdf5:
            raise NotImplementedError
        raw = scipy.io.loadmat(str(path))
    except NotImplementedError:
        raise MeasuredDataError(
            path, "is a MATLAB v7.3 (HDF5) file, which scipy cannot read; in MATLAB re-save it with "
            "save('file.mat', '-v7') (or export the variables to CSV)") from None
    except Exception as e:  # scipy raises several types for non-MAT files
        raise MeasuredDataError(path, f"cannot read as a MATLAB .mat file: {e}") from None
    vectors: dict[str, np.ndarray] = {}
    consts: dict[str, float] = {}
    for name, val in raw.items():
        if name.startswith("__") or not isinstance(val, np.ndarray) or val.dtype.kind not in "fiub":
            continue
        a = np.asarray(val, dtype=np.float64)
        if a.size == 1:
            consts[name] = float(a.reshape(()))
        elif a.ndim == 1 or (a.ndim == 2 and min(a.shape) == 1):
            vectors[name] = a.reshape(-1)
    return vectors, consts


# ---- map -> record ----------------------------------------------------------------------

def _evaluate(path: Any, ch: str, expr: str, cols: Mapping[str, np.ndarray], consts: Mapping[str, float], n: int):
    factors = [f.strip() for f in expr.split("*")]
    if not all(factors):
        raise MeasuredDataError(path, f"channel {ch!r}: source expression {expr!r} is malformed; use 'a' or 'a * b'", column=ch)
    out: np.ndarray | float = 1.0
    sources = []
    for f in factors:
        num = _float(f)
        if num is not None:
            val: Any = num
        elif f in cols:
            val = cols[f]
            if val.shape[0] != n:
                raise MeasuredDataError(path, f"channel {ch!r}: column {f!r} has {val.shape[0]} values, the record has {n}", column=ch)
            sources.append(f)
        elif f in consts:
            val = consts[f]
        else:
            avail = ", ".join([*cols, *consts]) or "(none)"
            raise MeasuredDataError(path, f"channel {ch!r}: no column or constant named {f!r} in the file; available: {avail}", column=ch)
        out = val if (len(factors) == 1) else out * val
    if not sources:
        raise MeasuredDataError(path, f"channel {ch!r}: expression {expr!r} names no column (only constants)", column=ch)
    return np.asarray(out, dtype=np.float64), sources


def apply_map(
    path: Any,
    plant: str,
    table: tuple,
    cols: Mapping[str, np.ndarray],
    header_units: Mapping[str, str | None],
    consts: Mapping[str, float],
    cmap: Mapping[str, Mapping[str, Any]],
    units: Mapping[str, str],
    required: Iterable[str] | None,
    allow_extra: bool,
    metadata: dict[str, str],
) -> MeasuredData:
    """Build the SI record from source columns, a normalised column map and units."""
    registered = {c.name: c for c in table}
    allowed = ", ".join(["t", *registered])
    if not cmap:  # identity map over the file's columns
        cmap = {}
        for name in cols:
            if name != "t" and name not in registered:
                if not allow_extra:
                    raise MeasuredDataError(path, f"column {name!r} is not a channel of plant {plant!r}; allowed: {allowed} "
                                            "(give a column map to select and rename columns)", column=name)
            cmap[name] = {"from": name, "unit": None, "gauge": None}
    for ch in cmap:
        if ch != "t" and ch not in registered and not allow_extra:
            raise MeasuredDataError(path, f"column map names {ch!r}, which is not a channel of plant {plant!r}; allowed: {allowed}", column=ch)
    for ch in units:
        if ch not in cmap:
            raise MeasuredDataError(path, f"a unit is given for {ch!r}, which is not among the loaded columns: {', '.join(cmap)}", column=ch)
    if "t" not in cmap:
        raise MeasuredDataError(path, f"no time column: map 't' to the file's time column (columns: {', '.join(cols)})", column="t")
    req = [c.name for c in table] if required is None else ([required] if isinstance(required, str) else list(required))
    missing = [r for r in req if r not in cmap]
    if missing:
        raise MeasuredDataError(path, f"missing required channel(s) {', '.join(map(repr, missing))} for plant {plant!r}; "
                                f"the file has: {', '.join(cols)}; map them with channel=column", column=missing[0])
    n = max((len(v) for v in cols.values()), default=0)
    if "t" in cmap:
        n = len(cols.get(cmap["t"]["from"].strip(), np.empty(n)))
    out_units: dict[str, str] = {}
    values: dict[str, np.ndarray] = {}
    for ch, entry in cmap.items():
        arr, sources = _evaluate(path, ch, entry["from"], cols, consts, n)
        unit = entry.get("unit") or units.get(ch)
        if unit is None and len(sources) == 1 and entry["from"].strip() == sources[0]:
            unit = header_units.get(sources[0])
        si = TIME_CHANNEL.unit if ch == "t" else (registered[ch].unit if ch in registered else None)
        if unit is None:
            if si is None:
                unit = ""
            else:
                raise MeasuredDataError(
                    path, f"column {ch!r} (from {entry['from']!r}) has no unit; give it as '{ch} [{si}]' in the "
                    f"header, '{ch}={entry['from']}[{si}]' in the map or '{ch}={si}' in the units", column=ch)
        if si is None:
            out_units[ch] = unit
            values[ch] = arr
            continue
        gauge_ch = ch in registered and "gauge" in (ch + " " + registered[ch].meaning).lower()
        try:
            conv = conversion(unit, si, column=ch, gauge_channel=gauge_ch, gauge=entry.get("gauge"))
        except UnitError as e:
            raise MeasuredDataError(path, str(e), column=ch) from None
        values[ch] = np.asarray(conv.apply(arr), dtype=np.float64)
        out_units[ch] = si
        if conv.note:
            metadata[f"unit.{ch}"] = conv.note
        if entry["from"].strip() != ch:
            metadata[f"source.{ch}"] = entry["from"].strip()
    order = [c.name for c in table if c.name in values] + [c for c in values if c != "t" and c not in registered]
    return MeasuredData(plant=plant, t=values["t"], channels={c: values[c] for c in order},
                        units={"t": "s", **{c: out_units[c] for c in order}}, metadata=metadata)
