"""Plausibility checks of a measured record against its plant's registry entry.

Every reader path (:func:`hydro_envs.data.load_measured` for every format, and the seal-friction
reader) ends here, before any fit. Each refusal is a :class:`MeasuredDataError` naming the
column, the value, the row and time, what is allowed and the likely cause. Limits (relative to
the plant's declared values, :class:`hydro_envs.spec.PlantSpec`):

* every value finite; time strictly increasing;
* sample time: the median step agrees with the file's ``# sample_rate:`` metadata (within
  :data:`RATE_TOL`) and is at most the plant's ``max_sample_time`` -- a coarser one is most
  likely ms (or us) under an ``[s]`` header;
* sampling: a step differing from the median step by more than ``max_jitter`` (default
  :data:`JITTER_TOL`, relative) is irregular (error); a step above ``max(GAP_FACTOR,
  1 + max_jitter)`` x median is a gap (error unless ``allow_gaps``, which returns the record's
  segments as index ranges; a gap is never interpolated). A plant whose logger has no fixed
  clock (``regular_clock=False``) skips both;
* positions (channels in [m]): max |x| <= :data:`STROKE_FACTOR` x stroke (the params default of
  ``spec.stroke_parameter``, else ``spec.max_stroke``), larger is most likely mm under an [m]
  header;
* pressures (channels in [Pa]): absolute ones > 0, gauge ones > -101325 Pa, all below
  :data:`PRESSURE_FACTOR` x the upper bound of ``spec.pressure_parameter``'s allowed range (or
  ``spec.max_pressure``); a column whose largest absolute pressure is below
  :data:`ABSOLUTE_FLOOR` (or a gauge column whose largest magnitude is below :data:`GAUGE_FLOOR`)
  is in another unit (bar, MPa, kPa, psi: named when the scaled values fit the plant);
* forces [N]: |F| <= ``spec.max_force``, else :data:`PRESSURE_FACTOR` x the pressure bound x the
  largest area parameter's allowed upper bound; velocities [m/s] and accelerations [m/s^2]: at
  most the position bound crossed in one sample (from rest: over one sample squared);
* every other channel: |value| <= :data:`ABSURD` (in its SI unit), or the unit's own bound in
  :data:`UNIT_BOUNDS` (a valve command of 1e3 V is no command).
"""

from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

import numpy as np

from hydro_envs.data.record import MeasuredData, MeasuredDataError
from hydro_envs.data.units import AMBIENT_PRESSURE

__all__ = ["JITTER_TOL", "GAP_FACTOR", "STROKE_FACTOR", "PRESSURE_FACTOR", "RATE_TOL", "ABSOLUTE_FLOOR",
           "GAUGE_FLOOR", "ABSURD", "UNIT_BOUNDS", "check_record", "sample_rate_of"]

JITTER_TOL = 1e-3
GAP_FACTOR = 1.5
STROKE_FACTOR = 5.0
PRESSURE_FACTOR = 2.0
#: relative disagreement allowed between the median step and ``# sample_rate:``
RATE_TOL = 0.01
#: an absolute-pressure column whose largest value is below this [Pa] is not in Pa (half the
#: ambient pressure: no fluid-power chamber stays in such a vacuum for a whole record)
ABSOLUTE_FLOOR = 0.5 * AMBIENT_PRESSURE
#: a gauge-pressure column whose largest magnitude lies in (GAUGE_NOISE, GAUGE_FLOOR) [Pa] is not in
#: Pa (1 kPa = 0.01 bar: a test pressure that low is below a transducer's noise)
GAUGE_FLOOR = 1e3
GAUGE_NOISE = 0.2
#: no value of a fluid-power rig reaches this magnitude in SI units: a wrong unit or a corrupt file
ABSURD = 1e12
#: magnitude bounds per SI unit where they are tighter than ABSURD (assumed: a valve command of
#: 1 kV, a coil current of 1 kA, a shaft speed of 1e5 rad/s (1 M rpm), a valve area of 1 m^2)
UNIT_BOUNDS = {"V": 1e3, "A": 1e3, "rad/s": 1e5, "m^2": 1.0}
#: units a wrong pressure column may be in: (name, Pa per unit)
_PRESSURE_UNITS = (("bar", 1e5), ("MPa", 1e6), ("kPa", 1e3), ("psi", 6894.757293168))


def _param_field(spec: Any, name: str | None):
    if not name or not getattr(spec, "params_class", ""):
        return None
    for f in dataclasses.fields(spec.params_cls):
        if f.name == name:
            return f
    return None


def _at(d: MeasuredData, i: int) -> str:
    return f"row {i + 1} (t = {float(d.t[i]):.6g} s)"


