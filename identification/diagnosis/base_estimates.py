r"""Base models read off the records: what a rig's preset would say, estimated from the data.

A diagnosis starts from a base model whose calibration quantities (mass, damping, stroke)
match the rig; the nominal parameters of a generic plant (a 1 kg slider on a 200 mm stroke)
do not match a 95 kg ball-screw axis, and a free run of the wrong mass diverges. When no preset
is given, the plant's estimator (``DiagnosisPlant.base_from_data``) sets those quantities from
the fit records and says so in a note; the diagnosis then fits them as usual.

* ``rigid_axis`` (force-driven axis, :mod:`hydro_envs.plants.slider`): mass and viscous
  friction from the inverse-dynamics least squares of :func:`identification.slider.identify_slider`
  (``f = m a + F_C sign(v) + b v + F_0``, Gautier's IDIM-LS with parallel filtering; the Coulomb
  level and the offset are regressors only, so that they do not bias m and b, and are *not*
  carried into the base model: finding them is the diagnosis' job); the stroke from the
  position range, the upper stop 10 % of the range beyond the largest position; the force
  range from the largest applied force. A record whose position zero is not the lower stop
  (an encoder zeroed anywhere: positions at or below 0) is shifted so that the lowest position
  lies 10 % of the range above the stop (:func:`position_shift`; the rigid axis has no
  position-dependent force inside its stops and scores positions without their window mean, so
  the shift changes nothing but where the stops are), and a note says by how much.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from identification.diagnosis.records import DiagnosisDataError, Record

__all__ = ["ESTIMATORS", "estimate_base", "position_shift", "shifted"]


def rigid_axis(params: Any, records: Sequence[Record], position: str) -> tuple[dict[str, float], str]:
    """Mass, viscous friction and stroke of a force-driven axis from ``records`` (longest one
    for the dynamics, all for the stroke)."""
    from identification.slider import SliderIdentificationError, identify_slider

    rec = max(records, key=lambda r: r.n)
    try:
        ident = identify_slider(rec.inputs[:, 0], rec.channels[position], rec.dt, stribeck="none")
    except SliderIdentificationError as err:
        raise DiagnosisDataError(f"the base model cannot be read off the record ({err}); give a base "
                                 "model that matches the rig (--base preset)") from err
    m = float(ident.params["mass"])
    b = float(ident.params["viscous_friction"])
    if not (m > 0 and np.isfinite(m)):
        raise DiagnosisDataError(f"the inverse-dynamics mass of the record is {m:.4g} kg (must be > 0): the force "
                                 "does not explain the acceleration; give a base model (--base preset)")
    lo = min(float(r.channels[position].min()) for r in records)
    hi = max(float(r.channels[position].max()) for r in records)
    if lo < 0:  # the caller shifts the records first (position_shift); a direct call is an error
        raise DiagnosisDataError(f"position channel {position!r} goes to {lo:.4g} m, below the lower end stop "
                                 "at 0: positions are measured from the lower stop (0..stroke)")
    stroke = hi + 0.1 * (hi - lo)
    f_peak = max(float(np.abs(r.inputs[:, 0]).max()) for r in records)
    values = {"mass": m, "viscous_friction": max(b, 0.0), "stroke": max(stroke, float(params.stroke)),
              "force_max": max(f_peak, float(params.force_max))}
    note = (f"base model read off the record (no --base preset): mass {m:.4g} kg and viscous friction "
            f"{values['viscous_friction']:.4g} N s/m from inverse dynamics, stroke {values['stroke']:.4g} m "
            f"from the position range {lo:.4g}..{hi:.4g} m")
    return values, note


def position_shift(records: Sequence[Record], position: str) -> float:
    """Shift [m] that puts the lowest recorded position 10 % of the position range (at least
    1 mm) above the lower end stop, if it is closer than that or below it (an encoder zero that
    is not the stop); 0 otherwise."""
    lo = min(float(r.channels[position].min()) for r in records)
    hi = max(float(r.channels[position].max()) for r in records)
    margin = max(0.1 * (hi - lo), 1e-3)
    return margin - lo if lo < margin else 0.0


def shifted(records: Sequence[Record], position: str, dx: float) -> list[Record]:
    """Copies of ``records`` with ``dx`` added to the position channel."""
    return [Record(r.dt, r.inputs.copy(), {k: (v + dx if k == position else v) for k, v in r.channels.items()},
                   r.name, list(r.notes)) for r in records]


ESTIMATORS: dict[str, Callable[..., tuple[dict[str, float], str]]] = {"rigid_axis": rigid_axis}


def estimate_base(spec: Any, params: Any, records: Sequence[Record]) -> tuple[Any, str]:
    """``params`` with the calibration quantities of ``spec``'s estimator read off ``records``,
    and a note saying what was estimated."""
    values, note = ESTIMATORS[spec.base_from_data](params, records, spec.position_channel)
    return dataclasses.replace(params, **values), note
