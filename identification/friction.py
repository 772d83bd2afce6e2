r"""Friction identification: constant-velocity points, static fits, graphical construction,
Dahl and LuGre fits from time series.

Sources (text extractions in ``/work/shared/seeds``):

* ``002_af30b681d6ccfd6c.txt`` sec. 4: at constant velocity and no load the friction equals the
  actuator force, eqs (9)-(10) ``F_f = F_a = A (P1 - P2)`` (double-rod cylinder; the viscous
  term ``d v`` of eq (7) is part of the friction); exponential Stribeck model eq (1); the
  fitting error E of eq (11) (mean absolute error over the measurement points).
* ``004_f1423316a055addb.txt`` sec. 3: ``F_f = A_a p_a - A_b p_b`` eq (1) (unequal areas), the
  graphical construction of the Stribeck parameters sec. 3.1 / Fig. 3, Table 2.
* ``003_54985feb8193da53.txt`` eqs (11)-(12): Gaussian Stribeck model.
* ``001_3253c61f41166c3e.txt`` eq (1): Dahl model; LuGre (Canudas de Wit et al. 1995, ref [30]
  of 003, ref [6] of 002). The laws themselves are in :mod:`hydro_envs.laws.friction`.

Sign convention (as in :mod:`hydro_envs.laws.friction`): the friction force has the sign of
the velocity (it opposes motion), ``m a = F_drive - F_f``.

Static models
-------------
Every static model here has the form (``sgn`` is ``sign(v)``, or ``tanh(v / v_eps)`` when the
caller passes ``sign_velocity = v_eps > 0`` to match a regularised simulation)::

    F(v, p) = sgn(v) [F_c + k_p p + (F_s - F_c) phi(|v| / v_s)] + F_v v

    phi(r) = exp(-r)     "stribeck"            002 eq (1)
    phi(r) = exp(-r^2)   "stribeck_gaussian"   003 eq (11)
    (no phi term)        "coulomb_viscous", "coulomb" (also without F_v v)

The pressure term ``k_p p`` [N/Pa = m^2] is present only with ``pressure_dependent=True``;
``p`` is the pressure that loads the seals (the mean chamber pressure for a hydraulic cylinder,
the gauge chamber pressure for the pneumatic seal rig). It shifts the Coulomb *and* the static
level by the same amount (the seal's normal force grows with pressure; the Stribeck dip
height ``F_s - F_c`` is taken as pressure-independent) -- the simplest law that the seal data
(:mod:`identification.experiments`, one speed per direction) can identify; Simscape's cylinder
friction uses the same linear growth with pressure. With ``pressure_dependent`` the reported
``F_c`` and ``F_s`` are the values at ``p = 0``.

Fitting is bounded nonlinear least squares (``scipy.optimize.least_squares``, trust-region
reflective) on the parameters. For a fixed ``v_s`` every model is *linear* in
``(F_c, k_p, F_s - F_c, F_v)``, so a grid over ``v_s`` with bounded linear least squares
(variable projection) gives a global starting point, which ``least_squares`` then polishes on
all parameters. Bounds: ``F_c, F_s - F_c, F_v >= 0`` (002 eq (1): all positive), ``v_s`` in
``[min|v| / 100, 10 max|v|]``, ``k_p`` free.

Covariance ``C = (J^T J)^-1 s^2`` with ``s^2 = SSR / (N - n_p)`` at the solution (``J`` the
Jacobian of the residuals in the reported parameters), standard errors ``sqrt(diag C)``.
These assume independent residuals of equal variance; window-averaged constant-velocity points
are close to that, raw autocorrelated time series are not (``shared/NOTES.md``: naive standard
errors 1.6-2.2x too small there).

Identifiability: a fit raises :class:`UnidentifiableError` naming the parameters the data
cannot determine: ``F_s, v_s`` when the slowest point lies where the Stribeck term has decayed
below 5 % (no low-velocity points to see the dip), ``v_s`` when the fitted dip height is not
significant (``F_s - F_c`` below twice its standard error: no dip in the data), and any
parameter whose standard error moves the model force over the data's range (``F_c, F_s``:
itself, ``F_v``: times ``max |v|``, ``k_p``: times the pressure span) by more than
``max_rel_std_error`` (default 0.5) of the largest measured force, or ``v_s`` with a relative
standard error above it.
Too few points raise :class:`InsufficientDataError`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numba as nb
import numpy as np
from scipy import optimize

from hydro_envs.laws.friction import (
    dahl_friction_step_exact,
    lugre_bristle_step_exact,
    lugre_g,
)

__all__ = [
    "IdentificationError",
    "InsufficientDataError",
    "UnidentifiableError",
    "actuator_force",
    "chamber_force",
    "FrictionPoints",
    "mean_absolute_error",
    "rmse",
    "nrmse",
    "STATIC_MODELS",
    "static_friction",
    "FrictionFit",
    "AsymmetricFrictionFit",
    "fit_friction",
    "GraphicalStribeck",
    "graphical_stribeck",
    "DynamicFrictionFit",
    "simulate_dahl",
    "simulate_lugre",
    "fit_dahl",
    "fit_lugre",
]


# ======================================================================================
# errors
# ======================================================================================


class IdentificationError(ValueError):
    """The data cannot give the requested model (base class)."""


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


# ======================================================================================
# static models
# ======================================================================================


@dataclass(frozen=True)
class _StaticModel:
    name: str
    dip: str | None  # "exp" | "gauss" | None
    viscous: bool
    description: str
    source: str


STATIC_MODELS: dict[str, _StaticModel] = {
    m.name: m
    for m in (
        _StaticModel("stribeck", "exp", True,
                     "(F_c + (F_s - F_c) exp(-|v|/v_s)) sgn(v) + F_v v", "002 eq (1)"),
        _StaticModel("stribeck_gaussian", "gauss", True,
                     "(F_c + (F_s - F_c) exp(-(v/v_s)^2)) sgn(v) + F_v v", "003 eq (11)"),
        _StaticModel("coulomb_viscous", None, True, "F_c sgn(v) + F_v v",
                     "002 eq (1) without the Stribeck term"),
        _StaticModel("coulomb", None, False, "F_c sgn(v)", "Coulomb"),
    )
}

_UNITS = {"F_c": "N", "F_s": "N", "v_s": "m/s", "F_v": "N s/m", "k_p": "N/Pa"}


def _sgn(v: np.ndarray, v_eps: float) -> np.ndarray:
    if v_eps > 0.0:
        return np.tanh(v / v_eps)
    return np.sign(v)


def _phi(r: np.ndarray, dip: str) -> np.ndarray:
    return np.exp(-r) if dip == "exp" else np.exp(-r * r)


def _dphi_dvs(r: np.ndarray, dip: str, v_s: float) -> np.ndarray:
    """d phi(|v|/v_s) / d v_s."""
    if dip == "exp":
        return np.exp(-r) * r / v_s
    return np.exp(-r * r) * 2.0 * r * r / v_s


def static_friction(
    model: str,
    v: Any,
    parameters: Mapping[str, float],
    pressure: Any = None,
    sign_velocity: float = 0.0,
) -> np.ndarray:
    """Evaluate a static friction model (see the module docstring) at velocities ``v``.

    ``parameters`` uses the reported names ``F_c, F_s, v_s, F_v, k_p`` (missing ``k_p`` = 0).
    """
    spec = _model_spec(model)
    v = np.asarray(v, dtype=float)
    s = _sgn(v, sign_velocity)
    level = parameters["F_c"] * np.ones_like(v)
    if "k_p" in parameters:
        if pressure is None:
            raise ValueError("this pressure-dependent model needs pressure=")
        level = level + parameters["k_p"] * np.asarray(pressure, dtype=float)
    if spec.dip is not None:
        level = level + (parameters["F_s"] - parameters["F_c"]) * _phi(
            np.abs(v) / parameters["v_s"], spec.dip
        )
    out = s * level
    if spec.viscous:
        out = out + parameters["F_v"] * v
    return out


def _model_spec(model: str) -> _StaticModel:
    try:
        return STATIC_MODELS[model]
    except KeyError:
        raise ValueError(
            f"unknown friction model {model!r}; known: {', '.join(STATIC_MODELS)}"
        ) from None


class _Layout:
    """Internal (fitted) and reported parameter layouts of one static model variant.

    Internal: linear coefficients ``F_c [, k_p] [, dF] [, F_v]`` then ``v_s`` (dip models).
    Reported: ``F_c [, F_s, v_s] [, F_v] [, k_p]`` with ``F_s = F_c + dF``.
    """

    def __init__(self, spec: _StaticModel, pressure_dependent: bool) -> None:
        self.spec = spec
        self.pd = pressure_dependent
        lin = ["F_c"]
        if pressure_dependent:
            lin.append("k_p")
        if spec.dip is not None:
            lin.append("dF")
        if spec.viscous:
            lin.append("F_v")
        self.linear = lin
        self.internal = lin + (["v_s"] if spec.dip is not None else [])
        rep = ["F_c"]
        if spec.dip is not None:
            rep += ["F_s", "v_s"]
        if spec.viscous:
            rep.append("F_v")
        if pressure_dependent:
            rep.append("k_p")
        self.reported = rep
        # reported = M @ internal
        m = np.zeros((len(rep), len(self.internal)))
        ii = {n: j for j, n in enumerate(self.internal)}
        for i, n in enumerate(rep):
            if n == "F_s":
                m[i, ii["F_c"]] = 1.0
                m[i, ii["dF"]] = 1.0
            else:
                m[i, ii[n]] = 1.0
        self.M = m

    def linear_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array([-np.inf if n == "k_p" else 0.0 for n in self.linear])
        hi = np.full(len(self.linear), np.inf)
        return lo, hi

    def basis(self, v: np.ndarray, p: np.ndarray | None, v_s: float | None, v_eps: float) -> np.ndarray:
        s = _sgn(v, v_eps)
        cols = []
        for n in self.linear:
            if n == "F_c":
                cols.append(s)
            elif n == "k_p":
                cols.append(s * p)
            elif n == "dF":
                cols.append(s * _phi(np.abs(v) / v_s, self.spec.dip))
            elif n == "F_v":
                cols.append(v)
        return np.column_stack(cols)

    def model(self, theta: np.ndarray, v, p, v_eps) -> np.ndarray:
        v_s = theta[-1] if self.spec.dip is not None else None
        return self.basis(v, p, v_s, v_eps) @ theta[: len(self.linear)]

    def jac(self, theta: np.ndarray, v, p, v_eps) -> np.ndarray:
        v_s = theta[-1] if self.spec.dip is not None else None
        b = self.basis(v, p, v_s, v_eps)
        if self.spec.dip is None:
            return b
        dF = theta[self.linear.index("dF")]
        d_vs = _sgn(v, v_eps) * dF * _dphi_dvs(np.abs(v) / v_s, self.spec.dip, v_s)
        return np.column_stack([b, d_vs])

    def to_reported(self, theta: np.ndarray) -> np.ndarray:
        return self.M @ theta


@dataclass
class FrictionFit:
    """Result of a static friction fit (one direction or both with a symmetric model)."""

    model: str
    parameters: dict[str, float]
    std_errors: dict[str, float]
    covariance: np.ndarray
    metrics: dict[str, float]
    residuals: np.ndarray
    sign_velocity: float = 0.0
    pressure_dependent: bool = False
    direction: str = "both"  # "both" | "positive" | "negative"
    units: dict[str, str] = field(default_factory=dict)

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(self.parameters)

    def predict(self, v: Any, pressure: Any = None) -> np.ndarray:
        """Friction force [N] at velocities ``v`` (and pressures, if pressure-dependent)."""
        return static_friction(self.model, v, self.parameters, pressure, self.sign_velocity)

    __call__ = predict

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "direction": self.direction,
            "pressure_dependent": self.pressure_dependent,
            "parameters": dict(self.parameters),
            "std_errors": dict(self.std_errors),
            "units": dict(self.units),
            "metrics": dict(self.metrics),
        }


@dataclass
class AsymmetricFrictionFit:
    """Per-direction fits; reported parameters carry ``_pos`` / ``_neg`` suffixes."""

    positive: FrictionFit
    negative: FrictionFit
    metrics: dict[str, float]

    @property
    def model(self) -> str:
        return self.positive.model

    @property
    def pressure_dependent(self) -> bool:
        return self.positive.pressure_dependent

    @property
    def parameters(self) -> dict[str, float]:
        out = {f"{k}_pos": v for k, v in self.positive.parameters.items()}
        out.update({f"{k}_neg": v for k, v in self.negative.parameters.items()})
        return out

    @property
    def std_errors(self) -> dict[str, float]:
        out = {f"{k}_pos": v for k, v in self.positive.std_errors.items()}
        out.update({f"{k}_neg": v for k, v in self.negative.std_errors.items()})
        return out

    @property
    def units(self) -> dict[str, str]:
        out = {f"{k}_pos": v for k, v in self.positive.units.items()}
        out.update({f"{k}_neg": v for k, v in self.negative.units.items()})
        return out

    def predict(self, v: Any, pressure: Any = None) -> np.ndarray:
        """Positive-direction law for ``v > 0``, negative-direction law for ``v < 0``, 0 at 0."""
        v = np.asarray(v, dtype=float)
        p = None if pressure is None else np.broadcast_to(np.asarray(pressure, dtype=float), v.shape)
        out = np.zeros_like(v)
        pos = v > 0
        neg = v < 0
        if pos.any():
            out[pos] = self.positive.predict(v[pos], None if p is None else p[pos])
        if neg.any():
            out[neg] = self.negative.predict(v[neg], None if p is None else p[neg])
        return out

    __call__ = predict

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "direction": "asymmetric",
            "pressure_dependent": self.pressure_dependent,
            "parameters": self.parameters,
            "std_errors": self.std_errors,
            "units": self.units,
            "metrics": dict(self.metrics),
        }


def _as_arrays(points, force, pressure):
    if isinstance(points, FrictionPoints):
        if force is not None:
            raise TypeError("pass either FrictionPoints or (v, force), not both")
        v, f = points.v, points.force
        if pressure is None:
            pressure = points.pressure
    else:
        if force is None:
            raise TypeError("force is required when the first argument is a velocity array")
        v = np.atleast_1d(np.asarray(points, dtype=float))
        f = np.atleast_1d(np.asarray(force, dtype=float))
    if v.shape != f.shape or v.ndim != 1:
        raise ValueError(f"v and force must be 1-D of equal length, got {v.shape}, {f.shape}")
    p = None if pressure is None else np.broadcast_to(np.asarray(pressure, dtype=float), v.shape).copy()
    for name, arr in (("v", v), ("force", f), ("pressure", p)):
        if arr is not None and not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf")
    return v, f, p


def fit_friction(
    points: FrictionPoints | Any,
    force: Any = None,
    *,
    model: str = "stribeck",
    pressure: Any = None,
    pressure_dependent: bool = False,
    asymmetric: bool = False,
    sign_velocity: float = 0.0,
    sigma: Any = None,
    check_identifiability: bool = True,
    max_rel_std_error: float = 0.5,
) -> FrictionFit | AsymmetricFrictionFit:
    """Fit a static friction model to constant-velocity points.

    ``fit_friction(points, model=...)`` with :class:`FrictionPoints`, or
    ``fit_friction(v, force, model=...)``. ``model`` is one of :data:`STATIC_MODELS`
    (``stribeck`` 002 eq (1), ``stribeck_gaussian`` 003 eq (11), ``coulomb_viscous``,
    ``coulomb``). ``asymmetric=True`` fits each direction separately (002 sec. 4: "the
    frictional parameters may differ for positive and negative velocity domains").
    ``pressure_dependent=True`` adds ``k_p p`` to the Coulomb/static level (needs
    ``pressure``, or ``points.pressure``). ``sign_velocity`` > 0 replaces ``sign(v)`` by
    ``tanh(v / sign_velocity)`` (use the simulator's regularisation when fitting simulated data).
    ``sigma`` (per-point standard deviations) weights the residuals.

    Raises :class:`InsufficientDataError` / :class:`UnidentifiableError` (see module docstring).
    """
    v, f, p = _as_arrays(points, force, pressure)
    spec = _model_spec(model)
    if pressure_dependent and p is None:
        raise ValueError("pressure_dependent=True needs pressure (or FrictionPoints.pressure)")
    w = None
    if sigma is not None:
        w = np.broadcast_to(np.asarray(sigma, dtype=float), v.shape)
        if not np.all(np.isfinite(w) & (w > 0)):
            raise ValueError("sigma must be finite and > 0")
    if not (math.isfinite(sign_velocity) and sign_velocity >= 0.0):
        raise ValueError(f"sign_velocity must be >= 0 m/s, got {sign_velocity}")
    moving = v != 0.0
    if not moving.all():
        v, f = v[moving], f[moving]
        p = None if p is None else p[moving]
        w = None if w is None else w[moving]
    if not asymmetric:
        return _fit_one(v, f, p, w, spec, pressure_dependent, sign_velocity, "both",
                        check_identifiability, max_rel_std_error)
    fits = {}
    for name, mask in (("positive", v > 0), ("negative", v < 0)):
        fits[name] = _fit_one(
            v[mask], f[mask], None if p is None else p[mask], None if w is None else w[mask],
            spec, pressure_dependent, sign_velocity, name, check_identifiability,
            max_rel_std_error,
        )
    n_par = len(fits["positive"].parameters) + len(fits["negative"].parameters)
    out = AsymmetricFrictionFit(fits["positive"], fits["negative"], {})
    out.metrics = _metrics(f, out.predict(v, p), n_par)
    return out


def _fit_one(v, f, p, w, spec, pd, v_eps, direction, check, max_rel):
    lay = _Layout(spec, pd)
    n_par = len(lay.internal)
    n = int(v.size)
    label = "" if direction == "both" else f" ({direction} direction)"
    if n < n_par + 2:
        raise InsufficientDataError(
            f"model {spec.name!r}{label} has {n_par} parameters ({', '.join(lay.reported)}) and "
            f"needs at least {n_par + 2} points; got {n}"
        )
    n_speeds = np.unique(np.round(np.abs(v), 12)).size
    n_vel_params = (2 if spec.dip else 0) + (1 if spec.viscous else 0)
    if n_vel_params and n_speeds < n_vel_params + 1:
        raise InsufficientDataError(
            f"model {spec.name!r}{label} needs at least {n_vel_params + 1} distinct speeds to "
            f"separate its velocity-dependent parameters; the data have {n_speeds}"
        )
    if pd and np.ptp(p) <= 1e-9 * max(1.0, float(np.max(np.abs(p)))):
        raise UnidentifiableError(
            ["k_p"],
            f"k_p{label} is unidentifiable: all points were taken at the same pressure "
            f"({float(p[0]):.6g} Pa); measure at several pressures",
        )
    wt = np.ones(n) if w is None else 1.0 / w
    lo, hi = lay.linear_bounds()
    speed = np.abs(v)

    def solve_linear(v_s):
        b = lay.basis(v, p, v_s, v_eps) * wt[:, None]
        res = optimize.lsq_linear(b, f * wt, bounds=(lo, hi), method="bvls")
        return res.x, float(np.sum((b @ res.x - f * wt) ** 2))

    if spec.dip is None:
        theta, _ = solve_linear(None)
        bounds_lo, bounds_hi = lo, hi
    else:
        vs_lo = max(float(speed.min()) / 100.0, 1e-9)
        vs_hi = 10.0 * float(speed.max())
        best = None
        for v_s in np.geomspace(vs_lo * 1.01, vs_hi / 1.01, 80):
            c, cost = solve_linear(v_s)
            if best is None or cost < best[0]:
                best = (cost, c, v_s)
        theta = np.append(best[1], best[2])
        bounds_lo = np.append(lo, vs_lo)
        bounds_hi = np.append(hi, vs_hi)

    def fun(th):
        return (lay.model(th, v, p, v_eps) - f) * wt

    def jac(th):
        return lay.jac(th, v, p, v_eps) * wt[:, None]

    theta = np.clip(theta, bounds_lo, bounds_hi)
    # least_squares needs strictly feasible starts for bounded 'trf'
    span = np.where(np.isfinite(bounds_hi - bounds_lo), bounds_hi - bounds_lo, 1.0)
    theta = np.where(theta <= bounds_lo, bounds_lo + 1e-9 * np.maximum(span, 1.0), theta)
    theta = np.where(theta >= bounds_hi, bounds_hi - 1e-9 * np.maximum(span, 1.0), theta)
    sol = optimize.least_squares(
        fun, theta, jac=jac, bounds=(bounds_lo, bounds_hi), method="trf", x_scale="jac",
        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000,
    )
    theta = sol.x
    r = fun(theta)
    dof = n - n_par
    s2 = float(r @ r) / dof
    jac_int = jac(theta)
    # reported-parameter Jacobian: J_rep = J_int M^-1 (M is square and invertible)
    m_inv = np.linalg.inv(lay.M)
    j_rep = jac_int @ m_inv
    cov, singular = _covariance(j_rep, s2)
    rep = lay.to_reported(theta)
    names = lay.reported
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    params = {nm: float(x) for nm, x in zip(names, rep)}
    std = {nm: float(x) for nm, x in zip(names, se)}
    y_hat = lay.model(theta, v, p, v_eps)
    fit = FrictionFit(
        model=spec.name,
        parameters=params,
        std_errors=std,
        covariance=cov,
        metrics=_metrics(f, y_hat, n_par),
        residuals=f - y_hat,
        sign_velocity=v_eps,
        pressure_dependent=pd,
        direction=direction,
        units={nm: _UNITS[nm] for nm in names},
    )
    if check:
        _check_identifiable(fit, spec, speed, f, p, singular, label, max_rel)
    return fit


def _covariance(j: np.ndarray, s2: float) -> tuple[np.ndarray, list[int]]:
    """``(J^T J)^-1 s^2`` via SVD; columns in a numerically null direction get inf variance."""
    scale = np.linalg.norm(j, axis=0)
    scale[scale == 0] = 1.0
    js = j / scale
    u, sv, vt = np.linalg.svd(js, full_matrices=False)
    tol = sv.max() * max(j.shape) * np.finfo(float).eps * 1e3 if sv.size else 0.0
    good = sv > tol
    inv = (vt[good].T / sv[good] ** 2) @ vt[good]
    cov = inv / np.outer(scale, scale) * s2
    singular: list[int] = []
    if not good.all():
        null = vt[~good]
        singular = [int(i) for i in np.flatnonzero(np.max(np.abs(null), axis=0) > 0.1)]
        for i in singular:
            cov[i, :] = cov[:, i] = np.inf
    return cov, singular


def _check_identifiable(fit, spec, speed, forces, pressure, singular, label, max_rel):
    pr = fit.parameters
    se = fit.std_errors
    names = list(pr)
    if singular:
        bad = [names[i] for i in singular]
        raise UnidentifiableError(
            bad, f"{', '.join(bad)}{label} unidentifiable: the data do not constrain them "
            f"(singular Jacobian; slowest point {float(speed.min()) * 1e3:.4g} mm/s, fastest "
            f"{float(speed.max()) * 1e3:.4g} mm/s)"
        )
    if spec.dip is not None:
        r_min = float(speed.min()) / pr["v_s"]
        phi_min = math.exp(-r_min) if spec.dip == "exp" else math.exp(-r_min * r_min)
        if phi_min < 0.05:
            raise UnidentifiableError(
                ["F_s", "v_s"],
                f"F_s and v_s{label} are unidentifiable: the slowest point "
                f"({float(speed.min()) * 1e3:.4g} mm/s) lies where the Stribeck term has decayed "
                f"below 5 % (fitted v_s = {pr['v_s'] * 1e3:.3g} mm/s); there are no "
                "low-velocity points to see the Stribeck dip. Measure slower or fit "
                "'coulomb_viscous'.",
            )
        dip = pr["F_s"] - pr["F_c"]
        se_dip = math.sqrt(max(fit.covariance[0, 0] + fit.covariance[1, 1] - 2 * fit.covariance[0, 1], 0.0))
        if not dip > 2.0 * se_dip:
            raise UnidentifiableError(
                ["F_s", "v_s"],
                f"F_s and v_s{label} are unidentifiable: the fitted Stribeck dip is not "
                f"significant (F_s - F_c = {dip:.3g} +- {se_dip:.3g} N, slowest point "
                f"{float(speed.min()) * 1e3:.4g} mm/s): either the data have no low-velocity "
                "points to see the dip or there is no dip; measure slower or fit "
                "'coulomb_viscous'",
            )
    # a parameter is "determined" when its uncertainty moves the model force over the data's
    # range by less than max_rel of the force scale (v_s: relative to itself)
    f_scale = float(np.max(np.abs(forces))) if forces.size else 1.0
    span = {"F_c": 1.0, "F_s": 1.0, "F_v": float(speed.max()),
            "k_p": float(np.ptp(pressure)) if pressure is not None else 0.0}
    bad = []
    for n in names:
        val, s = pr[n], se[n]
        if not math.isfinite(s):
            bad.append(n)
        elif n == "v_s":
            if s > max_rel * abs(val):
                bad.append(n)
        elif s * span[n] > max_rel * f_scale:
            bad.append(n)
    if bad:
        detail = ", ".join(f"{n} = {pr[n]:.4g} +- {se[n]:.3g}" for n in bad)
        raise UnidentifiableError(
            bad, f"{', '.join(bad)}{label} poorly identified (standard error moves the force "
            f"by more than {max_rel:g} of its scale {f_scale:.4g} N; v_s: relative error "
            f"> {max_rel:g}): {detail}; the data are too poor for model {spec.name!r}"
        )


# ======================================================================================
# graphical construction (004 sec. 3.1)
# ======================================================================================


@dataclass
class GraphicalStribeck:
    """Result of the graphical Stribeck construction of 004 sec. 3.1 (one direction).

    ``F_s`` intercept of the low-speed line f1 (slope ``-k``), ``F_c`` and ``sigma`` intercept
    and slope of the high-speed line f2, ``v_s`` where f1 meets the horizontal ``F = F_c``.
    """

    F_s: float
    F_c: float
    v_s: float
    sigma: float
    k: float
    split_speed: float
    n_low: int
    n_high: int

    @property
    def parameters(self) -> dict[str, float]:
        return {"F_c": self.F_c, "F_s": self.F_s, "v_s": self.v_s, "F_v": self.sigma}


def graphical_stribeck(
    v: Any,
    force: Any,
    *,
    low_speed_max: float | None = None,
    high_speed_min: float | None = None,
) -> GraphicalStribeck:
    """The graphical construction of 004 sec. 3.1 / Fig. 3 on one direction's points.

    004's recipe: the low-speed part of the friction curve is approximately a line f1 with
    slope ``-k`` whose ordinate intercept is ``F_s``; the high-speed part is a line f2 with
    slope ``sigma`` and intercept ``F_c``; the horizontal line through ``F_c`` meets the
    low-speed line at the critical Stribeck velocity, ``v_s = (F_s - F_c) / k``. (The text
    says the horizontal line meets "the curve"; for a curve above ``F_c + sigma v`` everywhere,
    as 002 eq (1) is, only the low-speed line f1 can be meant.) Works on speeds ``|v|`` and
    magnitudes ``|F|``.

    ``low_speed_max`` / ``high_speed_min`` [m/s] pick the points of each line; without them the
    split speed minimising the total squared error of the two lines is used (at least 3 points
    per line).

    For the exponential model 002 eq (1), the tangent at 0 has slope
    ``k = (F_s - F_c) / v_s - sigma``; if f1 were that tangent the construction would return
    ``v_s (F_s - F_c) / (F_s - F_c - sigma v_s)`` (5.3 % high at 004 Table 2). A chord through
    points spread over the dip is flatter than the tangent: ``F_s`` comes out low and ``v_s``
    high (tests quantify it). ``F_c`` and ``sigma`` are unbiased once the high-speed points lie
    beyond about 5 ``v_s``.
    """
    s = np.abs(np.asarray(v, dtype=float))
    f = np.abs(np.asarray(force, dtype=float))
    if s.shape != f.shape or s.ndim != 1:
        raise ValueError("v and force must be 1-D of equal length")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(f))):
        raise ValueError("v and force must be finite")
    order = np.argsort(s)
    s, f = s[order], f[order]
    n = s.size
    if n < 6:
        raise InsufficientDataError(
            f"the graphical construction needs at least 6 points (3 per line), got {n}"
        )

    def line(mask):
        a = np.column_stack([np.ones(int(mask.sum())), s[mask]])
        coef, *_ = np.linalg.lstsq(a, f[mask], rcond=None)
        sse = float(np.sum((a @ coef - f[mask]) ** 2))
        return coef, sse

    if low_speed_max is None and high_speed_min is None:
        best = None
        for i in range(3, n - 2):
            lo = np.arange(n) < i
            if np.unique(s[lo]).size < 2 or np.unique(s[~lo]).size < 2:
                continue
            c1, e1 = line(lo)
            c2, e2 = line(~lo)
            if best is None or e1 + e2 < best[0]:
                best = (e1 + e2, lo, ~lo, 0.5 * (s[i - 1] + s[i]))
        if best is None:
            raise InsufficientDataError("too few distinct speeds for two lines")
        _, low, high, split = best
    else:
        low = s <= (low_speed_max if low_speed_max is not None else high_speed_min)
        high = s >= (high_speed_min if high_speed_min is not None else low_speed_max)
        split = float(low_speed_max if low_speed_max is not None else high_speed_min)
        for nm, m in (("low-speed", low), ("high-speed", high)):
            if m.sum() < 2 or np.unique(s[m]).size < 2:
                raise InsufficientDataError(f"the {nm} line needs at least 2 distinct speeds")
    (f_s, slope1), _ = line(low)
    (f_c, sigma), _ = line(high)
    k = -slope1
    if not k > 0:
        raise UnidentifiableError(
            ["F_s", "v_s"],
            "the low-speed points do not fall with speed (slope "
            f"{slope1:.4g} N s/m): no Stribeck dip, F_s and v_s are unidentifiable",
        )
    v_s = (f_s - f_c) / k
    if not v_s > 0:
        raise UnidentifiableError(
            ["v_s"], f"F_s = {f_s:.4g} N is not above F_c = {f_c:.4g} N: v_s is unidentifiable"
        )
    return GraphicalStribeck(
        F_s=float(f_s), F_c=float(f_c), v_s=float(v_s), sigma=float(sigma), k=float(k),
        split_speed=float(split), n_low=int(low.sum()), n_high=int(high.sum()),
    )


# ======================================================================================
# dynamic models: Dahl (001 eq (1)) and LuGre, fitted on time series
# ======================================================================================


@nb.njit(cache=True, error_model="numpy")
def _dahl_sim(t, v, f_c, sigma0, f_v, f0, n_sub):
    n = t.shape[0]
    out = np.empty(n)
    fd = f0
    out[0] = fd + f_v * v[0]
    for k in range(n - 1):
        h = (t[k + 1] - t[k]) / n_sub
        for j in range(n_sub):
            a = (j + 0.5) / n_sub
            vm = v[k] + a * (v[k + 1] - v[k])
            fd = dahl_friction_step_exact(fd, vm, f_c, sigma0, h)
        out[k + 1] = fd + f_v * v[k + 1]
    return out


@nb.njit(cache=True, error_model="numpy")
def _lugre_sim(t, v, f_c, f_s, v_s, sigma0, sigma1, sigma2, z0, n_sub):
    n = t.shape[0]
    out = np.empty(n)
    z = z0
    zdot = v[0] - sigma0 * abs(v[0]) * z / lugre_g(v[0], f_c, f_s, v_s)
    out[0] = sigma0 * z + sigma1 * zdot + sigma2 * v[0]
    for k in range(n - 1):
        h = (t[k + 1] - t[k]) / n_sub
        for j in range(n_sub):
            a = (j + 0.5) / n_sub
            vm = v[k] + a * (v[k + 1] - v[k])
            z = lugre_bristle_step_exact(z, vm, f_c, f_s, v_s, sigma0, h)
        vk = v[k + 1]
        zdot = vk - sigma0 * abs(vk) * z / lugre_g(vk, f_c, f_s, v_s)
        out[k + 1] = sigma0 * z + sigma1 * zdot + sigma2 * vk
    return out


def _check_series(t, v, f=None):
    t = np.ascontiguousarray(t, dtype=float)
    v = np.ascontiguousarray(v, dtype=float)
    if t.ndim != 1 or t.shape != v.shape:
        raise ValueError(f"t and v must be 1-D of equal length, got {t.shape}, {v.shape}")
    if t.size < 3:
        raise InsufficientDataError(f"need at least 3 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise ValueError("t and v must be finite")
    if not np.all(np.diff(t) > 0):
        raise ValueError("t must be strictly increasing")
    if f is not None:
        f = np.ascontiguousarray(f, dtype=float)
        if f.shape != t.shape:
            raise ValueError(f"force has shape {f.shape}, expected {t.shape}")
        if not np.all(np.isfinite(f)):
            raise ValueError("force must be finite")
    return t, v, f


def simulate_dahl(
    t: Any, v: Any, f_c: float, sigma0: float, f_v: float = 0.0, f0: float = 0.0, n_sub: int = 4
) -> np.ndarray:
    """Friction force of the Dahl model (001 eq (1)) plus ``f_v v`` under a velocity record.

    The Dahl state is advanced with the exact frozen-velocity update
    (:func:`hydro_envs.laws.friction.dahl_friction_step_exact`) in ``n_sub`` sub-steps per
    sample, the velocity linearly interpolated (midpoint of each sub-step). ``f0`` is the
    Dahl force at ``t[0]``.
    """
    t, v, _ = _check_series(t, v)
    if not (f_c > 0 and sigma0 > 0):
        raise ValueError("f_c and sigma0 must be > 0")
    return _dahl_sim(t, v, float(f_c), float(sigma0), float(f_v), float(f0), int(n_sub))


def simulate_lugre(
    t: Any,
    v: Any,
    f_c: float,
    f_s: float,
    v_s: float,
    sigma0: float,
    sigma1: float,
    sigma2: float,
    z0: float = 0.0,
    n_sub: int = 4,
) -> np.ndarray:
    """LuGre friction force under a velocity record (exact bristle updates, ``n_sub`` per sample).

    ``F = sigma0 z + sigma1 dz/dt + sigma2 v``, ``dz/dt = v - sigma0 |v| z / g(v)``,
    ``g(v) = f_c + (f_s - f_c) exp(-(v/v_s)^2)`` (:mod:`hydro_envs.laws.friction`).
    """
    t, v, _ = _check_series(t, v)
    if not (f_c > 0 and f_s > 0 and v_s > 0 and sigma0 > 0):
        raise ValueError("f_c, f_s, v_s and sigma0 must be > 0")
    return _lugre_sim(t, v, float(f_c), float(f_s), float(v_s), float(sigma0), float(sigma1),
                      float(sigma2), float(z0), int(n_sub))


@dataclass
class DynamicFrictionFit:
    """Result of a Dahl or LuGre fit on a time series (force residuals)."""

    model: str
    parameters: dict[str, float]
    std_errors: dict[str, float]
    covariance: np.ndarray
    metrics: dict[str, float]
    initial_state: float
    units: dict[str, str]
    n_sub: int

    def predict(self, t: Any, v: Any, initial_state: float | None = None) -> np.ndarray:
        x0 = self.initial_state if initial_state is None else initial_state
        p = self.parameters
        if self.model == "dahl":
            return simulate_dahl(t, v, p["F_c"], p["sigma0"], p["F_v"], x0, self.n_sub)
        return simulate_lugre(t, v, p["F_c"], p["F_s"], p["v_s"], p["sigma0"], p["sigma1"],
                              p["sigma2"], x0, self.n_sub)

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "parameters": dict(self.parameters),
            "std_errors": dict(self.std_errors),
            "units": dict(self.units),
            "metrics": dict(self.metrics),
            "initial_state": self.initial_state,
        }


def _fit_series(names, units, simulate, theta0, lo, hi, f, model, check, max_rel, n_state_index):
    """Bounded least squares in log-parameters (all positive) except the state (last)."""
    n = f.size
    npar = len(theta0)
    if n < npar + 2:
        raise InsufficientDataError(f"{model}: need at least {npar + 2} samples, got {n}")
    is_log = np.array([i != n_state_index for i in range(npar)])

    def to_theta(q):
        return np.where(is_log, np.exp(q), q)

    def to_q(x):
        x = np.asarray(x, dtype=float)
        out = x.copy()
        out[is_log] = np.log(x[is_log])
        return out

    q0, qlo, qhi = to_q(theta0), to_q(lo), to_q(hi)
    q0 = np.clip(q0, qlo + 1e-9, qhi - 1e-9)

    def fun(q):
        return simulate(to_theta(q)) - f

    sol = optimize.least_squares(fun, q0, bounds=(qlo, qhi), method="trf", x_scale="jac",
                                 diff_step=1e-7, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                 max_nfev=400)
    theta = to_theta(sol.x)
    r = fun(sol.x)
    s2 = float(r @ r) / (n - npar)
    # Jacobian in the reported (linear) parameters: dF/dtheta = dF/dq * dq/dtheta
    jq = sol.jac
    dq = np.where(is_log, 1.0 / theta, 1.0)
    j = jq * dq[None, :]
    cov, singular = _covariance(j, s2)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    y_hat = f + r
    params = {nm: float(x) for nm, x in zip(names, theta) if nm != "state0"}
    std = {nm: float(x) for nm, x in zip(names, se) if nm != "state0"}
    fit = DynamicFrictionFit(
        model=model, parameters=params, std_errors=std, covariance=cov,
        metrics=_metrics(f, y_hat, npar), initial_state=float(theta[n_state_index]),
        units={nm: units[nm] for nm in params}, n_sub=0,
    )
    if check:
        bad = [names[i] for i in singular if names[i] != "state0"]
        bad += [nm for nm in params if nm not in bad and (
            not math.isfinite(std[nm]) or std[nm] > max_rel * abs(params[nm]))]
        if bad:
            detail = ", ".join(f"{nm} = {params[nm]:.4g} +- {std[nm]:.3g}" for nm in bad)
            raise UnidentifiableError(
                bad, f"{model}: {', '.join(bad)} poorly identified ({detail}); the velocity "
                "record does not excite them (LuGre sigma0/sigma1 need velocity reversals with "
                "pre-sliding, F_s/v_s need slow sliding, F_v fast sliding)"
            )
    return fit


def fit_dahl(
    t: Any,
    v: Any,
    force: Any,
    *,
    viscous: bool = True,
    n_sub: int = 4,
    check_identifiability: bool = True,
    max_rel_std_error: float = 0.5,
) -> DynamicFrictionFit:
    """Fit the Dahl model of 001 eq (1) (``F_c``, ``sigma0`` [N/m]) plus viscous ``F_v v``.

    The model is simulated under the measured velocity with the candidate parameters
    (:func:`simulate_dahl`) and the force residuals are minimised (bounded least squares in
    log-parameters, positive parameters). The Dahl force at ``t[0]`` is fitted as a nuisance
    state (``initial_state``). Without ``viscous`` ``F_v`` is fixed at 0.
    """
    t, v, f = _check_series(t, v, force)
    # initial guesses: F_c from the sliding force level, sigma0 from the presliding slope
    big = np.abs(v) > 0.5 * np.max(np.abs(v))
    fc0 = float(np.median(np.abs(f[big]))) if big.any() else float(np.max(np.abs(f)))
    fc0 = max(fc0, 1e-6)
    names = ["F_c", "sigma0", "F_v", "state0"]
    units = {"F_c": "N", "sigma0": "N/m", "F_v": "N s/m", "state0": "N"}
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    span = max(float(np.ptp(x)), 1e-9)
    fv_fix = 0.0

    def sim(th):
        fv = th[2] if viscous else fv_fix
        return _dahl_sim(t, v, th[0], th[1], fv, th[3], n_sub)

    # coarse grid on sigma0 for a global start
    best = None
    for s0 in np.geomspace(fc0 / span, fc0 / span * 1e6, 25):
        th = np.array([fc0, s0, 1e-3 * fc0 / max(np.max(np.abs(v)), 1e-9), float(np.clip(f[0], -0.99 * fc0, 0.99 * fc0))])
        c = float(np.sum((sim(th) - f) ** 2))
        if best is None or c < best[0]:
            best = (c, th)
    theta0 = best[1]
    lo = np.array([1e-6 * fc0, 1e-3 * fc0 / span, 1e-9, -10 * fc0])
    hi = np.array([1e3 * fc0, 1e12 * fc0 / span, 1e9, 10 * fc0])
    if not viscous:
        names = ["F_c", "sigma0", "state0"]
        sim3 = lambda th: _dahl_sim(t, v, th[0], th[1], 0.0, th[2], n_sub)  # noqa: E731
        fit = _fit_series(names, units, sim3, theta0[[0, 1, 3]], lo[[0, 1, 3]], hi[[0, 1, 3]],
                          f, "dahl", check_identifiability, max_rel_std_error, 2)
        fit.parameters["F_v"] = 0.0
        fit.std_errors["F_v"] = 0.0
        fit.units["F_v"] = "N s/m"
    else:
        fit = _fit_series(names, units, sim, theta0, lo, hi, f, "dahl",
                          check_identifiability, max_rel_std_error, 3)
    fit.n_sub = n_sub
    return fit


def fit_lugre(
    t: Any,
    v: Any,
    force: Any,
    *,
    n_sub: int = 4,
    initial: Mapping[str, float] | None = None,
    check_identifiability: bool = True,
    max_rel_std_error: float = 0.5,
) -> DynamicFrictionFit:
    """Fit the LuGre model (``F_c, F_s, v_s, sigma0, sigma1, sigma2``) to a force time series.

    Starting values: the static part from a Gaussian-Stribeck fit of the samples with
    ``|v|`` above 20 % of its maximum (there the bristles have relaxed), ``sigma0`` and
    ``sigma1`` from a coarse grid and then a fit of ``(sigma0, sigma1, z0)`` with the static
    part held; ``initial`` overrides any start value. Finally all six plus the initial bristle
    state are fitted by bounded least squares on the force residuals of :func:`simulate_lugre`.

    Excitation: the static part needs sliding over a range of speeds slow enough for the
    bristles to follow (bristle time constant ``g(v) / (sigma0 |v|)``); ``sigma0`` and
    ``sigma1`` need pre-sliding -- velocity reversals whose displacement stays below
    ``F_s / sigma0`` -- and ``sigma2`` fast sliding. A slow sine plus a small-amplitude dither at
    rest does all three (see the tests).
    """
    t, v, f = _check_series(t, v, force)
    speed = np.abs(v)
    vmax = float(speed.max())
    if vmax <= 0:
        raise InsufficientDataError("the velocity record never moves")
    # static start from the faster samples (there the bristles have relaxed, sigma1 dz/dt ~ 0)
    sliding = speed > 0.2 * vmax
    try:
        st = fit_friction(v[sliding], f[sliding], model="stribeck_gaussian",
                          check_identifiability=False)
        p0 = dict(st.parameters)
    except IdentificationError:
        med = float(np.median(np.abs(f[sliding]))) if sliding.any() else float(np.max(np.abs(f)))
        p0 = {"F_c": med, "F_s": 1.2 * med, "v_s": 0.1 * vmax, "F_v": 0.0}
    fc = max(p0["F_c"], 1e-3 * max(p0["F_s"], 1e-3))
    fs = max(p0["F_s"], fc * 1.01)
    vs = max(p0["v_s"], 1e-6)
    s2_0 = max(p0.get("F_v", 0.0), 1e-6)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    span = max(float(np.ptp(x)), 1e-9)
    names = ["F_c", "F_s", "v_s", "sigma0", "sigma1", "sigma2", "state0"]
    units = {"F_c": "N", "F_s": "N", "v_s": "m/s", "sigma0": "N/m", "sigma1": "N s/m",
             "sigma2": "N s/m", "state0": "m"}

    def sim(th):
        return _lugre_sim(t, v, th[0], th[1], th[2], th[3], th[4], th[5], th[6], n_sub)

    # coarse grid on (sigma0, sigma1) with the static part fixed
    best = None
    for s0 in np.geomspace(fs / span, fs / span * 1e6, 25):
        for s1 in fs / vmax * np.geomspace(1e-3, 1e1, 5):
            th = np.array([fc, fs, vs, s0, s1, s2_0, 0.0])
            c = float(np.sum((sim(th) - f) ** 2))
            if best is None or c < best[0]:
                best = (c, th)
    theta0 = best[1]
    if initial:
        for k, val in initial.items():
            if k not in names:
                raise ValueError(f"unknown LuGre parameter {k!r}; known: {names}")
            theta0[names.index(k)] = float(val)
    zmax = 10 * fs / theta0[3]
    lo = np.array([1e-6 * fc, 1e-6 * fs, 1e-6 * vmax, 1e-3 * fs / span, 1e-9 * fs / vmax,
                   1e-9 * fs / vmax, -zmax])
    hi = np.array([1e3 * fs, 1e3 * fs, 1e3 * vmax, 1e14 * fs / span, 1e6 * fs / vmax,
                   1e6 * fs / vmax, zmax])
    theta0 = np.clip(theta0, lo * (1 + 1e-6), hi * (1 - 1e-6))
    # stage 1: dynamic parameters and the initial state with the static part held
    dyn = [3, 4, 6]

    def sim_dyn(q):
        th = theta0.copy()
        th[dyn] = q
        return sim(th)

    stage = _fit_series([names[i] for i in dyn], units, sim_dyn, theta0[dyn], lo[dyn], hi[dyn],
                        f, "lugre", False, max_rel_std_error, 2)
    theta0[3] = stage.parameters["sigma0"]
    theta0[4] = stage.parameters["sigma1"]
    theta0[6] = stage.initial_state
    fit = _fit_series(names, units, sim, theta0, lo, hi, f, "lugre", check_identifiability,
                      max_rel_std_error, 6)
    fit.n_sub = n_sub
    return fit
