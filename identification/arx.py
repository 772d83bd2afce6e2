r"""ARX models: least-squares estimation, order/delay selection, validation, conversion.

Model (single input, single output, sample time ``dt``; the convention of MATLAB's ``arx``
used by seeds 001 and 004)::

    A(q) y(t) = B(q) u(t) + e(t)
    A(q) = 1 + a_1 q^-1 + ... + a_na q^-na
    B(q) = b_1 q^-nk + b_2 q^-(nk+1) + ... + b_nb q^-(nk+nb-1)

``nk`` is the input delay in samples (``nk = 1``: one sample, the usual sampled plant;
``nk = 3``: two extra delays as in 001 eq (6), where B starts at ``b_3 z^-3``).

Seed structures:

* ``001_3253c61f41166c3e.txt`` eq (6): tenth-order ARX from a low-amplitude PRBS at 5 kHz,
  ``na = 10, nb = 8, nk = 3`` (``b_3 ... b_10``).
* ``004_f1423316a055addb.txt`` sec. 4.2, eq (32): closed-loop direct identification with an
  M-sequence added to the controller output, ARX of order 3:
  ``H(z) = (0.1496 z^2 - 0.03607 z + 0.1678) / (z^3 - 1.4276 z^2 + 0.85537 z - 0.4243)``,
  i.e. ``na = 3, nb = 3, nk = 1`` (:data:`SEED_004_EQ32`).

Estimation (:func:`fit_arx`): linear least squares on the regressor
``phi(t) = [-y(t-1) .. -y(t-na), u(t-nk) .. u(t-nk-nb+1)]`` (QR via ``numpy.linalg.lstsq``
on scaled columns). With white equation error ``e`` the estimate is consistent and
``cov = sigma^2 (Phi' Phi)^-1`` with ``sigma^2 = RSS / (N - d)`` is its covariance; this
holds in closed loop too (direct identification, 004 sec. 4.2), as long as the loop has a
delay. If the noise is *not* white equation error -- e.g. white noise on the measured
output (output-error systems) -- least squares is biased; ``method="iv"`` then gives
consistent estimates with instruments made of the noise-free simulated output of a first
least-squares model (the basic simulated-output IV, Soderstrom & Stoica, System
Identification, 1989, ch. 8), iterated a few times. IV needs open-loop data (the input must
be uncorrelated with the noise); its covariance is the sandwich
``sigma^2 (Z'Phi)^-1 Z'Z (Phi'Z)^-1``, exact only for white residuals.

Criteria (``N`` = samples in the regression, ``d = na + nb`` parameters, ``V = RSS / N``)::

    AIC = N ln V + 2 d            BIC = N ln V + d ln N          FPE = V (N + d) / (N - d)

Order selection (:func:`select_arx_order`) evaluates every candidate on the *same*
estimation samples (the first ``max lag`` samples of the record are skipped for all), so the
criteria are comparable. docs/references.md warns that with autocorrelated data every criterion
keeps adding terms: the selection therefore also reports each candidate's free-run fit on
held-out data when validation data are given (``criterion="validation"`` decides on it) and
the margin of the winner over the runner-up.

Fit (percent, as MATLAB's ``compare``): ``100 (1 - ||y - yhat|| / ||y - mean(y)||)``, for
the one-step-ahead prediction and the free-run simulation (``yhat`` from the input alone,
initial conditions from the first measured samples).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Iterable
from typing import Any

import numpy as np
from scipy import signal

from hydro_envs.jsonutil import to_jsonable as _jsonable

__all__ = [
    "ArxError",
    "ArxModel",
    "ArxOrderSelection",
    "SEED_004_EQ32",
    "arx_regressors",
    "fit_arx",
    "select_arx_order",
    "fit_percent",
    "nrmse",
]




class ArxError(ValueError):
    """Bad data or orders for an ARX estimate (the message says which and why)."""

    exit_code = 1  # the command line's code for data that cannot give a result (hydro_envs.cli_errors)


#: 004 eq (32): identified open-loop ARX of the rodless-cylinder position loop (sample
#: time not printed in the extracted text). Coefficients in the q^-1 convention above.
SEED_004_EQ32 = {
    "a": (1.0, -1.4276, 0.85537, -0.4243),
    "b": (0.1496, -0.03607, 0.1678),
    "na": 3,
    "nb": 3,
    "nk": 1,
    "source": "004_f1423316a055addb.txt eq (32), sec. 4.2 (closed-loop M-sequence, ARX)",
}


def fit_percent(y: Any, yhat: Any) -> float:
    """``100 (1 - ||y - yhat|| / ||y - mean(y)||)`` (100 = perfect; can be negative)."""
    return 100.0 * (1.0 - nrmse(y, yhat))


def nrmse(y: Any, yhat: Any) -> float:
    """``||y - yhat|| / ||y - mean(y)||`` (0 = perfect, 1 = as good as the mean)."""
    y = np.asarray(y, dtype=np.float64)
    yhat = np.asarray(yhat, dtype=np.float64)
    den = float(np.linalg.norm(y - y.mean()))
    if den == 0.0:
        return math.inf
    return float(np.linalg.norm(y - yhat)) / den


def _check_data(y: Any, u: Any) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    for name, arr in (("y", y), ("u", u)):
        if arr.ndim != 1:
            raise ArxError(f"{name} must be a 1-D array (single input, single output), got shape {arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            raise ArxError(f"{name} has {bad.size} NaN/inf value(s), first at sample {int(bad[0])}")
    if y.shape != u.shape:
        raise ArxError(f"y and u must have the same length, got {y.size} and {u.size}")
    return y, u


def _check_orders(na: int, nb: int, nk: int) -> tuple[int, int, int]:
    for name, val, lo in (("na", na, 0), ("nb", nb, 1), ("nk", nk, 0)):
        if int(val) != val or val < lo:
            raise ArxError(f"{name} = {val!r} must be an integer >= {lo}")
    return int(na), int(nb), int(nk)


def _max_lag(na: int, nb: int, nk: int) -> int:
    return max(na, nk + nb - 1)


def arx_regressors(
    y: Any, u: Any, na: int, nb: int, nk: int, start: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Regressor matrix ``Phi`` and target ``y[start:]`` of ARX(na, nb, nk).

    Row ``t`` is ``[-y(t-1) .. -y(t-na), u(t-nk) .. u(t-nk-nb+1)]``; ``start`` defaults to
    the largest lag (every row complete) and may be larger (common sample for several
    orders).
    """
    y, u = _check_data(y, u)
    na, nb, nk = _check_orders(na, nb, nk)
    lag = _max_lag(na, nb, nk)
    start = lag if start is None else int(start)
    if start < lag:
        raise ArxError(f"start = {start} is smaller than the largest lag {lag}")
    n = y.size - start
    if n <= 0:
        raise ArxError(f"record of {y.size} samples is shorter than the largest lag {lag}")
    cols = [-y[start - i : y.size - i] for i in range(1, na + 1)]
    cols += [u[start - j : u.size - j] for j in range(nk, nk + nb)]
    return np.column_stack(cols), y[start:]


