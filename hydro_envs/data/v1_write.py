"""Writing format-v1 measured-data files (CSV and parquet), bit-exact on reading back."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hydro_envs.data.channels import TIME_CHANNEL
from hydro_envs.data.record import MeasuredData, MeasuredDataError
from hydro_envs.data.v1_common import (
    _KEY_RE,
    _META_META,
    _META_UNITS,
    _check_columns,
    _check_values,
    _import_pyarrow,
    _is_parquet,
    _resolve_plant,
)

__all__ = ["write_measured"]


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
