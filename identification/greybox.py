r"""Grey-box identification: nonlinear least squares of a plant's physical parameters.

Given a parameter dataclass instance ``base`` (any :class:`hydro_envs.params.PhysicalParams`
plant), the names of the parameters to fit, the plant's kernel id and one or several measured
experiments (initial state, input sequence, measured output channels), :func:`fit_greybox`
finds the parameters that minimise the normalised output error

.. math:: S(\theta) = \sum_e \sum_c \sum_k \left( (y_{e,c,k} - \hat y_{e,c,k}(\theta)) / \sigma_c \right)^2

by ``scipy.optimize.least_squares`` (``trf``, bounded). The model outputs are a free-run
simulation of the compiled plant (:func:`hydro_envs.sim.simulate`, RK4 with zero-order-hold
input, the same integrator the envs use).

Speed: every Jacobian evaluation simulates *all* its candidate parameter sets -- the central
finite-difference perturbations ``theta +- h e_i`` of every parameter, for every experiment --
as copies of one batched, threaded :func:`~hydro_envs.sim.simulate` call per experiment (one
``prange`` over copies, each copy integrating its whole record). All copies of a call use the same number of RK4
sub-steps (from the plant's ``stiffness_modes`` at the most demanding candidate), so a
perturbation never changes the integration grid and the finite differences stay smooth.

Parameterisation: each fitted parameter is optimised as ``log(value)`` (default when its
allowed range is positive) or ``value / |base value|``; bounds are the dataclass's allowed
range (open ends nudged inside). Candidates are packed straight into the kernel's parameter
array (cross-field relations such as ``F_s >= F_c`` are checked once, on the result).

Measurement convention: sample ``k`` of an experiment is the state at ``t_k``; input sample
``u_k`` is held over ``[t_k, t_k+1)`` (the last input sample is used only by derivative
channels). Output channels (:class:`OutputChannel`) read a state component (``x``, ``p1``),
a component of the state derivative (the shaking table's accelerometer reads ``dv/dt``) or any
function of the state trajectory.

Weights: residuals of channel ``c`` are divided by ``sigma_c`` -- given, or by default first
the RMS of the measured channel about its mean and, after a first fit (``reweight=True``), the
RMS of that channel's residuals (a noise estimate), followed by a warm-started refit. With
noise-level weights the scaled residuals are about unit-variance and the covariance below is
the usual Gauss-Newton one.

Statistics (at the optimum, ``J`` the Jacobian of the weighted residuals in theta):

* covariance ``C = s^2 (J^T J)^-1``, ``s^2 = S / (N - p)``; standard errors in the parameter's
  own units by the delta method; 95 % confidence intervals ``theta +- t_0.975,N-p se`` mapped
  back (asymmetric, positive for log-scaled parameters);
* identifiability: the condition number of ``J`` with unit-norm columns (scale-free; above
  ``1e6`` the data cannot separate the parameters), the correlation matrix of ``C`` and every
  pair with ``|rho| > 0.95`` named. ``(J^T J)^-1`` is formed from the eigen-decomposition of the
  column-scaled ``J^T J`` with eigenvalues floored at ``1e-14`` of the largest, so a
  rank-deficient problem (two parameters that enter only as a product) reports a correlation
  of -1 along the unidentifiable direction and huge standard errors instead of failing;
* per channel: NRMSE ``||y - y_hat|| / ||y - mean(y)||`` and MSE (in the channel's unit^2).

Source of the method: the nonlinear least-squares (NLSM) estimation of seed 003 sec. 3.4 eq
(21)-(22) (``003_54985feb8193da53.txt``: S = sum r_i^2 over velocity and acceleration of the
shaking table); statistics as in Seber & Wild, Nonlinear Regression (1989), ch. 2 and 5.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy import optimize, stats

from hydro_envs.jsonutil import to_jsonable as _jsonable
from hydro_envs.params import ParameterError, PhysicalParams
from identification.greybox_problem import (
    Experiment,
    GreyboxError,
    OutputChannel,
    _build_problem,
    _Problem,
    experiment_from_measured,
    plant_setup,
    simulate_outputs,
    supported_plants,
)

__all__ = [
    "GreyboxError",
    "OutputChannel",
    "Experiment",
    "GreyboxResult",
    "plant_setup",
    "supported_plants",
    "simulate_outputs",
    "fit_greybox",
    "experiment_from_measured",
]

CORRELATION_LIMIT = 0.95
CONDITION_LIMIT = 1e6


@dataclasses.dataclass
class GreyboxResult:
    """A grey-box fit with its statistics (see the module docstring)."""

    plant: str
    names: tuple[str, ...]
    values: dict[str, float]
    initial: dict[str, float]
    std_errors: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    units: dict[str, str]
    log_scaled: dict[str, bool]
    covariance: np.ndarray  # of the values (parameter units)
    correlation: np.ndarray
    condition_number: float  # of J with unit-norm columns
    correlated_pairs: list[tuple[str, str, float]]
    nrmse: dict[str, float]  # per channel, all experiments
    mse: dict[str, float]  # per channel, unit^2
    nrmse_per_experiment: list[dict[str, float]]
    mse_per_experiment: list[dict[str, float]]
    sigma: dict[str, float]
    cost: float  # 0.5 sum of weighted squared residuals
    noise_variance: float  # s^2 = 2 cost / (N - p)
    n_residuals: int
    n_substeps: int
    nfev: int
    njev: int
    success: bool
    message: str
    seconds: float
    params: PhysicalParams | None  # the fitted parameter set (None if a relation fails)
    notes: list[str] = dataclasses.field(default_factory=list)
    offsets: dict[str, float] = dataclasses.field(default_factory=dict)  # profiled sensor offsets
    # trial points rejected as stiffer than ``max_substep_ratio`` allows (fit_greybox)
    substep_rejections: int = 0

    @property
    def identifiable(self) -> bool:
        return bool(self.condition_number < CONDITION_LIMIT and not self.correlated_pairs
                    and all(math.isfinite(v) for v in self.std_errors.values()))

    def to_json_dict(self) -> dict[str, Any]:
        return _jsonable({
            "method": "grey-box nonlinear least squares (trf, bounded, batched finite-difference Jacobian)",
            "plant": self.plant,
            "parameters": self.values,
            "std_errors": self.std_errors,
            "ci95": {k: list(v) for k, v in self.ci95.items()},
            "initial": self.initial,
            "units": self.units,
            "log_scaled": self.log_scaled,
            "identifiability": {
                "condition_number": self.condition_number,
                "correlation": {"names": list(self.names), "matrix": self.correlation},
                "correlated_pairs": [{"a": a, "b": b, "rho": r} for a, b, r in self.correlated_pairs],
                "identifiable": self.identifiable,
            },
            "covariance": self.covariance,
            "metrics": {
                **{f"nrmse_{k}": v for k, v in self.nrmse.items()},
                **{f"mse_{k}": v for k, v in self.mse.items()},
                "noise_variance": self.noise_variance,
                "cost": self.cost,
                "n_residuals": self.n_residuals,
                "nfev": self.nfev,
                "njev": self.njev,
                "seconds": self.seconds,
            },
            "per_experiment": {"nrmse": self.nrmse_per_experiment, "mse": self.mse_per_experiment},
            "sigma": self.sigma,
            "n_substeps": self.n_substeps,
            "substep_rejections": self.substep_rejections,
            "success": self.success,
            "message": self.message,
            "notes": self.notes,
            "offsets": self.offsets,
        })


# ======================================================================================
# fit
# ======================================================================================


class _Evaluator:
    """Residuals and finite-difference Jacobians of a grey-box problem for the solver, with the
    sub-step bookkeeping (the largest count any candidate so far needed) and call counts."""

    def __init__(self, prob: _Problem, base: PhysicalParams, fd_step: float,
                 progress: Callable[[int, int], None] | None, max_calls: int,
                 max_substep_ratio: float | None = None, substep_reference: int | None = None) -> None:
        self.prob, self.fd_step, self.progress, self.max_calls = prob, fd_step, progress, max_calls
        self.p = len(prob.names)
        # the start values' sub-steps; a stiffer candidate raises it (per-call maximum)
        self.nsub = prob.nsub(base.to_array()[None, :]) if prob.fixed_nsub is None else prob.fixed_nsub
        # trial points needing more than this many sub-steps are rejected (None: no cap)
        ref = max(self.nsub, substep_reference or 0)
        self.cap = (None if max_substep_ratio is None or prob.fixed_nsub is not None
                    else max(self.nsub, int(math.ceil(max_substep_ratio * ref))))
        self.rejected = 0
        self.nfev = 0
        self.njev = 0
        self.last: dict[str, Any] = {}

    def nsub_for(self, P: np.ndarray, need: int | None = None) -> int:
        """Sub-steps for the copies ``P`` (``need``: their stiffness bound's, if known)."""
        prob = self.prob
        if prob.fixed_nsub is not None:
            n = prob.fixed_nsub
        else:
            n = max(self.nsub, prob.nsub(P) if need is None else need)
        if self.cap is not None:
            n = min(n, self.cap)  # Jacobian copies next to the cap: integrated at the cap
        self.nsub = n
        return n

    def restart_substeps(self, theta: np.ndarray) -> int:
        """Set the sub-step count to the one the parameters ``theta`` need themselves (capped),
        as at the start of a fit, for a new solver run from ``theta``; return the count before."""
        before = self.nsub
        if self.prob.fixed_nsub is None:
            n = self.prob.nsub(self.prob.param_arrays(theta[None, :]))
            self.nsub = n if self.cap is None else min(n, self.cap)
        return before

    def _tick(self) -> None:
        if self.progress is not None:
            self.progress(self.nfev + self.njev, self.max_calls)

    def fun(self, theta: np.ndarray) -> np.ndarray:
        self.nfev += 1
        self._tick()
        P = self.prob.param_arrays(theta[None, :])
        need = self.prob.nsub(P) if self.cap is not None else None
        if need is not None and "r" in self.last and need > self.cap:
            # stiffer than the cap allows: a residual far above the last one, so the solver
            # rejects the step and shrinks its trust region
            self.rejected += 1
            return 1e3 * self.last["r"] + 1e3
        n = self.nsub_for(P, need)
        r, _ = self.prob.residuals(P, n)
        self.last.update(theta=theta.copy(), r=r[0], nsub=n)
        return r[0]

    def jac_forward(self, theta: np.ndarray) -> np.ndarray:
        """Forward differences re-using the residual just evaluated at ``theta`` (``p`` copies)."""
        self.njev += 1
        self._tick()
        prob, p, h, last = self.prob, self.p, self.fd_step, self.last
        th = np.repeat(theta[None, :], p, axis=0)
        for i in range(p):  # forward step, backward where the upper bound leaves no room
            th[i, i] += h if prob.hi[i] - theta[i] >= h else -min(h, max(theta[i] - prob.lo[i], 0.0))
        P = prob.param_arrays(th)
        n = self.nsub_for(P)
        r, _ = prob.residuals(P, n)
        if "theta" in last and last["nsub"] == n and np.array_equal(last["theta"], theta):
            r0 = last["r"]
        else:  # residual at theta on the same integration grid
            r0 = prob.residuals(prob.param_arrays(theta[None, :]), n)[0][0]
        J = np.empty((r.shape[1], p))
        for i in range(p):
            step = th[i, i] - theta[i]
            J[:, i] = (r[i] - r0) / step if step != 0 else 0.0
        return J

    def jac(self, theta: np.ndarray) -> np.ndarray:
        """Central differences (``2 p`` copies), one-sided at a bound."""
        self.njev += 1
        self._tick()
        prob, p, h = self.prob, self.p, self.fd_step
        th = np.repeat(theta[None, :], 2 * p, axis=0)
        for i in range(p):
            hi = min(h, (prob.hi[i] - theta[i])) if prob.hi[i] - theta[i] > 1e-12 else 0.0
            lo = min(h, (theta[i] - prob.lo[i])) if theta[i] - prob.lo[i] > 1e-12 else 0.0
            th[2 * i, i] += hi
            th[2 * i + 1, i] -= lo
        P = prob.param_arrays(th)
        r, _ = prob.residuals(P, self.nsub_for(P))
        J = np.empty((r.shape[1], p))
        for i in range(p):
            step = th[2 * i, i] - th[2 * i + 1, i]
            J[:, i] = (r[2 * i] - r[2 * i + 1]) / step if step > 0 else 0.0
        return J


def _reestimate_sigma(prob: _Problem, theta: np.ndarray, nsub: int, given: set[str]) -> bool:
    """Channel weights from the residual RMS at ``theta`` (channels not in ``given``); True if
    any changed."""
    outs, _ = prob.outputs(prob.param_arrays(theta[None, :]), nsub)
    changed = False
    for name in prob.sigma:
        if name in given:
            continue
        rr = np.concatenate([(e.outputs[name] - o[name][0])[slice(None) if e.weights is None else e.weights > 0]
                             for e, o in zip(prob.experiments, outs) if name in o])
        s = float(np.sqrt(np.mean(rr**2)))
        if s > 0 and math.isfinite(s):
            prob.sigma[name] = s
            changed = True
    return changed


def _statistics(prob: _Problem, theta: np.ndarray, J: np.ndarray, r: np.ndarray) -> dict[str, Any]:
    """Covariance (scaled Gauss-Newton, ``s^2 (J'J)^-1`` in theta, mapped to values), standard
    errors, t-based 95 % intervals, correlation, scaled condition number, correlated pairs."""
    p = len(prob.names)
    n_res = r.size
    n_off = len({(e.group, k) for e in prob.experiments for k in e.outputs if k in prob.offsets})
    dof = max(n_res - p - n_off, 1)
    s2 = float(r @ r) / dof
    norms = np.linalg.norm(J, axis=0)
    safe = np.where(norms > 0, norms, 1.0)
    Js = J / safe
    sv = np.linalg.svd(Js, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    lam, V = np.linalg.eigh(Js.T @ Js)
    lam_f = np.maximum(lam, max(lam.max(), 1e-300) * 1e-14)
    cov_s = (V / lam_f) @ V.T
    cov_theta = s2 * cov_s / np.outer(safe, safe)
    cov_theta[norms == 0, :] = np.inf
    cov_theta[:, norms == 0] = np.inf
    se_theta = np.sqrt(np.diag(cov_theta))
    d = np.sqrt(np.diag(cov_s))
    corr = cov_s / np.outer(d, d)
    vals = prob.to_values(theta)
    dvdt = np.where(prob.log, vals, prob.scale)  # d value / d theta
    tq = float(stats.t.ppf(0.975, dof))
    lo_t, hi_t = theta - tq * se_theta, theta + tq * se_theta
    ci = {}
    for i, n in enumerate(prob.names):
        if prob.log[i]:
            ci[n] = (float(math.exp(min(lo_t[i], 700))), float(math.exp(min(hi_t[i], 700))))
        else:
            ci[n] = (float(lo_t[i] * prob.scale[i]), float(hi_t[i] * prob.scale[i]))
    pairs = [(prob.names[i], prob.names[j], float(corr[i, j])) for i in range(p) for j in range(i + 1, p)
             if abs(corr[i, j]) > CORRELATION_LIMIT]
    return {"values": vals, "cov": cov_theta * np.outer(dvdt, dvdt), "se": se_theta * np.abs(dvdt), "ci": ci,
            "corr": corr, "cond": cond, "pairs": pairs, "s2": s2, "n_res": n_res}


def _fit_metrics(prob: _Problem, theta: np.ndarray, nsub: int) -> dict[str, Any]:
    """NRMSE and MSE per channel (pooled and per experiment) and the profiled sensor offsets."""
    P = prob.param_arrays(theta[None, :])
    outs, _ = prob._raw_outputs(P, nsub)
    offs = {f"{k}@{g}" if g else k: float(v[0]) for (g, k), v in prob.add_offsets(outs).items()}
    nr_e, mse_e = [], []
    pooled: dict[str, tuple[list, list]] = {}
    for e, o in zip(prob.experiments, outs):
        nr, ms = {}, {}
        for k, yhat in o.items():
            y = e.outputs[k]
            err = y - yhat[0]
            den = float(np.linalg.norm(y - y.mean()))
            nr[k] = float(np.linalg.norm(err)) / den if den > 0 else math.inf
            ms[k] = float(np.mean(err**2))
            pooled.setdefault(k, ([], []))
            pooled[k][0].append(y)
            pooled[k][1].append(yhat[0])
        nr_e.append(nr)
        mse_e.append(ms)
    nrmse, mse = {}, {}
    for k, (ys, yh) in pooled.items():
        y = np.concatenate(ys)
        err = y - np.concatenate(yh)
        den = float(np.linalg.norm(y - y.mean()))
        nrmse[k] = float(np.linalg.norm(err)) / den if den > 0 else math.inf
        mse[k] = float(np.mean(err**2))
    return {"nrmse": nrmse, "mse": mse, "nrmse_e": nr_e, "mse_e": mse_e, "offsets": offs}


# see fit_greybox's ``cost_ceiling``
CEILING_GAIN_FRACTION = 0.01


def fit_greybox(
    base: PhysicalParams,
    fit: Sequence[str],
    experiments: Experiment | Sequence[Experiment],
    channels: Sequence[OutputChannel],
    *,
    sigma: Mapping[str, float] | None = None,
    reweight: bool = True,
    log_scale: bool | Mapping[str, bool] | None = None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    fd_step: float = 1e-4,
    n_substeps: int | None = None,
    max_nfev: int = 60,
    tol: float = 1e-8,
    tie: Callable[[np.ndarray], None] | None = None,
    jacobian: str = "central",
    offsets: Sequence[str] = (),
    progress: Callable[[int, int], None] | None = None,
    max_substep_ratio: float | None = None,
    substep_reference: int | None = None,
    cost_tol: float | None = None,
    cost_ceiling: float | None = None,
    cost_target: float | None = None,
) -> GreyboxResult:
    """Fit parameters ``fit`` of ``base`` to the experiments (see the module docstring).

    ``base`` holds the start values (and every fixed parameter); ``log_scale`` None = log for
    positive ranges; ``bounds`` override the allowed ranges; ``sigma`` fixes the channel
    weights (then ``reweight`` only re-estimates channels not given); ``fd_step`` is the
    central-difference step in theta (relative for log-scaled parameters); ``n_substeps``
    fixes the RK4 sub-steps per sample (default: from the plant's ``stiffness_modes`` at the
    start values, bounded over the candidates of each call). ``tie(P)`` edits the packed
    parameter rows ``P (c, n_params)`` in place after the fitted columns are written, for
    parameters that follow fitted ones (e.g. a static friction level kept equal to the
    Coulomb level while no Stribeck effect is modelled).

    The solver (trf) stops on first-order optimality (``gtol``), a small relative cost change
    (``ftol``) or a small step (``xtol``), each ``tol``. The last two also end a run whose trust
    region has shrunk in a curved valley far from the minimum, so such a stop is followed by one
    more run from its point, kept if it lowers the cost (with a note; at a minimum it ends at
    once); ``max_nfev`` bounds each run.

    ``jacobian``: finite differences of the Jacobians the iterations use: ``"central"``
    (``2 p`` perturbed copies per Jacobian) or ``"forward"`` (``p`` copies, re-using the
    residual the solver has just evaluated at the same point: about half the simulation cost
    of a fit; the optimum is defined by the residual, so only the path to it changes). The
    Jacobian of the statistics (covariance, standard errors) is always central.

    ``offsets``: channels with an unknown constant sensor offset per experiment ``group``
    (a pressure transducer's zero error): nuisance parameters profiled out of the residual
    (variable projection: at every parameter set the offsets take their least-squares values,
    the weighted mean residual of the group), reported in ``offsets`` of the result and
    counted in the degrees of freedom.

    ``progress``: an optional callable ``progress(simulations, upper_bound)`` called at every
    residual and Jacobian evaluation (e.g. :class:`identification.quality.Progress`).

    ``max_substep_ratio``: trial points whose stiffness bound needs more than this many times
    the start values' sub-steps are rejected (the solver sees a residual far above its last one
    and shrinks its step), so a fit does not wander into parameter sets whose integration costs
    ten times the start's (None: no cap); ``substep_reference``: sub-steps the ratio multiplies
    when they exceed the start's (a fit started near an effect's null value keeps the room of
    the effect's usual start).

    ``cost_tol``: an iteration that lowers the cost by less than this (absolute, in the units
    of the weighted cost ``0.5 sum (r / sigma)^2``) ends the fit, as ``tol`` does relative to
    the cost (None: only ``tol``). With noise-level weights a fall of 0.5 is a chi-square
    change of 1; a fit creeping along a flat valley (a Stribeck velocity on a record without
    Stribeck friction) otherwise spends its remaining evaluations on such steps.

    ``cost_ceiling``: the cost of a model this fit extends (None: not known). An iteration that
    ends above it and lowers the cost by less than ``CEILING_GAIN_FRACTION`` of the cost ends
    the fit: it is creeping towards a model that explains less than the one it extends
    (a LuGre bristle model fitted to a record with a static friction curve, held at 200 times
    the current model's cost by its stiffness cap).

    ``cost_target``: the cost of a rival model this fit has to fall below to matter (None: no
    rival; two valve effects refitted as a pair beside a supply droop that leaves 1/800 of
    their cost). An iteration that ends above the lower of ``cost_ceiling`` and ``cost_target``
    with a gain that, repeated at every evaluation left (``max_nfev``), would still leave the
    cost above it ends the fit: it cannot get there.
    """
    if jacobian not in ("central", "forward"):
        raise GreyboxError(f"jacobian must be 'central' or 'forward', got {jacobian!r}")
    t0 = time.perf_counter()
    prob = _build_problem(base, fit, experiments, channels, sigma,
                          True if log_scale is None else log_scale, bounds, n_substeps, tie, offsets)
    theta0 = prob.to_theta(np.array([getattr(base, n) for n in prob.names]))
    ev = _Evaluator(prob, base, fd_step, progress, (2 if reweight else 1) * 4 * max_nfev + 1, max_substep_ratio,
                    substep_reference)
    notes: list[str] = []

    def solve(theta_start):
        last_cost = [math.inf]
        calls = [0]

        def stop_when_flat(intermediate_result: optimize.OptimizeResult) -> None:
            cost = float(intermediate_result.cost)
            gained, last_cost[0] = last_cost[0] - cost, cost
            calls[0] += 1
            if cost_tol is not None and 0.0 <= gained < cost_tol:
                raise StopIteration
            if cost_ceiling is not None and cost > cost_ceiling and 0.0 <= gained < CEILING_GAIN_FRACTION * cost:
                raise StopIteration
            bar = min(b for b in (cost_ceiling, cost_target, math.inf) if b is not None)
            if cost > bar and 0.0 <= gained:
                left = max_nfev - int(intermediate_result.get("nfev", calls[0] + 1))
                if cost - left * gained > bar:
                    raise StopIteration

        def run(theta):
            return optimize.least_squares(ev.fun, theta, jac=ev.jac_forward if jacobian == "forward" else ev.jac,
                                          bounds=(prob.lo, prob.hi), method="trf",
                                          x_scale=1.0, ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev,
                                          callback=(None if cost_tol is None and cost_ceiling is None
                                                    and cost_target is None else stop_when_flat))

        sol = run(theta_start)
        if sol.status in (2, 3, 4):
            # stopped on a small cost change or step, not on the gradient: a trust region that
            # has shrunk in a curved valley stops there too, far from the minimum; a second
            # run from that point starts with a fresh one (at a minimum it ends at once), and
            # with the sub-steps that point needs (a stiff trial point of the first run may
            # have raised them for the rest of it)
            before = ev.restart_substeps(sol.x)
            again = run(sol.x)
            if again.cost < sol.cost:
                notes.append(f"restarted from the first stop ({sol.message}, cost {sol.cost:.4g}): cost "
                             f"{again.cost:.4g}")
                sol = again
            else:
                ev.nsub = max(ev.nsub, before)
        if sol.status == -2:  # stopped by stop_when_flat
            sol.success = True
            sol.message = ("an iteration lowered the cost by less than cost_tol, above cost_ceiling by less "
                           f"than {CEILING_GAIN_FRACTION:g} of it, or too little to reach cost_target")
        return sol

    sol = solve(np.clip(theta0, prob.lo, prob.hi))
    if reweight and _reestimate_sigma(prob, sol.x, ev.nsub, set(sigma or {})):
        sol = solve(sol.x)
        notes.append("channel weights re-estimated from the residual RMS of a first fit (noise levels)")

    if ev.rejected:
        notes.append(f"{ev.rejected} trial point(s) rejected: their stiffness bound needed more than "
                     f"{ev.cap} sub-steps per sample ({max_substep_ratio:g} x the start's or the reference's)")
    theta = sol.x
    # statistics: a central Jacobian, except after forward-difference iterations, whose last
    # Jacobian the solver evaluated at sol.x already (forward differences of step fd_step:
    # standard errors within ~fd_step relative of the central ones, no extra simulations)
    J = sol.jac if jacobian == "forward" else ev.jac(theta)
    st = _statistics(prob, theta, J, sol.fun)
    if st["cond"] >= CONDITION_LIMIT:
        notes.append(f"scaled condition number {st['cond']:.3g} >= {CONDITION_LIMIT:g}: the data do not determine "
                     "all fitted parameters (see correlated_pairs)")
    for a, b, rho in st["pairs"]:
        notes.append(f"{a} and {b} are correlated (rho = {rho:+.4f}): only a combination is identified")
    m = _fit_metrics(prob, theta, ev.nsub)
    try:
        row = prob.param_arrays(theta[None, :])[0]  # fitted and tied columns
        fitted = dataclasses.replace(base, **{n: float(v) for n, v in zip(type(base).names(), row)
                                             if float(v) != float(getattr(base, n))})
    except ParameterError as e:
        fitted = None
        notes.append(f"fitted set violates a parameter relation: {e}")
    fields = {f.name: f for f in dataclasses.fields(base)}
    plant = getattr(type(base), "plant", "") or type(base).__name__
    return GreyboxResult(
        plant=plant, names=prob.names, values={n: float(v) for n, v in zip(prob.names, st["values"])},
        initial={n: float(getattr(base, n)) for n in prob.names},
        std_errors={n: float(s) for n, s in zip(prob.names, st["se"])}, ci95=st["ci"],
        units={n: fields[n].metadata["unit"] for n in prob.names},
        log_scaled={n: bool(b) for n, b in zip(prob.names, prob.log)},
        covariance=st["cov"], correlation=st["corr"], condition_number=st["cond"], correlated_pairs=st["pairs"],
        nrmse=m["nrmse"], mse=m["mse"], nrmse_per_experiment=m["nrmse_e"], mse_per_experiment=m["mse_e"],
        sigma=dict(prob.sigma), cost=float(sol.cost), noise_variance=st["s2"], n_residuals=int(st["n_res"]),
        n_substeps=int(ev.nsub), nfev=ev.nfev, njev=ev.njev, success=bool(sol.success),
        message=str(sol.message), seconds=time.perf_counter() - t0, params=fitted, notes=notes, offsets=m["offsets"], substep_rejections=ev.rejected,
    )
