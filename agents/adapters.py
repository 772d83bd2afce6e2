"""What the benchmark needs to know about one env: its true output, limits and step reference.

Each plant's controller module (``agents.controllers.<plant>``) returns an :class:`EnvAdapter`
per env id (``benchmark_adapter(env_id)``); the helpers below serve every cylinder-tracking
batch (they read the batch's index attributes, no plant is named).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import numpy as np

__all__ = ["EnvAdapter", "PRESSURE_MAX_FACTOR", "ref_now", "cyl_output", "cyl_pressures", "cyl_stroke"]

#: a chamber pressure above this multiple of the supply pressure counts as a violation
PRESSURE_MAX_FACTOR = 1.25


@dataclasses.dataclass(frozen=True)
class EnvAdapter:
    """What the benchmark needs to know about one env (true output, limits, step reference)."""

    env_id: str
    quantity: str
    unit: str
    step_reference: str | None  # kind name of the env's step reference, None: not available
    settle_abs: float  # absolute floor of the settling band [unit]
    output: Callable[[Any], tuple[np.ndarray, np.ndarray]]  # batch -> (y, ref) after a step
    pressures: Callable[[Any], tuple[np.ndarray, np.ndarray, np.ndarray]] | None  # (p (n,k), lo, hi)
    outside_stroke: Callable[[Any], np.ndarray] | None
    note: str = ""


def ref_now(b) -> np.ndarray:
    """Each copy's reference at its current step."""
    k = np.minimum(b.K, b.REF.shape[1] - 1)
    return b.REF[np.arange(b.n), k]


def cyl_output(b):
    """Position and reference of a cylinder-tracking batch."""
    return b.Y[:, b.position_index].copy(), ref_now(b)


def cyl_pressures(b):
    """Chamber pressures with the floor and ``PRESSURE_MAX_FACTOR`` x supply as limits."""
    ip1, ip2 = b.pressure_indices
    p = b.Y[:, [ip1, ip2]]
    names = b.params_cls.names()
    floor = b.P[:, names.index("pressure_floor")]
    ps = b.P[:, names.index("supply_pressure")]
    return p, floor, PRESSURE_MAX_FACTOR * ps


def cyl_stroke(b):
    """Copies whose position lies outside ``[0, stroke]``."""
    x = b.Y[:, b.position_index]
    return (x < 0.0) | (x > b.P[:, b.stroke_index])
