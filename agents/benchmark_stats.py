r"""Aggregates of the benchmark's per-episode metrics, with intervals that respect each metric.

* Means of nonnegative metrics (RMSE, errors, effort, counts, stick time, ...): a seeded
  percentile bootstrap over the parameter draws (:func:`draw_bootstrap_ci`). Its bounds are
  means of resampled data, so they never leave the data's range (never below zero).
* ``rmse_rel_pid``: the mean over draws of the paired ratio ``RMSE_controller / RMSE_PID`` on
  the same draw and episode; the same bootstrap resamples whole draws, so controller and PID
  stay paired (a paired bootstrap of the ratio).
* Failure rate: the Wilson score interval (:func:`wilson_ci`, ``scipy.stats.binomtest``).
* CVaR-10 % of the RMSE: a seeded percentile bootstrap over episodes (:func:`bootstrap_ci`).
* ``friction_share`` (the PID row): ``1 - sum MSE_dry_free / sum MSE`` over the draws, the share
  of the mean squared error that dry friction causes (:func:`share_ci`), with the same
  bootstrap over whole draws (the two runs stay paired).

Episodes of several training seeds of one learned controller share the draws: episode ``j``
belongs to draw ``j % n_draws``, and a resample takes every episode of a drawn draw.
Resampling is driven by ``numpy.random.default_rng``: the same seed gives the same interval.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

__all__ = ["N_BOOT", "bootstrap_ci", "cvar", "draw_bootstrap_ci", "share_ci", "summarize", "wilson_ci"]

#: bootstrap resamples (the percentile bounds move by < 1 % of the interval between seeds)
N_BOOT = 4000
_BLOCK = 1_000_000  # resampled indices held at once


def cvar(values: Sequence[float], alpha: float = 0.1) -> float:
    """Upper-tail CVaR: mean of the worst ``ceil(alpha n)`` values (NaNs ignored)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan")
    k = max(1, math.ceil(alpha * v.size - 1e-12))
    return float(np.mean(np.sort(v)[::-1][:k]))


def _check_level(level: float) -> None:
    if not (0.0 < level < 1.0):
        raise ValueError(f"level = {level!r}; allowed (0, 1)")


def wilson_ci(k: int, n: int, level: float = 0.95) -> tuple[float, float, float]:
    """Proportion ``k/n`` with its Wilson score interval (NaNs for ``n = 0``)."""
    from scipy import stats

    _check_level(level)
    if n == 0:
        return float("nan"), float("nan"), float("nan")
    if not (0 <= k <= n):
        raise ValueError(f"k = {k!r}; allowed 0 <= k <= n = {n}")
    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=level, method="wilson")
    return k / n, max(0.0, float(ci.low)), min(1.0, float(ci.high))


