r"""Friction metrics of one tracking episode: reversal error, steady-state error, limit cycles, stick.

Pure functions of sampled signals (``y`` output, ``r`` reference, both at a fixed step ``dt``;
sample ``k`` of both belongs to the same instant). The tracking error is ``e = r - y``.

* **Moving reference**: sample ``k >= 1`` with ``r[k] != r[k-1]`` inside a run of at least
  ``min_run`` such samples. A lone jump of a step reference (a run of one sample) is not a
  movement, so steps do not count as reversals or as time the reference moves.
* **Reversal** (:func:`reversal_indices`): a sample where the direction of the moving
  reference changes, ``sgn(r[k] - r[k-1]) != sgn`` of the previous moving sample -- the
  velocity sign change at which friction flips sign (the quadrant glitch of machine tools).
* **Reversal error** (:func:`reversal_error`): mean over reversals of ``max |e|`` within
  ``window`` seconds from the reversal.
* **Hold** (:func:`holds`): a run of constant reference of at least ``min_hold`` seconds
  (the level of a step or micro-step reference).
* **Hold window**: the last ``tail`` fraction of a hold, ending ``guard`` seconds before the hold
  ends (:data:`PREVIEW_GUARD`, 60 ms: the observation previews the reference 10-50 ms ahead, so a
  controller may start the next step early; that anticipation is not an error of the hold).
* **Steady-state error** (:func:`steady_state_error`): mean over holds of ``mean |e|`` over the
  hold window.
* **Limit-cycle amplitude** (:func:`limit_cycle_amplitude`): mean over holds of the
  peak-to-peak ``max e - min e`` over the hold window (hunting under integral action leaves a
  nonzero value; a plant at rest leaves zero).
* **Hunting** (:func:`hunting`): the limit-cycle amplitude over the holds of at least
  ``min_hold`` = :data:`HUNTING_HOLD` (2 s) only: a loop with integral action against
  stick-slip friction hunts with periods of a second or more, which a short hold cannot show.
* **Reversal excess** (the benchmark's ``reversal_excess``): the reversal error less that of the
  same controller on the same episode of the plant without dry friction -- the part of the
  reversal error friction makes, with the loop's lag removed.
* **Stick time** (:func:`stick_time`): fraction of the moving-reference samples at which the
  reference speed is above ``v_tol`` and the plant speed ``|y[k] - y[k-1]| / dt`` is not,
  with ``v_tol = stick_frac * max |reference speed|``.

Each function returns NaN when the episode has nothing to measure (no reversal, no hold, a
reference that never moves), so a mean over episodes can skip it.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "MIN_HOLD",
    "MIN_RUN",
    "REVERSAL_WINDOW",
    "STICK_FRAC",
    "TAIL",
    "holds",
    "limit_cycle_amplitude",
    "hunting",
    "HUNTING_HOLD",
    "PREVIEW_GUARD",
    "moving_mask",
    "reversal_error",
    "reversal_indices",
    "steady_state_error",
    "stick_time",
]

#: seconds after a reversal searched for the peak error (the glitch of a PID-controlled axis
#: lasts about one integral time; 0.2 s spans it for the 2-20 Hz loops of the suite's plants)
REVERSAL_WINDOW = 0.2
#: consecutive changing samples that make a movement (a step's jump is one sample)
MIN_RUN = 3
#: shortest hold [s] (the micro-step references hold 0.3-0.8 s)
MIN_HOLD = 0.1
#: last fraction of each hold used for the steady-state error and the limit cycle
TAIL = 0.5
#: plant/reference speed below this fraction of the peak reference speed counts as at rest
STICK_FRAC = 0.05
#: seconds at the end of each hold left out of its window (the 10-50 ms reference preview)
PREVIEW_GUARD = 0.06
#: shortest hold [s] that counts for the hunting metric
HUNTING_HOLD = 2.0


def _check(y: np.ndarray | None, r: np.ndarray, dt: float) -> tuple[np.ndarray | None, np.ndarray]:
    r = np.asarray(r, dtype=float).reshape(-1)
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt = {dt!r}; must be > 0 [s]")
    if y is None:
        return None, r
    y = np.asarray(y, dtype=float).reshape(-1)
    if y.shape != r.shape:
        raise ValueError(f"y has {y.size} samples, r has {r.size}; they must be equal")
    return y, r


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[(start, end)]`` of the runs of True in ``mask`` (end exclusive)."""
    m = np.r_[False, np.asarray(mask, dtype=bool), False].astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def moving_mask(r: np.ndarray, min_run: int = MIN_RUN) -> np.ndarray:
    """Samples at which the reference moves (``r[k] != r[k-1]`` in a run of ``>= min_run``)."""
    r = np.asarray(r, dtype=float).reshape(-1)
    if min_run < 1:
        raise ValueError(f"min_run = {min_run!r}; must be >= 1")
    change = np.r_[False, np.diff(r) != 0.0]
    out = np.zeros(r.size, dtype=bool)
    for a, b in _runs(change):
        if b - a >= min_run:
            out[a:b] = True
    return out


