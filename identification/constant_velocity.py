"""Friction points from constant-velocity tests: steady windows of a record, averaged.

* :func:`friction_points_from_square_wave`: 002 sec. 4 -- in each half-period of a square-wave
  command the velocity and the chamber pressures are averaged after the transient and
  ``F_f = A (P1 - P2)`` (eqs (9)-(10)).
* :func:`constant_velocity_test`, plant-agnostic (004 sec. 3.2): for each valve command a
  caller-supplied ``simulate(command)`` returns time series (time, position or velocity, and
  force or chamber pressures); steady windows are found automatically (:func:`steady_windows`)
  and ``F_f = A_a p_a - A_b p_b`` (004 eq (1)) averaged.

Both return :class:`~identification.friction.FrictionPoints` for the static friction fits.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy import signal

from hydro_envs.data.measured import MeasuredData, MeasuredDataError
from identification.friction import FrictionPoints, InsufficientDataError, chamber_force

__all__ = [
    "friction_points_from_square_wave",
    "smoothed_velocity",
    "steady_windows",
    "constant_velocity_points",
    "constant_velocity_test",
]


def _runs_of_constant(u: np.ndarray, tol: float) -> list[tuple[int, int]]:
    """Index ranges ``[i0, i1)`` where ``u`` stays within ``tol`` of its first value."""
    runs = []
    i0 = 0
    n = u.size
    for i in range(1, n + 1):
        if i == n or abs(u[i] - u[i0]) > tol:
            runs.append((i0, i))
            i0 = i
    return runs


def friction_points_from_square_wave(
    data: MeasuredData,
    area: float | None = None,
    *,
    settle_time: float = 0.05,
    window_fraction: float = 0.5,
    command_tol: float = 1e-9,
    min_samples: int = 10,
    correct_inertia: float | None = None,
    area_2: float | None = None,
    ambient_pressure: float = 0.0,
) -> FrictionPoints:
    """Constant-velocity points of a square-wave test (002 sec. 4 algorithm).

    ``area_2`` [m^2]: a differential cylinder's rod-side (annulus) area; the force is then
    ``area (p1 - p_amb) - area_2 (p2 - p_amb)`` with ``ambient_pressure`` p_amb [Pa] (absolute
    pressures: the ambient pressure acts on the rod's end face ``area - area_2``), instead of
    ``area (p1 - p2)`` of an equal-area cylinder.

    Segments are the runs of constant nonzero command ``u``. In each, the window is the last
    ``window_fraction`` of the segment, starting at least ``settle_time`` after the switch
    ("after the transients, set the average ... over a given time period"). Velocity = slope of
    a least-squares line through the position samples of the window (robust to encoder
    quantisation); force = ``A * mean(p1 - p2)`` (eq (10)); pressure = mean of
    ``(p1 + p2) / 2``; ``force_std`` = standard deviation of the force samples.
    ``correct_inertia`` = mass [kg] subtracts ``m a`` with ``a`` from a quadratic fit (zero in
    a truly steady window). ``area`` defaults to the file's ``piston_area`` metadata.
    """
    for ch in ("u", "x", "p1", "p2"):
        if ch not in data:
            raise MeasuredDataError(None, f"square-wave friction data need channel {ch!r}; "
                                    f"the data have t, {', '.join(data.names)}", column=ch)
    if area is None:
        if "piston_area" not in data.metadata:
            raise ValueError("area is required (no 'piston_area' in the data's metadata)")
        area = float(data.metadata["piston_area"])
    if not (0.0 < window_fraction <= 1.0):
        raise ValueError(f"window_fraction must be in (0, 1], got {window_fraction}")
    t, u, x = data.t, data["u"], data["x"]
    if area_2 is not None and not (0.0 < area_2 < area):
        raise ValueError(f"area_2 = {area_2} m^2; allowed 0 < area_2 < area = {area} m^2")
    if area_2 is None:
        dp = data["p1"] - data["p2"]
    else:  # force per cap-side area: (A1 (p1 - p_amb) - A2 (p2 - p_amb)) / A1
        dp = (data["p1"] - ambient_pressure) - area_2 / area * (data["p2"] - ambient_pressure)
    pm = 0.5 * (data["p1"] + data["p2"])
    rows: dict[str, list[float]] = {k: [] for k in
                                    ("v", "f", "p", "fs", "n", "t0", "t1", "c")}
    for i0, i1 in _runs_of_constant(u, command_tol):
        if u[i0] == 0.0:
            continue
        seg_t0, seg_t1 = t[i0], t[i1 - 1]
        w0 = max(seg_t0 + settle_time, seg_t1 - window_fraction * (seg_t1 - seg_t0))
        sel = np.flatnonzero((t >= w0) & (t <= seg_t1))
        sel = sel[(sel >= i0) & (sel < i1)]
        if sel.size < max(min_samples, 3):
            continue
        tt = t[sel] - t[sel].mean()
        v = float(np.polyfit(tt, x[sel], 1)[0])
        force = area * dp[sel]
        f_mean = float(force.mean())
        if correct_inertia is not None:
            acc = 2.0 * float(np.polyfit(tt, x[sel], 2)[0])
            f_mean -= correct_inertia * acc
        rows["v"].append(v)
        rows["f"].append(f_mean)
        rows["p"].append(float(pm[sel].mean()))
        rows["fs"].append(float(force.std()))
        rows["n"].append(sel.size)
        rows["t0"].append(float(t[sel[0]]))
        rows["t1"].append(float(t[sel[-1]]))
        rows["c"].append(float(u[i0]))
    if not rows["v"]:
        raise InsufficientDataError(
            "no constant-command segment long enough for a steady window "
            f"(settle_time {settle_time} s, min_samples {min_samples})"
        )
    return FrictionPoints(
        v=rows["v"], force=rows["f"], pressure=rows["p"], force_std=rows["fs"],
        n_samples=rows["n"], t_start=rows["t0"], t_end=rows["t1"], command=rows["c"],
        group=np.arange(len(rows["v"])), meta={"area": area, "area_2": area_2, "source": "002 sec. 4 square wave"},
    )


def smoothed_velocity(t: np.ndarray, x: np.ndarray, smooth_time: float) -> np.ndarray:
    """Velocity from positions: Savitzky-Golay derivative (quadratic) over ``smooth_time``."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    dt = float(np.median(np.diff(t)))
    n = max(5, int(round(smooth_time / dt)) | 1)
    if n > x.size:
        n = x.size if x.size % 2 else x.size - 1
    if n < 3:
        return np.gradient(x, t)
    # resample-free: savgol assumes uniform steps; records with gaps use np.gradient on the
    # smoothed position instead
    if np.max(np.diff(t)) > 1.5 * dt:
        xs = signal.savgol_filter(x, n, 2)
        return np.gradient(xs, t)
    return signal.savgol_filter(x, n, 2, deriv=1, delta=dt)


def steady_windows(
    t: Any,
    v: Any,
    *,
    min_duration: float = 0.2,
    rel_tol: float = 0.15,
    abs_tol: float = 0.0,
    v_min: float | None = None,
    trim: float = 0.1,
) -> list[tuple[int, int]]:
    """Index ranges ``[i0, i1)`` where the (smoothed) velocity is steady.

    The record is split into runs of one direction with ``|v| > v_min`` (default 5 % of
    ``max |v|``); in each run, samples within ``max(abs_tol, rel_tol |median|)`` of the run's
    median velocity form candidate windows; the longest is kept if it lasts at least
    ``min_duration`` seconds, then ``trim`` of its length is cut at both ends (transients).
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.shape != v.shape or t.ndim != 1:
        raise ValueError("t and v must be 1-D of equal length")
    if not (0.0 <= trim < 0.5):
        raise ValueError(f"trim must be in [0, 0.5), got {trim}")
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    if vmax == 0.0:
        return []
    thr = 0.05 * vmax if v_min is None else float(v_min)
    sgn = np.where(v > thr, 1, np.where(v < -thr, -1, 0))
    out: list[tuple[int, int]] = []
    i = 0
    n = v.size
    while i < n:
        if sgn[i] == 0:
            i += 1
            continue
        j = i
        while j < n and sgn[j] == sgn[i]:
            j += 1
        med = float(np.median(v[i:j]))
        ok = np.abs(v[i:j] - med) <= max(abs_tol, rel_tol * abs(med))
        best = None
        k = 0
        while k < ok.size:
            if not ok[k]:
                k += 1
                continue
            m = k
            while m < ok.size and ok[m]:
                m += 1
            if best is None or (m - k) > (best[1] - best[0]):
                best = (k, m)
            k = m
        if best is not None:
            a, b = i + best[0], i + best[1]
            if t[b - 1] - t[a] >= min_duration:
                cut = int(trim * (b - a))
                if b - cut - (a + cut) >= 3:
                    out.append((a + cut, b - cut))
        i = j
    return out


def constant_velocity_points(
    t: Any,
    force: Any,
    *,
    x: Any = None,
    v: Any = None,
    pressure: Any = None,
    smooth_time: float = 0.1,
    min_duration: float = 0.2,
    rel_tol: float = 0.15,
    abs_tol: float = 0.0,
    v_min: float | None = None,
    trim: float = 0.1,
    windows: Sequence[tuple[int, int]] | None = None,
) -> FrictionPoints:
    """Average force (and pressure) over steady-velocity windows of a record (004 sec. 3.2).

    Give the position ``x`` (preferred: the window velocity is then the slope of a line
    through the positions, immune to differentiation noise) or the velocity ``v``. Windows come
    from :func:`steady_windows` on ``v`` (or on the Savitzky-Golay velocity of ``x`` over
    ``smooth_time``) unless passed in. ``group`` numbers the windows in time order.
    """
    t = np.asarray(t, dtype=float)
    f = np.asarray(force, dtype=float)
    if x is None and v is None:
        raise ValueError("give the position x or the velocity v")
    if f.shape != t.shape:
        raise ValueError(f"force has shape {f.shape}, expected {t.shape}")
    xa = None if x is None else np.asarray(x, dtype=float)
    va = np.asarray(v, dtype=float) if v is not None else smoothed_velocity(t, xa, smooth_time)
    pa = None if pressure is None else np.asarray(pressure, dtype=float)
    if windows is None:
        windows = steady_windows(t, va, min_duration=min_duration, rel_tol=rel_tol,
                                 abs_tol=abs_tol, v_min=v_min, trim=trim)
    rows: dict[str, list[float]] = {k: [] for k in ("v", "f", "p", "fs", "n", "t0", "t1")}
    for i0, i1 in windows:
        sl = slice(i0, i1)
        if xa is not None:
            tt = t[sl] - t[sl].mean()
            vel = float(np.polyfit(tt, xa[sl], 1)[0])
        else:
            vel = float(va[sl].mean())
        rows["v"].append(vel)
        rows["f"].append(float(f[sl].mean()))
        rows["p"].append(float(pa[sl].mean()) if pa is not None else 0.0)
        rows["fs"].append(float(f[sl].std()))
        rows["n"].append(i1 - i0)
        rows["t0"].append(float(t[i0]))
        rows["t1"].append(float(t[i1 - 1]))
    if not rows["v"]:
        raise InsufficientDataError(
            f"no steady-velocity window of at least {min_duration} s found "
            f"(rel_tol {rel_tol}, smooth_time {smooth_time} s)"
        )
    return FrictionPoints(
        v=rows["v"], force=rows["f"], pressure=rows["p"] if pa is not None else None,
        force_std=rows["fs"], n_samples=rows["n"], t_start=rows["t0"], t_end=rows["t1"],
        group=np.arange(len(rows["v"])),
    )


def constant_velocity_test(
    simulate: Callable[[float], Mapping[str, Any]],
    commands: Sequence[float],
    *,
    area_a: float | None = None,
    area_b: float | None = None,
    settle_time: float = 0.0,
    min_duration: float = 0.2,
    rel_tol: float = 0.15,
    smooth_time: float = 0.05,
) -> FrictionPoints:
    """The constant-velocity friction test of 004 sec. 3.2 for any plant.

    For each valve command ``c`` in ``commands``, ``simulate(c)`` runs the plant (or the rig)
    with that command held and returns a mapping with ``"t"`` [s], ``"x"`` [m] or ``"v"`` [m/s],
    and either ``"force"`` [N] (the friction-balancing force) or ``"pa"``, ``"pb"`` [Pa] chamber
    pressures, turned into ``F_f = A_a p_a - A_b p_b`` (004 eq (1); ``area_b`` defaults to
    ``area_a``); an optional ``"pressure"`` entry is averaged too. Samples before
    ``settle_time`` are ignored; the longest steady window (:func:`steady_windows`) gives one
    point per command. Commands whose run never reaches a steady velocity are skipped; if none
    does, :class:`InsufficientDataError` is raised.
    """
    parts = []
    skipped = []
    for c in commands:
        rec = simulate(float(c))
        if "t" not in rec:
            raise KeyError("simulate() must return a mapping with 't'")
        t = np.asarray(rec["t"], dtype=float)
        if "force" in rec:
            f = np.asarray(rec["force"], dtype=float)
        elif "pa" in rec and "pb" in rec:
            if area_a is None:
                raise ValueError("area_a is required when simulate() returns pressures")
            f = chamber_force(rec["pa"], rec["pb"], area_a, area_a if area_b is None else area_b)
        else:
            raise KeyError("simulate() must return 'force' or both 'pa' and 'pb'")
        keep = t >= t[0] + settle_time
        kw: dict[str, Any] = {}
        for key in ("x", "v", "pressure"):
            if key in rec:
                kw[key] = np.asarray(rec[key], dtype=float)[keep]
        try:
            pts = constant_velocity_points(t[keep], f[keep], smooth_time=smooth_time,
                                           min_duration=min_duration, rel_tol=rel_tol, **kw)
        except InsufficientDataError:
            skipped.append(c)
            continue
        best = int(np.argmax(pts.n_samples))
        one = pts.select([best])
        one.command = np.array([float(c)])
        parts.append(one)
    if not parts:
        raise InsufficientDataError(
            f"no command reached a steady velocity (commands {list(commands)}); lengthen the "
            "runs or relax rel_tol"
        )
    out = FrictionPoints.concatenate(parts)
    out.group = np.arange(len(out))
    out.meta = {"source": "004 sec. 3.2 constant-velocity test", "skipped_commands": skipped}
    return out