@dataclasses.dataclass
class ArxModel:
    """An estimated ARX(na, nb, nk) model with its statistics.

    ``a = [1, a_1 .. a_na]``, ``b = [b_1 .. b_nb]`` (coefficient of ``q^-(nk + i - 1)``).
    """

    na: int
    nb: int
    nk: int
    dt: float
    a: np.ndarray
    b: np.ndarray
    std_a: np.ndarray  # std errors of a_1 .. a_na
    std_b: np.ndarray
    covariance: np.ndarray  # of theta = [a_1 .. a_na, b_1 .. b_nb]
    noise_variance: float  # RSS / (N - d)
    n_samples: int  # N, rows of the regression
    loss: float  # V = RSS / N
    aic: float
    bic: float
    fpe: float
    fit_one_step: float  # percent, on the estimation data
    method: str = "ls"

    # -------------------------------------------------------------- basic properties
    @property
    def n_params(self) -> int:
        return self.na + self.nb

    @property
    def theta(self) -> np.ndarray:
        return np.concatenate([self.a[1:], self.b])

    @property
    def b_full(self) -> np.ndarray:
        """Numerator in powers of q^-1 from q^0: ``[0]*nk + b``."""
        return np.concatenate([np.zeros(self.nk), self.b])

    def transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """``(num, den)`` of ``H(z)`` in descending powers of ``z`` (same length)."""
        bf = self.b_full
        n = max(bf.size, self.a.size)
        num = np.concatenate([bf, np.zeros(n - bf.size)])
        den = np.concatenate([self.a, np.zeros(n - self.a.size)])
        return num, den

    def to_dlti(self) -> signal.dlti:
        """``scipy.signal.dlti`` transfer function ``B(z) / A(z)`` with ``dt``."""
        num, den = self.transfer_function()
        num = np.trim_zeros(num, "f")  # leading zeros = delay; scipy warns about them
        return signal.dlti(num if num.size else np.zeros(1), den, dt=self.dt)

    @property
    def poles(self) -> np.ndarray:
        """Roots of ``z^na A(z)`` (the model's ``na`` poles)."""
        return np.roots(self.a) if self.na > 0 else np.zeros(0, dtype=complex)

    @property
    def zeros(self) -> np.ndarray:
        """Roots of ``b_1 z^(nb-1) + ... + b_nb`` (the ``nb - 1`` finite zeros)."""
        b = np.trim_zeros(self.b, "f")
        return np.roots(b) if b.size > 1 else np.zeros(0, dtype=complex)

    @property
    def is_stable(self) -> bool:
        return bool(np.all(np.abs(self.poles) < 1.0))

    def dc_gain(self) -> float:
        """``B(1) / A(1)`` (inf for a pole at z = 1)."""
        den = float(np.sum(self.a))
        return float(np.sum(self.b)) / den if den != 0 else math.inf

    def dc_gain_std(self) -> float:
        """Standard error of :meth:`dc_gain` by the delta method (first-order propagation)."""
        sa = float(np.sum(self.a))
        if sa == 0:
            return math.inf
        grad = np.concatenate([np.full(self.na, -float(np.sum(self.b)) / sa**2), np.full(self.nb, 1.0 / sa)])
        return float(math.sqrt(max(grad @ self.covariance @ grad, 0.0)))

    # ---------------------------------------------------------------- prediction
    def predict(self, y: Any, u: Any) -> np.ndarray:
        """One-step-ahead prediction; the first ``max lag`` samples are copied from ``y``."""
        y, u = _check_data(y, u)
        lag = _max_lag(self.na, self.nb, self.nk)
        Phi, _ = arx_regressors(y, u, self.na, self.nb, self.nk, start=lag)
        out = y.copy()
        out[lag:] = Phi @ self.theta
        return out

    def simulate(self, u: Any, y_init: Any = None, u_init: Any = None) -> np.ndarray:
        """Free-run (simulation) output for input ``u``.

        ``y_init``/``u_init``: measured samples *before or at the start of* the record used
        as initial conditions. If ``y_init`` has ``L = max lag`` entries (the first ``L``
        samples of the measured output, with ``u`` the whole input), the first ``L`` outputs
        are those samples and the simulation runs from sample ``L`` on. Without them the
        model starts at rest (zero initial conditions).
        """
        u = np.asarray(u, dtype=np.float64)
        if u.ndim != 1 or not np.all(np.isfinite(u)):
            raise ArxError("u must be a finite 1-D array")
        bf = self.b_full
        if y_init is None:
            return signal.lfilter(bf, self.a, u)
        y_init = np.asarray(y_init, dtype=np.float64)
        lag = y_init.size
        if lag >= u.size:
            raise ArxError(f"y_init has {lag} samples, the input only {u.size}")
        # lfiltic wants past outputs/inputs most recent first
        zi = signal.lfiltic(bf, self.a, y_init[::-1], u[:lag][::-1])
        y_rest, _ = signal.lfilter(bf, self.a, u[lag:], zi=zi)
        return np.concatenate([y_init, y_rest])

    def validate(self, y: Any, u: Any) -> dict[str, float]:
        """Fit percent of one-step prediction and free-run simulation on data ``(y, u)``.

        The free run takes its initial conditions from the first ``max lag`` samples of
        ``y``; both fits are computed on the samples after them.
        """
        y, u = _check_data(y, u)
        lag = max(_max_lag(self.na, self.nb, self.nk), 1)
        if y.size <= lag + 1:
            raise ArxError(f"validation record of {y.size} samples is too short (max lag {lag})")
        y1 = self.predict(y, u)
        ys = self.simulate(u, y_init=y[:lag])
        return {
            "fit_one_step": fit_percent(y[lag:], y1[lag:]),
            "fit_free_run": fit_percent(y[lag:], ys[lag:]),
            "nrmse_one_step": nrmse(y[lag:], y1[lag:]),
            "nrmse_free_run": nrmse(y[lag:], ys[lag:]),
            "n_samples": int(y.size - lag),
        }

    # ------------------------------------------------------------------ report
    def to_json_dict(self, validation: dict[str, float] | None = None) -> dict[str, Any]:
        num, den = self.transfer_function()

        def cplx(z: np.ndarray) -> list[list[float]]:
            return [[float(c.real), float(c.imag)] for c in np.asarray(z, dtype=complex)]

        d = {
            "method": f"ARX least squares ({self.method})",
            "orders": {"na": self.na, "nb": self.nb, "nk": self.nk},
            "dt": self.dt,
            "parameters": {
                **{f"a{i}": float(v) for i, v in enumerate(self.a[1:], start=1)},
                **{f"b{i}": float(v) for i, v in enumerate(self.b, start=1)},
            },
            "std_errors": {
                **{f"a{i}": float(v) for i, v in enumerate(self.std_a, start=1)},
                **{f"b{i}": float(v) for i, v in enumerate(self.std_b, start=1)},
            },
            "transfer_function_z": {"num": [float(v) for v in num], "den": [float(v) for v in den]},
            "poles": cplx(self.poles),
            "zeros": cplx(self.zeros),
            "stable": self.is_stable,
            "metrics": {
                "noise_variance": self.noise_variance,
                "loss": self.loss,
                "aic": self.aic,
                "bic": self.bic,
                "fpe": self.fpe,
                "fit_one_step_percent": self.fit_one_step,
                "n_samples": self.n_samples,
            },
        }
        if validation is not None:
            d["validation"] = dict(validation)
        return _jsonable(d)