def reversal_indices(r: np.ndarray, min_run: int = MIN_RUN) -> np.ndarray:
    """Samples at which the moving reference changes direction (see the module docstring)."""
    r = np.asarray(r, dtype=float).reshape(-1)
    mov = np.flatnonzero(moving_mask(r, min_run))
    if mov.size < 2:
        return np.zeros(0, dtype=int)
    s = np.sign(r[mov] - r[mov - 1])
    return mov[1:][s[1:] != s[:-1]]


def reversal_error(y: np.ndarray, r: np.ndarray, dt: float, window: float = REVERSAL_WINDOW,
                   min_run: int = MIN_RUN) -> float:
    """Mean over reversals of the peak ``|r - y|`` within ``window`` [s] from each reversal."""
    y, r = _check(y, r, dt)
    if not (np.isfinite(window) and window > 0):
        raise ValueError(f"window = {window!r}; must be > 0 [s]")
    idx = reversal_indices(r, min_run)
    if idx.size == 0:
        return float("nan")
    e = np.abs(r - y)
    w = max(1, int(round(window / dt)))
    return float(np.mean([np.max(e[k : k + w]) for k in idx]))


def holds(r: np.ndarray, dt: float, min_hold: float = MIN_HOLD) -> list[tuple[int, int]]:
    """``[(start, end)]`` (end exclusive) of the runs of constant reference of ``>= min_hold`` s.

    A hold starts at the first sample of the new level (the sample of the jump)."""
    _, r = _check(None, r, dt)
    if not (np.isfinite(min_hold) and min_hold > 0):
        raise ValueError(f"min_hold = {min_hold!r}; must be > 0 [s]")
    if r.size == 0:
        return []
    same = np.r_[True, np.diff(r) == 0.0]  # sample k has the level of sample k - 1
    starts = np.r_[0, np.flatnonzero(~same)]
    ends = np.r_[starts[1:], r.size]
    n_min = max(2, int(round(min_hold / dt)))
    return [(int(a), int(b)) for a, b in zip(starts, ends) if b - a >= n_min]


def _hold_tails(y: np.ndarray, r: np.ndarray, dt: float, tail: float, min_hold: float,
                guard: float) -> list[np.ndarray]:
    if not (0.0 < tail <= 1.0):
        raise ValueError(f"tail = {tail!r}; allowed (0, 1]")
    if not (np.isfinite(guard) and guard >= 0):
        raise ValueError(f"guard = {guard!r}; must be >= 0 [s]")
    g = int(round(guard / dt))
    out = []
    for a, b in holds(r, dt, min_hold):
        end = b - g
        if end - a < 2:
            continue
        k = max(1, int(round(tail * (end - a))))
        out.append(r[end - k : end] - y[end - k : end])
    return out


def steady_state_error(y: np.ndarray, r: np.ndarray, dt: float, tail: float = TAIL,
                       min_hold: float = MIN_HOLD, guard: float = PREVIEW_GUARD) -> float:
    """Mean over holds of the mean ``|r - y|`` over each hold window (module docstring)."""
    y, r = _check(y, r, dt)
    parts = _hold_tails(y, r, dt, tail, min_hold, guard)
    return float(np.mean([np.mean(np.abs(e)) for e in parts])) if parts else float("nan")


def limit_cycle_amplitude(y: np.ndarray, r: np.ndarray, dt: float, tail: float = TAIL,
                          min_hold: float = MIN_HOLD, guard: float = PREVIEW_GUARD) -> float:
    """Mean over holds of the peak-to-peak error over each hold window (module docstring)."""
    y, r = _check(y, r, dt)
    parts = _hold_tails(y, r, dt, tail, min_hold, guard)
    return float(np.mean([np.max(e) - np.min(e) for e in parts])) if parts else float("nan")


def hunting(y: np.ndarray, r: np.ndarray, dt: float, tail: float = TAIL, min_hold: float = HUNTING_HOLD,
            guard: float = PREVIEW_GUARD) -> float:
    """:func:`limit_cycle_amplitude` over the holds of at least ``min_hold`` seconds (2 s)."""
    return limit_cycle_amplitude(y, r, dt, tail, min_hold, guard)


def stick_time(y: np.ndarray, r: np.ndarray, dt: float, stick_frac: float = STICK_FRAC,
               min_run: int = MIN_RUN) -> float:
    """Fraction of the moving-reference time (reference speed above ``v_tol``) the plant rests.

    Speeds are backward differences ``|x[k] - x[k-1]| / dt``; ``v_tol = stick_frac`` times the
    peak reference speed over the moving samples."""
    y, r = _check(y, r, dt)
    if not (0.0 < stick_frac < 1.0):
        raise ValueError(f"stick_frac = {stick_frac!r}; allowed (0, 1)")
    mov = moving_mask(r, min_run)
    if not mov.any():
        return float("nan")
    vr = np.abs(np.r_[0.0, np.diff(r)]) / dt
    vy = np.abs(np.r_[0.0, np.diff(y)]) / dt
    tol = stick_frac * float(np.max(vr[mov]))
    sel = mov & (vr > tol)
    if not sel.any():
        return float("nan")
    return float(np.mean(vy[sel] <= tol))
