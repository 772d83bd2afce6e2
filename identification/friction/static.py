"""Static friction laws (Coulomb, Stribeck variants, pressure-dependent) fitted to constant-velocity points, symmetric or per direction, with identifiability checks."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize


from identification.friction.data import FrictionPoints, InsufficientDataError, UnidentifiableError, _metrics

__all__ = ['STATIC_MODELS', 'static_friction', 'FrictionFit', 'AsymmetricFrictionFit', 'fit_friction']


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