def draw_bootstrap_ci(values: Sequence[float], n_draws: int | None = None, *, level: float = 0.95,
                      n_boot: int = N_BOOT, seed: int = 0) -> tuple[float, float, float, int]:
    """Mean of the finite ``values`` with a percentile-bootstrap interval over draws.

    Episode ``j`` belongs to draw ``j % n_draws`` (default: every episode its own draw); a
    resample draws ``n_draws`` draws with replacement and averages the finite values of all
    their episodes. Returns ``(mean, low, high, n_finite)``; NaNs without finite values.
    """
    _check_level(level)
    v = np.asarray(values, dtype=float).reshape(-1)
    n = v.size if n_draws is None else int(n_draws)
    if n < 1 or v.size % n:
        raise ValueError(f"n_draws = {n_draws!r}; must divide the {v.size} episodes")
    fin = np.isfinite(v)
    if not fin.any():
        return float("nan"), float("nan"), float("nan"), 0
    rows = np.where(fin, v, 0.0).reshape(-1, n)
    sums, counts = rows.sum(axis=0), fin.reshape(-1, n).sum(axis=0)
    m = float(np.sum(sums) / np.sum(counts))
    if n == 1 or np.ptp(v[fin]) == 0.0:
        return m, m, m, int(fin.sum())
    rng = np.random.default_rng([int(seed), 11])
    boots = np.empty(n_boot)
    step = max(1, _BLOCK // n)
    for a in range(0, n_boot, step):
        idx = rng.integers(0, n, (min(step, n_boot - a), n))
        c = counts[idx].sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            boots[a : a + idx.shape[0]] = sums[idx].sum(axis=1) / c
    boots = boots[np.isfinite(boots)]  # a resample of draws without finite values
    lo, hi = np.percentile(boots, [50 * (1 - level), 50 * (1 + level)])
    return m, float(min(lo, m)), float(max(hi, m)), int(fin.sum())


def share_ci(total: Sequence[float], part_free: Sequence[float], *, level: float = 0.95, n_boot: int = N_BOOT,
             seed: int = 0) -> tuple[float, float, float, int]:
    """``1 - sum(part_free) / sum(total)`` over the draws where both are finite, with a seeded
    percentile-bootstrap interval over those draws (pairs resampled together): the share of a
    total (a controller's mean squared error per draw) that a cause removed in ``part_free``
    makes. Negative where removing the cause makes the total grow. ``(share, low, high, n)``."""
    _check_level(level)
    a = np.asarray(total, dtype=float).reshape(-1)
    b = np.asarray(part_free, dtype=float).reshape(-1)
    if a.shape != b.shape:
        raise ValueError(f"total has {a.size} draws, part_free {b.size}; they must be paired")
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    if a.size == 0 or not np.sum(a) > 0.0:
        return float("nan"), float("nan"), float("nan"), int(a.size)
    s = float(1.0 - np.sum(b) / np.sum(a))
    if a.size == 1:
        return s, s, s, 1
    rng = np.random.default_rng([int(seed), 13])
    idx = rng.integers(0, a.size, (n_boot, a.size))
    with np.errstate(invalid="ignore", divide="ignore"):
        boots = 1.0 - b[idx].sum(axis=1) / a[idx].sum(axis=1)
    boots = boots[np.isfinite(boots)]
    lo, hi = np.percentile(boots, [50 * (1 - level), 50 * (1 + level)])
    return s, float(min(lo, s)), float(max(hi, s)), int(a.size)


def bootstrap_ci(values: Sequence[float], stat: Callable[[np.ndarray], float], *, level: float = 0.95,
                 n_boot: int = 2000, seed: int = 0) -> tuple[float, float, float]:
    """Statistic of the finite ``values`` and its seeded percentile-bootstrap interval."""
    _check_level(level)
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return float("nan"), float("nan"), float("nan")
    s = stat(v)
    rng = np.random.default_rng(seed)
    boots = np.array([stat(v[rng.integers(0, v.size, v.size)]) for _ in range(n_boot)])
    lo, hi = np.percentile(boots, [50 * (1 - level), 50 * (1 + level)])
    return float(s), float(min(lo, s)), float(max(hi, s))


def summarize(episodes: Mapping[str, np.ndarray], keys: Sequence[str], seed: int = 0,
              n_draws: int | None = None) -> dict[str, tuple[float, float, float, int]]:
    """Metric -> ``(value, ci_low, ci_high, n)`` for one controller (module docstring).

    ``keys``: the metrics to report; ``cvar10_rmse`` and ``failed`` are computed from
    ``rmse`` and ``failed``, ``friction_share`` from ``rmse`` and ``mse_dry_free`` (NaN without
    it), every other key is the mean of ``episodes[key]`` over its finite
    values (a missing key: NaN)."""
    out = {}
    for key in keys:
        if key == "cvar10_rmse":
            v = np.asarray(episodes["rmse"], dtype=float)
            if (~np.isfinite(v)).any() and np.isfinite(v).any():
                # a failed (non-finite) episode counts as the worst
                out[key] = (float("inf"), float("inf"), float("inf"), int(v.size))
            else:
                fin = v[np.isfinite(v)]
                s, lo, hi = bootstrap_ci(fin, cvar, seed=seed)
                out[key] = (s, lo, hi, int(fin.size))
        elif key == "friction_share":
            if "mse_dry_free" not in episodes:
                out[key] = (float("nan"), float("nan"), float("nan"), 0)
            else:
                out[key] = share_ci(np.asarray(episodes["rmse"], dtype=float) ** 2, episodes["mse_dry_free"],
                                    seed=seed)
        elif key == "failed":
            f = np.asarray(episodes["failed"], dtype=float)
            p, lo, hi = wilson_ci(int(np.sum(f > 0.5)), int(f.size))
            out[key] = (p, lo, hi, int(f.size))
        else:
            v = np.asarray(episodes.get(key, np.full(1, np.nan)), dtype=float)
            nd = n_draws if (n_draws is not None and v.size % n_draws == 0) else None
            out[key] = draw_bootstrap_ci(v, nd, seed=seed)
    return out
