"""The final model of a diagnosis as a table: every fitted parameter with its uncertainty.

One row per parameter of the last fit (the base-fit parameters, then each named effect's),
with the value, its standard error from the fit's covariance, the unit, the bounds the fit
was held to and whether the value lies on one of them (a base-fit parameter on its bound is
absorbing something the model lacks, or the base model is far off). A fitted sensor delay
is a row of its own. ``hydro diagnose`` prints the table, ``--json`` carries it as
``final_model`` and ``report.md`` shows it.
"""

from __future__ import annotations

import math
from typing import Any

from identification.diagnosis.fitting import FitOutcome, _fit_names
from identification.diagnosis.plants import DiagnosisPlant

__all__ = ["ON_BOUND_LOG_MARGIN", "final_model_lines", "final_model_rows", "on_bound"]

#: a value within this relative (log) distance of a bound counts as on it
ON_BOUND_LOG_MARGIN = 1e-3


def on_bound(value: float, lower: float, upper: float) -> bool:
    """True when ``value`` lies on ``lower`` or ``upper`` (relative margin
    :data:`ON_BOUND_LOG_MARGIN` of the span's scale; works for signed bounds)."""
    scale = max(abs(lower), abs(upper), 1e-300)
    if lower > 0 and value > 0:
        return math.log(value / lower) < ON_BOUND_LOG_MARGIN or math.log(upper / value) < ON_BOUND_LOG_MARGIN
    return value - lower < ON_BOUND_LOG_MARGIN * scale or upper - value < ON_BOUND_LOG_MARGIN * scale


def final_model_rows(spec: DiagnosisPlant, fit: FitOutcome, effects: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows ``{name, role, value, std_error, unit, lower, upper, on_bound}`` of the final
    model ``fit``; ``role`` is ``base`` or the name of the effect (``effects``: the named
    effects, each with its ``parameters``) the parameter belongs to."""
    names, bounds, _ = _fit_names(spec, fit.model)
    owner = {k: e["name"] for e in effects for k in e.get("parameters", {})}
    res = fit.result
    se = res.std_errors if res is not None else {}
    units = res.units if res is not None else {}
    rows = []
    for n in names:
        v = float(getattr(fit.model.params, n))
        lo, hi = bounds.get(n, (-math.inf, math.inf))
        rows.append({"name": n, "role": owner.get(n, "base" if n in spec.base_fit else "effect"), "value": v,
                     "std_error": float(se.get(n, math.nan)), "unit": units.get(n, ""),
                     "lower": float(lo), "upper": float(hi),
                     "on_bound": bool(math.isfinite(lo) and math.isfinite(hi) and on_bound(v, lo, hi))})
    if fit.model.delay > 0:
        rows.append({"name": "delay", "role": owner.get("delay", "sensor_delay"), "value": float(fit.model.delay),
                     "std_error": float(fit.delay_se), "unit": "s", "lower": 0.0, "upper": math.inf,
                     "on_bound": False})
    return rows


def final_model_lines(rows: list[dict[str, Any]]) -> list[str]:
    """One text line per row: ``name = value +- se unit (role)``, ``ON ITS BOUND`` flagged."""
    out = []
    for r in rows:
        flag = f"; ON ITS BOUND [{r['lower']:.4g}, {r['upper']:.4g}]" if r["on_bound"] else ""
        unit = f" {r['unit']}" if r["unit"] else ""
        out.append(f"{r['name']} = {r['value']:.4g} +- {r['std_error']:.2g}{unit} ({r['role']}{flag})")
    return out
