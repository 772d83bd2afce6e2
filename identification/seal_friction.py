"""Measured seal friction (CC0, ``EvaZillen/3D-printed-pneumatic-actuator``): load and extract.

:func:`load_seal_friction` reads the original whitespace format of the published X-ring strokes
or a measured-data CSV of plant ``seal_friction`` (see its docstring);
:func:`seal_friction_points` turns the strokes into constant-velocity friction points.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from hydro_envs.data.measured import MeasuredData, MeasuredDataError, load_measured
from identification.constant_velocity import constant_velocity_points
from identification.friction import FrictionPoints

__all__ = ["SEAL_FRICTION_PLANT", "SEAL_BORE", "load_seal_friction", "seal_friction_points"]


SEAL_FRICTION_PLANT = "seal_friction"
#: X-ring test cylinder bore [m] (data README: "Bore 25.7 mm for these X-ring files")
SEAL_BORE = 0.0257

_RAW_COLUMNS = ("time [ms]", "laser signal [V]", "pressure signal [V]", "force signal [V]",
                "displacement [mm]", "pressure [bar gauge]", "load-cell force [N]")
_RAW_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


def _parse_raw_seal(path: Path, text: str) -> tuple[np.ndarray, list[int]]:
    rows = []
    linenos = []
    for k, ln in enumerate(text.splitlines()):
        s = ln.strip()
        if not s:
            continue
        cells = s.split()
        if len(cells) != 7:
            raise MeasuredDataError(
                path,
                f"line {k + 1}: has {len(cells)} whitespace-separated values, expected 7 "
                f"({', '.join(_RAW_COLUMNS)})",
                line=k + 1,
            )
        row = []
        for j, c in enumerate(cells):
            if not _RAW_NUMBER.fullmatch(c):
                raise MeasuredDataError(
                    path, f"line {k + 1}, column {j + 1} ({_RAW_COLUMNS[j]}): {c!r} is not a "
                    "finite decimal number", line=k + 1, column=_RAW_COLUMNS[j])
            row.append(float(c))
        rows.append(row)
        linenos.append(k + 1)
    return np.array(rows, dtype=float).reshape(-1, 7), linenos


def load_seal_friction(
    path: str | os.PathLike[str],
    *,
    bore: float | None = SEAL_BORE,
    drop_rows: int = 15,
    stroke: float | None = None,
    check: bool = True,
) -> MeasuredData:
    """Load a seal-friction record as plant ``seal_friction`` (channels ``x, p_gauge, F_load``, SI).

    Two formats are accepted:

    * the original files (whitespace-separated, no header, about 100 Hz, seven columns: time
      [ms], laser / pressure / force sensor signals [V], displacement [mm], chamber pressure
      [bar, gauge], load-cell force [N]; see ``tests/data/pneumatic_seal_friction/README.md``).
      The first ``drop_rows`` rows are dropped, as in the original analysis; time is converted
      to s (starting at the first kept row's time), mm to m, bar to Pa. The raw sensor voltages
      are not kept.
    * a measured-data CSV (:mod:`hydro_envs.data.measured`) with ``# plant: seal_friction``.

    The format is recognised by the first non-blank character (``#`` or a letter: measured-data
    CSV; a digit or sign: original). Malformed files raise
    :class:`~hydro_envs.data.measured.MeasuredDataError` naming file, line and column. The
    piston area ``pi bore^2 / 4`` is stored as ``metadata["piston_area"]`` (CSV files may carry
    their own). ``bore=None``: no geometry is assumed; an original-format file then carries no
    ``piston_area`` and :func:`seal_friction_points` needs ``piston_area``.

    The logger's clock is irregular (10-17 ms steps, pauses); the record is kept as sampled --
    the stroke analysis (:func:`seal_friction_points`) fits each window on its own time stamps
    and needs no uniform clock. Either format is then checked against the plant's registry entry
    (:func:`hydro_envs.data.checks.check_record`: positions against ``stroke`` [m], else the
    bench's bound; pressures, forces, the median step; ``check=False`` skips it).
    """
    p = Path(path)
    if not p.is_file():
        raise MeasuredDataError(p, "file not found")
    if bore is not None and not (math.isfinite(bore) and bore > 0):
        raise ValueError(f"bore = {bore!r} m; allowed: a finite value > 0 m")
    raw = p.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasuredDataError(p, f"not valid UTF-8 (byte offset {e.start})") from None
    first = text.lstrip()[:1]
    if not first:
        raise MeasuredDataError(p, "file is empty")
    area = None if bore is None else math.pi * bore**2 / 4.0
    if first == "#" or first.isalpha():
        data = load_measured(p, plant=SEAL_FRICTION_PLANT, check=False)
        if area is not None:
            data.metadata.setdefault("piston_area", repr(area))
        return _checked(data, p, stroke, check)
    arr, linenos = _parse_raw_seal(p, text)
    if drop_rows < 0:
        raise ValueError(f"drop_rows must be >= 0, got {drop_rows}")
    arr = arr[drop_rows:]
    linenos = linenos[drop_rows:]
    if arr.shape[0] < 2:
        raise MeasuredDataError(p, f"has {arr.shape[0]} data row(s) after dropping {drop_rows}; "
                                "at least 2 are needed")
    t_ms = arr[:, 0]
    bad = np.flatnonzero(~(np.diff(t_ms) > 0))
    if bad.size:
        i = int(bad[0]) + 1
        raise MeasuredDataError(
            p, f"line {linenos[i]}, column 1 (time [ms]): time {t_ms[i]!r} is not greater than "
            f"{t_ms[i - 1]!r} on line {linenos[i - 1]}; time must be strictly increasing",
            line=linenos[i], column="time [ms]")
    t = (t_ms - t_ms[0]) * 1e-3
    return _checked(MeasuredData(
        plant=SEAL_FRICTION_PLANT,
        t=t,
        channels={"x": arr[:, 4] * 1e-3, "p_gauge": arr[:, 5] * 1e5, "F_load": arr[:, 6]},
        units={"t": "s", "x": "m", "p_gauge": "Pa", "F_load": "N"},
        metadata={
            "source": f"{p.name}: EvaZillen/3D-printed-pneumatic-actuator, "
                      "results_pneumatic-actuator/data/friction (CC0 1.0)",
            "license": "CC0-1.0",
            "dropped_rows": str(drop_rows),
            "t0_ms": repr(float(t_ms[0])),
            **({} if bore is None else {"bore": repr(bore), "piston_area": repr(area)}),
        },
    ), p, stroke, check)


def _checked(data: MeasuredData, path: Path, stroke: float | None, check: bool) -> MeasuredData:
    """``data`` after the registry's plausibility checks of a seal-friction record."""
    if check:
        from hydro_envs import registry
        from hydro_envs.data.checks import check_record

        check_record(data, registry.get(SEAL_FRICTION_PLANT), stroke=stroke, max_jitter=math.inf, path=path)
    return data


def seal_friction_points(
    data: MeasuredData,
    *,
    piston_area: float | None = None,
    smooth_time: float = 0.3,
    min_duration: float = 0.5,
    rel_tol: float = 0.25,
    trim: float = 0.15,
) -> FrictionPoints:
    """One friction point per constant-speed stroke of a seal-friction record.

    Friction ``F_f = F_load - p_gauge A`` -- the README's ``p A - F_loadcell`` with the sign
    flipped so that it follows the direction of ``v = dx/dt`` of the displacement column
    (friction opposes the motion: ``F_f v > 0``, checked in the tests). The windows are the
    steady parts of each stroke (:func:`~identification.constant_velocity.steady_windows` on the Savitzky-Golay velocity over
    ``smooth_time``); velocity = slope of the positions, pressure = mean ``p_gauge``;
    ``group`` numbers the strokes.
    """
    for ch in ("x", "p_gauge", "F_load"):
        if ch not in data:
            raise MeasuredDataError(None, f"seal-friction data need channel {ch!r}", column=ch)
    if piston_area is None:
        if "piston_area" not in data.metadata:
            raise ValueError("piston_area is unknown: the record carries no 'piston_area' "
                             "(give the bore or the piston area)")
        piston_area = float(data.metadata["piston_area"])
    f = data["F_load"] - data["p_gauge"] * piston_area
    pts = constant_velocity_points(
        data.t, f, x=data["x"], pressure=data["p_gauge"], smooth_time=smooth_time,
        min_duration=min_duration, rel_tol=rel_tol, trim=trim,
    )
    pts.meta = {"piston_area": piston_area, "source": data.metadata.get("source", "")}
    return pts