def sample_rate_of(metadata: dict[str, str], path: Any = None) -> float | None:
    """The ``# sample_rate:`` metadata [Hz] (``1000``, ``1000 Hz``, ``1 kHz``), or None without one."""
    raw = metadata.get("sample_rate")
    if raw is None:
        return None
    m = re.fullmatch(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(Hz|kHz)?\s*", str(raw))
    if m is None or not (math.isfinite(float(m.group(1))) and float(m.group(1)) > 0):
        raise MeasuredDataError(path, f"metadata sample_rate = {raw!r}; allowed a number > 0 in Hz "
                                "(e.g. '# sample_rate: 1000')", column="t")
    return float(m.group(1)) * (1e3 if m.group(2) == "kHz" else 1.0)


def _time_hint(ratio: float) -> str:
    for name, k in (("ms", 1e3), ("us", 1e6)):
        if abs(ratio / k - 1.0) < 0.05:
            return f"the times are {k:g} x too large: most likely {name} under an [s] header; declare the unit 't [{name}]'"
    return "check the time unit (declare it, e.g. 't [ms]') and the sample_rate metadata"


def _check_sample_time(d: MeasuredData, spec: Any, h: float, path: Any) -> None:
    fs = sample_rate_of(d.metadata, path)
    if fs is not None and abs(h * fs - 1.0) > RATE_TOL:
        raise MeasuredDataError(
            path, f"column 't': median step {h:.6g} s contradicts the file's '# sample_rate: {d.metadata['sample_rate']}' "
            f"(a step of {1.0 / fs:.6g} s); {_time_hint(h * fs)}", column="t")
    hmax = getattr(spec, "max_sample_time", None)
    if hmax is not None and h > hmax:
        hint = ("most likely ms under an [s] header; declare the unit 't [ms]'" if h * 1e-3 <= hmax
                else "check the time unit (declare it, e.g. 't [ms]')")
        raise MeasuredDataError(
            path, f"column 't': median step {h:.6g} s; allowed at most {hmax:g} s for plant {spec.name!r} (coarser does "
            f"not resolve its dynamics); {hint}", column="t")


def _check_clock(d: MeasuredData, h: float, dt: np.ndarray, allow_gaps: bool, max_jitter: float,
                 path: Any) -> list[tuple[int, int]]:
    t = d.t
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
    return [(bounds[k], bounds[k + 1]) for k in range(len(bounds) - 1)]


def _pressure_hint(name: str, top: float, pmax: float | None, nominal: float | None) -> str:
    """The units that make the column's largest value a plausible pressure of the plant, closest
    (in decades) to its nominal pressure first; those within half a decade of the best are named."""
    fits = []
    for j, (unit, k) in enumerate(_PRESSURE_UNITS):
        v = top * k
        if ABSOLUTE_FLOOR <= v and (pmax is None or v <= pmax):
            fits.append((abs(math.log10(v / nominal)) if nominal else 0.0, j, unit))
    if not fits:
        return "they are not pressures in Pa; declare the column's unit"
    fits.sort()
    names = [u for d, _, u in fits if d <= fits[0][0] + 0.5]
    return f"they look like {' or '.join(names)}, not Pa; declare the unit '{name} [{names[0]}]'"


def _check_pressure(d: MeasuredData, spec: Any, c: Any, v: np.ndarray, pmax: float | None, pwhy: str,
                    nominal: float | None, path: Any) -> None:
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
                                f"physical maximum {pmax:g} Pa ({pwhy}); most likely a wrong unit "
                                "(mbar/kPa given as bar/MPa?)", column=c.name, line=i + 1)
    lo, hi = float(np.min(v)), float(np.max(v))
    top = float(np.max(np.abs(v)))
    if (not gauge and hi < ABSOLUTE_FLOOR) or (gauge and GAUGE_NOISE < top < GAUGE_FLOOR):
        floor = f"a largest absolute pressure of at least {ABSOLUTE_FLOOR:g} Pa" if not gauge else \
            f"a gauge pressure of at least {GAUGE_FLOOR:g} Pa somewhere"
        raise MeasuredDataError(
            path, f"column {c.name!r}: values {lo:.4g}..{hi:.4g} Pa; allowed {floor} (plant {spec.name!r}); "
            f"{_pressure_hint(c.name, top, pmax, nominal)}", column=c.name)


