"""Dynamic friction (Dahl, 001 eq (1); LuGre) simulated on a velocity record and fitted to the force."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np
from scipy import optimize

from hydro_envs.laws.friction import (
    dahl_friction_step_exact,
    lugre_bristle_step_exact,
    lugre_g,
)

from identification.friction.data import IdentificationError, InsufficientDataError, UnidentifiableError, _metrics
from identification.friction.static import _covariance, fit_friction

__all__ = ['DynamicFrictionFit', 'simulate_dahl', 'simulate_lugre', 'fit_dahl', 'fit_lugre',
           'bristle_stiffness_from_loading']


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


def bristle_stiffness_from_loading(x: Any, force: Any) -> tuple[float, float]:
    """``(sigma0, F_b)`` of the LuGre pre-sliding loading branch fitted to a record of the
    deflection ``x`` [m] and friction force ``force`` [N] of a body loaded slowly from rest
    (:func:`hydro_envs.plants.servo_cylinder.friction_test.presliding_test`).

    At speeds far below the Stribeck velocity the level is the breakaway force ``F_b``, and the
    rate law ``dz/dx = 1 - sigma0 z / F_b`` integrates to ``F = F_b (1 - exp(-sigma0 x / F_b))``
    (x from rest, monotone loading); the slope at the start is ``sigma0``. Least squares on that
    branch (:func:`scipy.optimize.least_squares`); :class:`InsufficientDataError` for fewer
    than 10 samples or a record that does not load monotonically."""
    x = np.asarray(x, dtype=float).reshape(-1)
    f = np.asarray(force, dtype=float).reshape(-1)
    if x.shape != f.shape:
        raise ValueError(f"x has {x.size} samples, force {f.size}; they must be equal")
    ok = np.isfinite(x) & np.isfinite(f) & (x > 0) & (f > 0)
    x, f = x[ok], f[ok]
    if x.size < 10 or np.any(np.diff(x) < 0):
        raise InsufficientDataError("bristle_stiffness_from_loading needs >= 10 samples of monotone loading "
                                    f"(x > 0, F > 0); got {x.size}")
    fb0 = 1.05 * float(f.max())
    k0 = float(np.polyfit(x[: max(3, x.size // 10)], f[: max(3, x.size // 10)], 1)[0])

    def res(th):
        s0, fb = np.exp(th)
        return (fb * (1.0 - np.exp(-s0 * x / fb)) - f) / fb

    sol = optimize.least_squares(res, np.log([max(k0, 1.0), fb0]), method="lm")
    s0, fb = np.exp(sol.x)
    return float(s0), float(fb)
