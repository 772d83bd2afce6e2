"""Friction identification: errors, forces from chamber pressures, constant-velocity points and fit metrics."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np



__all__ = ['IdentificationError', 'InsufficientDataError', 'UnidentifiableError', 'actuator_force', 'chamber_force', 'FrictionPoints', 'mean_absolute_error', 'rmse', 'nrmse']


# ======================================================================================
# errors
# ======================================================================================


class IdentificationError(ValueError):
    """The data cannot give the requested model (base class)."""

    exit_code = 1  # the command line's code for data that cannot give a result (hydro_envs.cli_errors)


class InsufficientDataError(IdentificationError):
    """Too few (or too few distinct) data points for the number of parameters."""


class UnidentifiableError(IdentificationError):
    """The fit converged but some parameters are not determined by the data.

    ``parameters`` lists their names.
    """

    def __init__(self, parameters: Sequence[str], message: str) -> None:
        self.parameters = tuple(parameters)
        super().__init__(message)


# ======================================================================================
# forces from pressures
# ======================================================================================


def actuator_force(p1: Any, p2: Any, area: float) -> np.ndarray:
    """Actuator force of a double-rod cylinder ``F_a = A (p1 - p2)`` [N], 002 eq (10).

    At constant velocity with no load, ``F_f = F_a`` (002 eq (9)).
    """
    if not (math.isfinite(area) and area > 0.0):
        raise ValueError(f"area must be > 0 m^2, got {area}")
    return area * (np.asarray(p1, dtype=float) - np.asarray(p2, dtype=float))


def chamber_force(pa: Any, pb: Any, area_a: float, area_b: float) -> np.ndarray:
    """Friction at constant velocity ``F_f = A_a p_a - A_b p_b`` [N], 004 eq (1).

    For a single-rod (or rodless) cylinder with different effective areas; with equal areas it
    is 002 eq (10).
    """
    for name, a in (("area_a", area_a), ("area_b", area_b)):
        if not (math.isfinite(a) and a >= 0.0):
            raise ValueError(f"{name} must be >= 0 m^2, got {a}")
    return area_a * np.asarray(pa, dtype=float) - area_b * np.asarray(pb, dtype=float)


# ======================================================================================
# data: constant-velocity points
# ======================================================================================


@dataclass
class FrictionPoints:
    """Steady (constant-velocity) friction measurements, one row per window.

    ``v`` [m/s] window velocity, ``force`` [N] mean friction force (sign of ``v``),
    ``pressure`` [Pa] mean seal-loading pressure (or None), ``force_std`` [N] standard deviation
    of the force samples inside the window (a limit cycle shows up here), ``n_samples``,
    ``t_start`` / ``t_end`` [s] the averaged window, ``command`` the input held during the
    window (or NaN), ``group`` an integer label (stroke / file / pressure level) used to hold
    data out.
    """

    v: np.ndarray
    force: np.ndarray
    pressure: np.ndarray | None = None
    force_std: np.ndarray | None = None
    n_samples: np.ndarray | None = None
    t_start: np.ndarray | None = None
    t_end: np.ndarray | None = None
    command: np.ndarray | None = None
    group: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    _OPTIONAL = ("pressure", "force_std", "n_samples", "t_start", "t_end", "command", "group")

    def __post_init__(self) -> None:
        self.v = np.atleast_1d(np.asarray(self.v, dtype=float))
        self.force = np.atleast_1d(np.asarray(self.force, dtype=float))
        if self.v.ndim != 1 or self.v.shape != self.force.shape:
            raise ValueError(
                f"v and force must be 1-D of equal length, got {self.v.shape} and {self.force.shape}"
            )
        for name in self._OPTIONAL:
            val = getattr(self, name)
            if val is None:
                continue
            arr = np.atleast_1d(np.asarray(val, dtype=np.int64 if name == "group" else float))
            if arr.shape != self.v.shape:
                raise ValueError(f"{name} has shape {arr.shape}, expected {self.v.shape}")
            setattr(self, name, arr)
        bad = ~np.isfinite(self.v) | ~np.isfinite(self.force)
        if self.pressure is not None:
            bad |= ~np.isfinite(self.pressure)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"friction point {i} is not finite (v={self.v[i]}, force={self.force[i]})")

    def __len__(self) -> int:
        return int(self.v.shape[0])

    def select(self, mask: Any) -> "FrictionPoints":
        """The points where ``mask`` (boolean or index array) holds."""
        mask = np.asarray(mask)
        kw = {n: (None if getattr(self, n) is None else getattr(self, n)[mask]) for n in self._OPTIONAL}
        return FrictionPoints(self.v[mask], self.force[mask], meta=dict(self.meta), **kw)

    @staticmethod
    def concatenate(parts: Sequence["FrictionPoints"]) -> "FrictionPoints":
        parts = list(parts)
        if not parts:
            raise ValueError("nothing to concatenate")
        kw: dict[str, Any] = {}
        for n in FrictionPoints._OPTIONAL:
            vals = [getattr(p, n) for p in parts]
            kw[n] = None if any(v is None for v in vals) else np.concatenate(vals)
        return FrictionPoints(
            np.concatenate([p.v for p in parts]), np.concatenate([p.force for p in parts]), **kw
        )

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"v": self.v.tolist(), "force": self.force.tolist()}
        for n in self._OPTIONAL:
            val = getattr(self, n)
            if val is not None:
                out[n] = val.tolist()
        return out


# ======================================================================================
# metrics
# ======================================================================================


def mean_absolute_error(y: Any, y_hat: Any) -> float:
    """002 eq (11): ``E = (1/N) sum |F_f(v_i) - F_model(v_i)|`` [N]."""
    y = np.asarray(y, dtype=float)
    return float(np.mean(np.abs(y - np.asarray(y_hat, dtype=float))))


def rmse(y: Any, y_hat: Any) -> float:
    """Root-mean-square error."""
    y = np.asarray(y, dtype=float)
    return float(np.sqrt(np.mean((y - np.asarray(y_hat, dtype=float)) ** 2)))


def nrmse(y: Any, y_hat: Any) -> float:
    """Normalised RMSE ``||y - y_hat|| / ||y - mean(y)||`` (0 perfect, 1 = the mean predictor).

    This is ``1 - fit/100`` of MATLAB's ``compare``; used for every NRMSE in this package.
    """
    y = np.asarray(y, dtype=float)
    den = float(np.linalg.norm(y - y.mean()))
    num = float(np.linalg.norm(y - np.asarray(y_hat, dtype=float)))
    if den == 0.0:
        return 0.0 if num == 0.0 else math.inf
    return num / den


def _metrics(y: np.ndarray, y_hat: np.ndarray, n_params: int) -> dict[str, float]:
    n = int(y.size)
    ss_res = float(np.sum((y - y_hat) ** 2))
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return {
        "rmse": rmse(y, y_hat),
        "nrmse": nrmse(y, y_hat),
        "E": mean_absolute_error(y, y_hat),
        "r2": 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan"),
        "n_points": n,
        "dof": n - n_params,
    }