def _bound(d: MeasuredData, c: Any, v: np.ndarray, limit: float, why: str, hint: str, path: Any) -> None:
    i = int(np.argmax(np.abs(v)))
    if not abs(v[i]) <= limit:
        raise MeasuredDataError(path, f"column {c.name!r}, {_at(d, i)}: {c.name} = {float(v[i]):.6g} {c.unit}; allowed "
                                f"|{c.name}| <= {limit:.6g} {c.unit} ({why}); {hint}", column=c.name, line=i + 1)


def _force_limit(spec: Any, pmax: float | None) -> tuple[float | None, str]:
    if getattr(spec, "max_force", None) is not None:
        return float(spec.max_force), f"the largest force of plant {spec.name!r}"
    if pmax is None or not getattr(spec, "params_class", ""):
        return None, ""
    areas = [f.metadata["allowed"][1] for f in dataclasses.fields(spec.params_cls)
             if f.metadata.get("unit") == "m^2" and math.isfinite(f.metadata["allowed"][1])]
    if not areas:
        return None, ""
    return PRESSURE_FACTOR * pmax * max(areas), f"{PRESSURE_FACTOR:g} x the pressure bound on the largest area"


def check_record(d: MeasuredData, spec: Any, *, allow_gaps: bool = False, stroke: float | None = None,
                 max_jitter: float = JITTER_TOL, path: Any = None) -> list[tuple[int, int]]:
    """Check ``d`` against ``spec``; return segments ``[(start, stop), ...]`` (stop exclusive).

    ``max_jitter`` is the accepted relative deviation of a step from the median step; a step
    longer than ``max(GAP_FACTOR, 1 + max_jitter)`` x median is a gap. The timestamps are kept
    as they are (see :meth:`MeasuredData.resample_uniform`).
    """
    if not (max_jitter > 0):
        raise MeasuredDataError(path, f"max_jitter must be > 0, got {max_jitter!r}")
    if stroke is not None and not (math.isfinite(stroke) and stroke > 0):
        raise MeasuredDataError(path, f"stroke = {stroke!r} m; allowed a finite number > 0 m")
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
    _check_sample_time(d, spec, h, path)
    if getattr(spec, "regular_clock", True):
        segments = _check_clock(d, h, dt, allow_gaps, max_jitter, path)
    else:
        segments = [(0, len(t))]

    sf = _param_field(spec, getattr(spec, "stroke_parameter", None))
    L = stroke if stroke is not None else (float(sf.default) if sf is not None else getattr(spec, "max_stroke", None))
    pf = _param_field(spec, getattr(spec, "pressure_parameter", None))
    if pf is not None:
        pmax = PRESSURE_FACTOR * float(pf.metadata["allowed"][1])
        pwhy = f"{PRESSURE_FACTOR:g} x the largest {spec.pressure_parameter}"
        pnom = float(pf.default)
    else:
        pmax, pwhy = getattr(spec, "max_pressure", None), f"the largest pressure of plant {spec.name!r}"
        pnom = None
    fmax, fwhy = _force_limit(spec, pmax)
    for c in spec.channels:
        if c.name not in d:
            continue
        v = d[c.name]
        if c.unit == "m" and L is not None and L > 0:
            i = int(np.argmax(np.abs(v)))
            if abs(v[i]) > STROKE_FACTOR * L:
                raise MeasuredDataError(path, f"column {c.name!r}, {_at(d, i)}: position {float(v[i]):.6g} m is more than "
                                        f"{STROKE_FACTOR:g} x the stroke {L:g} m; most likely mm under an [m] header "
                                        f"(declare the unit '{c.name} [mm]') -- or pass the rig's stroke (--stroke)",
                                        column=c.name, line=i + 1)
        elif c.unit == "Pa":
            _check_pressure(d, spec, c, v, pmax, pwhy, pnom, path)
        elif c.unit == "N" and fmax is not None:
            _bound(d, c, v, fmax, fwhy, "most likely a wrong unit (kN, mN?) or a corrupt file", path)
        elif c.unit == "m/s" and L is not None:
            _bound(d, c, v, STROKE_FACTOR * L / h, f"{STROKE_FACTOR:g} x the stroke {L:g} m crossed in one sample of "
                   f"{h:.3g} s", "most likely a wrong unit (mm/s?)", path)
        elif c.unit == "m/s^2" and L is not None:
            _bound(d, c, v, STROKE_FACTOR * L / h**2, f"{STROKE_FACTOR:g} x the stroke {L:g} m crossed from rest in "
                   f"one sample of {h:.3g} s", "most likely a wrong unit (mm/s^2?)", path)
        if c.unit != "m" and c.unit != "Pa":
            _bound(d, c, v, UNIT_BOUNDS.get(c.unit, ABSURD), "no rig reaches more", "a wrong unit or a corrupt file", path)
    return segments
