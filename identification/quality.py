"""Fit-quality gate of an identification result, and a progress line for long fits.

:func:`assess` reads a result mapping of ``hydro identify`` (``parameters``, ``std_errors``,
``metrics``) and returns ``{"ok": bool, "reasons": [...], "thresholds": {...}}``. A result is
flagged when

* its fit is below :data:`MIN_FIT_PERCENT` (50 %). The fit is ``100 (1 - NRMSE)`` of the
  measure that shows whether the model explains the data: the complex FRF fit of a
  mass-spring-damper (``fit_percent``), the held-out *free-run* fit of an ARX model
  (``heldout_fit_free_run``; the one-step fit is close to 100 % for nearly any model of
  sampled data and says little), the free-run NRMSE per output channel of a grey-box fit
  (``nrmse_<channel>``). Below 50 % the model explains less than half of the output's
  deviation from its mean, and its parameters describe the noise as much as the plant;
* any parameter's relative standard error ``SE / |value|`` exceeds :data:`MAX_REL_SE`
  (100 %): the data do not tell the value from zero, so the number must not be used;
* an FRF fit rests on fewer than :data:`MIN_FRF_POINTS` (10) frequency points of coherence
  >= 0.9 (the points the fit keeps): a short or badly excited record;
* a grey-box fit's optimiser stopped before converging (``success`` false: its evaluations ran
  out): the values are not a least-squares minimum, whatever their standard errors say.

The thresholds are conventions, not derived from a seed: 50 % is the common "fit" level below
which a linear model is rejected in identification practice (``fit = 100 (1 - NRMSE)`` as in
:func:`identification.arx.fit_percent`), and 100 % relative error is the point where the
confidence interval of a parameter contains zero at about one standard error.

:class:`Progress` prints ``label: k/n`` on standard error for loops that run longer than
:data:`PROGRESS_DELAY` (2 s), at most :data:`PROGRESS_INTERVAL` apart (a carriage-return line
on a terminal, plain lines, further apart, otherwise); it prints nothing for short runs.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Mapping
from typing import Any, TextIO

__all__ = ["MIN_FIT_PERCENT", "MAX_REL_SE", "MIN_FRF_POINTS", "assess", "warning_lines", "Progress",
           "PROGRESS_DELAY", "PROGRESS_INTERVAL"]

#: fit [%] below which a result is flagged
MIN_FIT_PERCENT = 50.0
#: relative standard error above which a parameter is flagged (1.0 = 100 %)
MAX_REL_SE = 1.0
#: fewest FRF points (coherence >= 0.9) a mass-spring-damper fit should rest on
MIN_FRF_POINTS = 10
#: seconds before the first progress line
PROGRESS_DELAY = 2.0
#: seconds between progress lines on a terminal (plain lines: four times as far apart)
PROGRESS_INTERVAL = 0.5


def _fits(method: str, metrics: Mapping[str, Any]) -> dict[str, float]:
    """The fit percentages that decide, name -> value."""
    out: dict[str, float] = {}
    if method == "frf" and "fit_percent" in metrics:
        out["fit_percent"] = float(metrics["fit_percent"])
    elif method == "arx" and "heldout_fit_free_run" in metrics:
        out["heldout_fit_free_run"] = float(metrics["heldout_fit_free_run"])
    elif method == "greybox":
        for k, v in metrics.items():
            if k.startswith("nrmse_"):
                out[f"fit_{k[len('nrmse_'):]}"] = 100.0 * (1.0 - float(v))
    return out


def assess(res: Mapping[str, Any], method: str | None = None, *, min_fit: float = MIN_FIT_PERCENT,
           max_rel_se: float = MAX_REL_SE) -> dict[str, Any]:
    """Quality flag of a result mapping (see the module docstring)."""
    method = method or str(res.get("method", ""))
    metrics = res.get("metrics") or {}
    reasons: list[str] = []
    for name, fit in _fits(method, metrics).items():
        if not (math.isfinite(fit) and fit >= min_fit):
            reasons.append(f"{name} = {fit:.3g} % is below {min_fit:g} %: the model does not explain the data")
    params = res.get("parameters") or {}
    se = res.get("std_errors") or {}
    units = res.get("units") or {}
    for k, v in params.items():
        s = se.get(k)
        if s is None or not isinstance(v, (int, float)) or isinstance(v, bool):
            continue
        v, s = float(v), float(s)
        rel = abs(s) / abs(v) if v != 0 else math.inf
        if not (math.isfinite(rel) and rel <= max_rel_se):
            reasons.append(f"{k} = {v:.4g} +- {s:.3g} {units.get(k, '')}".rstrip()
                           + f": relative standard error {100 * rel:.3g} % > {100 * max_rel_se:g} %"
                           " (the data do not determine it)")
    if method == "greybox" and res.get("success") is False:
        reasons.append(f"the fit did not converge ({res.get('message', 'no message')}): the values are not "
                       "a least-squares minimum; start it closer to the values (--set NAME=VALUE)")
    if method == "frf" and "n_points" in metrics and int(metrics["n_points"]) < MIN_FRF_POINTS:
        reasons.append(f"only {int(metrics['n_points'])} frequency points with coherence >= 0.9 "
                       f"(fewer than {MIN_FRF_POINTS}): excite longer or wider")
    return {"ok": not reasons, "reasons": reasons,
            "thresholds": {"min_fit_percent": min_fit, "max_relative_std_error": max_rel_se,
                           **({"min_frf_points": MIN_FRF_POINTS} if method == "frf" else {})}}


def warning_lines(quality: Mapping[str, Any]) -> list[str]:
    """The text lines that report a failed gate (none when it passed)."""
    if quality.get("ok", True):
        return []
    return ["warning: poor fit -- do not use these parameters: " + r for r in quality.get("reasons", [])]


class Progress:
    """``label: k/n`` on ``stream`` (standard error) once a loop runs longer than ``delay``.

    Call it with the count done (``n`` is the total, or an upper bound, or None) and
    :meth:`close` at the end. Nothing is printed for runs shorter than ``delay``.
    """

    def __init__(self, label: str, total: int | None = None, *, unit: str = "", stream: TextIO | None = None,
                 delay: float = PROGRESS_DELAY, interval: float = PROGRESS_INTERVAL) -> None:
        self.label = label
        self.unit = unit
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.delay = float(delay)
        self.interval = float(interval) * (1.0 if self.tty else 4.0)
        self.t0 = time.monotonic()
        self.last = -math.inf
        self.printed = False

    def __call__(self, done: int, total: int | None = None) -> None:
        if total is not None:
            self.total = total
        now = time.monotonic()
        if now - self.t0 < self.delay or now - self.last < self.interval:
            return
        self.last = now
        n = "?" if self.total is None else str(self.total)
        text = f"{self.label}: {done}/{n}{' ' + self.unit if self.unit else ''} ({now - self.t0:.0f} s)"
        self.stream.write(("\r" + text) if self.tty else (text + "\n"))
        self.stream.flush()
        self.printed = True

    def close(self) -> None:
        if self.printed and self.tty:
            self.stream.write("\n")
            self.stream.flush()