def _criteria(rss: float, n: int, d: int) -> tuple[float, float, float, float]:
    v = rss / n
    lv = math.log(v) if v > 0 else -math.inf
    aic = n * lv + 2 * d
    bic = n * lv + d * math.log(n)
    fpe = v * (n + d) / (n - d) if n > d else math.inf
    return v, aic, bic, fpe


def fit_arx(
    y: Any,
    u: Any,
    na: int,
    nb: int,
    nk: int = 1,
    dt: float = 1.0,
    *,
    method: str = "ls",
    start: int | None = None,
    iv_iterations: int = 3,
) -> ArxModel:
    """Estimate ARX(na, nb, nk) from output ``y`` and input ``u`` (1-D, same length).

    ``method="ls"`` (least squares) or ``"iv"`` (simulated-output instrumental variables,
    consistent for output-error noise in open loop; see the module docstring). ``start``
    is the first regression row (default: the largest lag). Remove offsets (means or an
    operating point) before fitting; the model has no constant term.
    """
    y, u = _check_data(y, u)
    na, nb, nk = _check_orders(na, nb, nk)
    if not (math.isfinite(dt) and dt > 0):
        raise ArxError(f"dt = {dt!r} must be a finite sample time > 0 s")
    if method not in ("ls", "iv"):
        raise ArxError(f"method = {method!r}; allowed: 'ls', 'iv'")
    Phi, target = arx_regressors(y, u, na, nb, nk, start=start)
    n, d = Phi.shape
    if n < 2 * d + 1:
        raise ArxError(
            f"{n} regression rows for {d} parameters: need at least {2 * d + 1}; record longer data"
        )
    if np.ptp(u) == 0.0:
        raise ArxError("input u is constant: no excitation, B(q) is not identifiable")
    scale = np.sqrt(np.sum(Phi * Phi, axis=0))
    if np.any(scale == 0.0):
        raise ArxError("a regressor column is identically zero (constant zero output or input)")
    Ps = Phi / scale
    sv = np.linalg.svd(Ps, compute_uv=False)
    if sv[-1] <= 1e-10 * sv[0]:
        raise ArxError(
            f"regressor is rank deficient (condition number {sv[0] / max(sv[-1], 1e-300):.3g}): "
            "the input does not excite enough frequencies for this order (persistent "
            f"excitation of order >= {nb} needed), or the orders are too high"
        )
    theta_s, *_ = np.linalg.lstsq(Ps, target, rcond=None)
    theta = theta_s / scale
    resid = target - Phi @ theta
    G_inv = np.linalg.inv(Ps.T @ Ps)
    if method == "iv":
        first_start = _max_lag(na, nb, nk) if start is None else int(start)
        for _ in range(max(1, int(iv_iterations))):
            a = np.concatenate([[1.0], theta[:na]])
            if na and np.any(np.abs(np.roots(a)) >= 1.0):
                raise ArxError(
                    "IV: the auxiliary model is unstable, its simulated output cannot serve as "
                    "instrument; use method='ls' or check the data"
                )
            xsim = signal.lfilter(np.concatenate([np.zeros(nk), theta[na:]]), a, u)
            Z, _ = arx_regressors(xsim, u, na, nb, nk, start=first_start)
            Zs = Z / scale
            M = Zs.T @ Ps
            theta_s = np.linalg.solve(M, Zs.T @ target)
            theta = theta_s / scale
        resid = target - Phi @ theta
        Minv = np.linalg.inv(M)
        G_inv = Minv @ (Zs.T @ Zs) @ Minv.T
    rss = float(resid @ resid)
    sigma2 = rss / (n - d)
    cov = sigma2 * G_inv / np.outer(scale, scale)
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    v, aic, bic, fpe = _criteria(rss, n, d)
    return ArxModel(
        na=na,
        nb=nb,
        nk=nk,
        dt=float(dt),
        a=np.concatenate([[1.0], theta[:na]]),
        b=theta[na:].copy(),
        std_a=std[:na],
        std_b=std[na:],
        covariance=cov,
        noise_variance=sigma2,
        n_samples=n,
        loss=v,
        aic=aic,
        bic=bic,
        fpe=fpe,
        fit_one_step=fit_percent(target, target - resid),
        method=method,
    )


