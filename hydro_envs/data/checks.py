"""Plausibility checks of a measured record against its plant's registry entry.

Run before any fit. Each refusal is a :class:`MeasuredDataError` naming the column, the value,
the row and time, and the likely cause. Limits (all relative to the plant's declared values):

* every value finite; time strictly increasing;
* sampling: a step differing from the median step by more than ``max_jitter`` (default
  :data:`JITTER_TOL`, relative) is irregular (error); a step above ``max(GAP_FACTOR,
  1 + max_jitter)`` x median is a gap (error unless ``allow_gaps``, which returns the record's
  segments as index ranges; a gap is never interpolated);
* positions (channels in [m]): max |x| <= :data:`STROKE_FACTOR` x stroke (the params default
  of ``spec.stroke_parameter``), larger is most likely mm under an [m] header;
* pressures (channels in [Pa]): absolute ones > 0, gauge ones > -101325 Pa, and all below
  :data:`PRESSURE_FACTOR` x the upper bound of ``spec.pressure_parameter``'s allowed range.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from hydro_envs.data.record import MeasuredData, MeasuredDataError
from hydro_envs.data.units import AMBIENT_PRESSURE

__all__ = ["JITTER_TOL", "GAP_FACTOR", "STROKE_FACTOR", "PRESSURE_FACTOR", "check_record"]

JITTER_TOL = 1e-3
GAP_FACTOR = 1.5
STROKE_FACTOR = 5.0
PRESSURE_FACTOR = 2.0


def _param_field(spec: Any, name: str | None):
    if not name or not getattr(spec, "params_class", ""):
        return None
    for f in dataclasses.fields(spec.params_cls):
        if f.name == name:
            return f
    return None


def _at(d: MeasuredData, i: int) -> str:
    return f"row {i + 1} (t = {float(d.t[i]):.6g} s)"


def check_record(d: MeasuredData, spec: Any, *, allow_gaps: bool = False, stroke: float | None = None,
                 max_jitter: float = JITTER_TOL, path: Any = None) -> list[tuple[int, int]]:
    """Check ``d`` against ``spec``; return segments ``[(start, stop), ...]`` (stop exclusive).

    ``max_jitter`` is the accepted relative deviation of a step from the median step; a step
    longer than ``max(GAP_FACTOR, 1 + max_jitter)`` x median is a gap. The timestamps are kept
    as they are (see :meth:`MeasuredData.resample_uniform`).
    """
    if not (max_jitter > 0):
        raise MeasuredDataError(path, f"max_jitter must be > 0, got {max_jitter!r}")
    for name in ("t", *d.names):
        v = d[name]
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            i = int(bad[0])
            raise MeasuredDataError(path, f"column {name!r}, row {i + 1}: value {float(v[i])!r} is not finite "
                                    "(a logger dropout or an empty cell)", column=name, line=i + 1)
    t = d.t
    if len(t) < 2:
        raise MeasuredDataError(path, f"has {len(t)} sample(s); at least 2 are needed", column="t")
    dt = np.diff(t)
    bad = np.flatnonzero(~(dt > 0))
    if bad.size:
        i = int(bad[0]) + 1
        raise MeasuredDataError(path, f"column 't', {_at(d, i)}: time is not strictly increasing (previous t = "
                                f"{float(t[i - 1]):.6g} s); records appended or a clock reset?", column="t", line=i + 1)
    h = float(np.median(dt))
    gap_factor = max(GAP_FACTOR, 1.0 + max_jitter)
    gaps = np.flatnonzero(dt > gap_factor * h)
    rel = np.abs(dt - h) / h
    rel[gaps] = 0.0
    j = int(np.argmax(rel))
    if rel[j] > max_jitter:
        raise MeasuredDataError(path, f"column 't', {_at(d, j + 1)}: step {float(dt[j]):.6g} s differs from the median "
                                f"step {h:.6g} s by {rel[j]:.2g} (relative), more than {max_jitter:g}; the sampling is "
                                "irregular (wrong time unit or a logger without a fixed clock? a larger max_jitter "
                                "accepts it with the actual timestamps)", column="t", line=j + 2)
    if gaps.size and not allow_gaps:
        g = int(gaps[0])
        raise MeasuredDataError(path, f"column 't', {_at(d, g + 1)}: gap of {float(dt[g]):.6g} s after t = {float(t[g]):.6g} s "
                                f"(more than {gap_factor:g} x the median step {h:.6g} s; {gaps.size} gap(s) in all); pass allow_gaps=True (--allow-gaps) "
                                "to split the record into segments -- it is never interpolated", column="t", line=g + 2)
    bounds = [0, *(int(g) + 1 for g in gaps), len(t)]
    segments = [(bounds[k], bounds[k + 1]) for k in range(len(bounds) - 1)]

    sf = _param_field(spec, getattr(spec, "stroke_parameter", None))
    L = stroke if stroke is not None else (None if sf is None else float(sf.default))
    pf = _param_field(spec, getattr(spec, "pressure_parameter", None))
    pmax = None if pf is None else PRESSURE_FACTOR * float(pf.metadata["allowed"][1])
    for c in spec.channels:
        if c.name not in d:
            continue
        v = d[c.name]
        if c.unit == "m" and L is not None and L > 0:
            i = int(np.argmax(np.abs(v)))
            if abs(v[i]) > STROKE_FACTOR * L:
                raise MeasuredDataError(path, f"column {c.name!r}, {_at(d, i)}: position {float(v[i]):.6g} m is more than "
                                        f"{STROKE_FACTOR:g} x the stroke {L:g} m; most likely mm under an [m] header "
                                        "(give the unit as [mm]) -- or pass the rig's stroke", column=c.name, line=i + 1)
        if c.unit == "Pa":
            gauge = "gauge" in (c.name + " " + c.meaning).lower()
            low = -AMBIENT_PRESSURE if gauge else 0.0
            i = int(np.argmin(v))
            if not v[i] > low:
                what = "gauge pressure below vacuum" if gauge else "absolute pressure not above 0"
                raise MeasuredDataError(path, f"column {c.name!r}, {_at(d, i)}: {what}: {float(v[i]):.6g} Pa; most likely a "
                                        "gauge reading in an absolute channel (give the unit as bar(g)/barg or gauge: true) "
                                        "or an offset sensor", column=c.name, line=i + 1)
            i = int(np.argmax(v))
            if pmax is not None and v[i] > pmax:
                raise MeasuredDataError(path, f"column {c.name!r}, {_at(d, i)}: pressure {float(v[i]):.6g} Pa is above the "
                                        f"physical maximum {pmax:g} Pa ({PRESSURE_FACTOR:g} x the largest "
                                        f"{spec.pressure_parameter}); most likely a wrong unit (mbar/kPa given as bar/MPa?)",
                                        column=c.name, line=i + 1)
    return segments