@dataclasses.dataclass
class ArxOrderSelection:
    """Result of :func:`select_arx_order`: the chosen model and the candidate table."""

    best: ArxModel
    criterion: str
    table: list[dict[str, float]]  # one row per candidate: na, nb, nk, aic, bic, fpe, [fit_val]
    margin: float  # criterion difference winner vs runner-up (same sign convention: > 0)
    runner_up: tuple[int, int, int] | None
    validation: dict[str, float] | None = None

    @property
    def orders(self) -> tuple[int, int, int]:
        return (self.best.na, self.best.nb, self.best.nk)

    def to_json_dict(self) -> dict[str, Any]:
        return _jsonable({
            "method": "ARX order selection",
            "criterion": self.criterion,
            "orders": {"na": self.best.na, "nb": self.best.nb, "nk": self.best.nk},
            "margin_over_runner_up": self.margin,
            "runner_up": None if self.runner_up is None else dict(zip(("na", "nb", "nk"), self.runner_up)),
            "model": self.best.to_json_dict(self.validation),
            "candidates": list(self.table),
        })


def select_arx_order(
    y: Any,
    u: Any,
    na: Iterable[int] = range(1, 6),
    nb: Iterable[int] = range(1, 6),
    nk: Iterable[int] = range(0, 4),
    dt: float = 1.0,
    *,
    criterion: str = "bic",
    validation_data: tuple[Any, Any] | None = None,
    method: str = "ls",
    fit_tolerance: float = 0.5,
    progress: Any = None,
) -> ArxOrderSelection:
    """Fit every ARX(na, nb, nk) candidate on common samples and pick the best.

    ``criterion``: ``"aic" | "bic" | "fpe"`` (smallest wins, on the estimation data) or
    ``"validation"``: free-run fit percent on ``validation_data = (y_val, u_val)`` with
    parsimony -- the candidate with the fewest parameters whose fit is within
    ``fit_tolerance`` percentage points of the best one (ties: higher fit), because
    over-parameterised models that contain the true one fit held-out data equally well up
    to noise. With validation data every row of the table carries ``fit_free_run`` and
    ``fit_one_step`` whatever the criterion. ``margin`` is how much the winner beats the
    runner-up: criterion units for the information criteria; for ``"validation"`` the
    winner's fit minus the best fit among candidates with fewer parameters (inf if none).
    ``progress``: an optional callable ``progress(candidates_done, n_candidates)``.
    """
    y, u = _check_data(y, u)
    if criterion not in ("aic", "bic", "fpe", "validation"):
        raise ArxError(f"criterion = {criterion!r}; allowed: 'aic', 'bic', 'fpe', 'validation'")
    if criterion == "validation" and validation_data is None:
        raise ArxError("criterion='validation' needs validation_data=(y_val, u_val)")
    cands = [
        _check_orders(a, b, k) for a, b, k in itertools.product(list(na), list(nb), list(nk))
    ]
    if not cands:
        raise ArxError("no candidate orders given")
    start = max(_max_lag(*c) for c in cands)
    yv = uv = None
    if validation_data is not None:
        yv, uv = _check_data(*validation_data)
    rows: list[dict[str, float]] = []
    models: list[ArxModel] = []
    for i_c, c in enumerate(cands):
        if progress is not None:
            progress(i_c, len(cands))
        try:
            m = fit_arx(y, u, *c, dt=dt, method=method, start=start)
        except ArxError:
            continue  # a rank-deficient candidate is not a candidate
        row: dict[str, Any] = {"na": c[0], "nb": c[1], "nk": c[2], "n_samples": m.n_samples,
                               "aic": m.aic, "bic": m.bic, "fpe": m.fpe,
                               "fit_one_step_estimation": m.fit_one_step}
        if yv is not None:
            if m.is_stable:
                val = m.validate(yv, uv)
                row["fit_free_run"] = val["fit_free_run"]
                row["fit_one_step"] = val["fit_one_step"]
            else:  # an unstable model's free run diverges: it cannot win on validation
                row["fit_free_run"] = -math.inf
                lag = _max_lag(m.na, m.nb, m.nk)
                row["fit_one_step"] = fit_percent(yv[lag:], m.predict(yv, uv)[lag:])
        rows.append(row)
        models.append(m)
    if not models:
        raise ArxError("every candidate order was rank deficient on these data")
    if criterion == "validation":
        fits = np.array([r["fit_free_run"] for r in rows])
        dims = np.array([models[i].n_params for i in range(len(models))])
        ok = np.flatnonzero(fits >= fits.max() - float(fit_tolerance))
        # fewest parameters, then highest fit
        win = int(min(ok, key=lambda i: (dims[i], -fits[i])))
        simpler = np.flatnonzero(dims < dims[win])
        if simpler.size:
            r_idx = int(simpler[np.argmax(fits[simpler])])
            margin = float(fits[win] - fits[r_idx])
            runner = (rows[r_idx]["na"], rows[r_idx]["nb"], rows[r_idx]["nk"])
        else:
            margin, runner = math.inf, None
        best = models[win]
    else:
        score = np.array([r[criterion] for r in rows])
        order = np.argsort(score, kind="stable")
        best = models[order[0]]
        margin = float(score[order[1]] - score[order[0]]) if len(order) > 1 else math.inf
        runner = (rows[order[1]]["na"], rows[order[1]]["nb"], rows[order[1]]["nk"]) if len(order) > 1 else None
    validation = best.validate(yv, uv) if yv is not None else None
    return ArxOrderSelection(
        best=best, criterion=criterion, table=rows, margin=margin, runner_up=runner, validation=validation
    )
