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

from hydro_envs import registry
from hydro_envs.params import ParameterError, PhysicalParams
from hydro_envs.sim.simulate import simulate
from hydro_envs.sim.stiffness import substeps_from_stiffness as substeps_for_modes
from hydro_envs.jsonutil import to_jsonable as _jsonable

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


class GreyboxError(ValueError):
    """Bad problem definition for a grey-box fit (the message names the field and why)."""




# ======================================================================================
# problem definition
# ======================================================================================


@dataclasses.dataclass(frozen=True)
class OutputChannel:
    """A measured output: state component ``state``, derivative component ``derivative``, or
    ``func(states (c, T, ns), P (c, np)) -> (c, T)``. Exactly one of the three."""

    name: str
    state: int | None = None
    derivative: int | None = None
    func: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    unit: str = ""

    def __post_init__(self) -> None:
        if sum(x is not None for x in (self.state, self.derivative, self.func)) != 1:
            raise GreyboxError(f"output channel {self.name!r}: give exactly one of state, derivative, func")


@dataclasses.dataclass
class Experiment:
    """One record: sample time ``dt``, input ``u`` (n_samples,) or (n_samples, n_inputs),
    initial state ``y0`` (or a callable ``params -> state``), measured ``outputs`` by channel
    name (each (n_samples,), sample k at t_k = k dt)."""

    dt: float
    u: np.ndarray
    y0: Any
    outputs: dict[str, np.ndarray]
    name: str = ""
    weights: np.ndarray | None = None  # per-sample residual weights (0 = not scored), default 1
    group: str = ""  # experiments of one group share the sensor offsets of ``offsets`` channels

    def __post_init__(self) -> None:
        u = np.asarray(self.u, dtype=np.float64)
        if u.ndim == 1:
            u = u[:, None]
        if u.ndim != 2 or u.shape[0] < 3:
            raise GreyboxError(f"experiment {self.name!r}: u must have >= 3 samples, got shape {u.shape}")
        self.u = np.ascontiguousarray(u)
        if not (self.dt > 0 and math.isfinite(self.dt)):
            raise GreyboxError(f"experiment {self.name!r}: dt = {self.dt} must be > 0")
        if not self.outputs:
            raise GreyboxError(f"experiment {self.name!r}: no measured outputs")
        outs = {}
        for k, v in self.outputs.items():
            a = np.asarray(v, dtype=np.float64)
            if a.shape != (u.shape[0],):
                raise GreyboxError(f"experiment {self.name!r}: output {k!r} has shape {a.shape}, "
                                   f"expected ({u.shape[0]},) like u")
            if not np.all(np.isfinite(a)):
                raise GreyboxError(f"experiment {self.name!r}: output {k!r} has NaN/inf values")
            outs[k] = a
        self.outputs = outs
        if self.weights is not None:
            w = np.asarray(self.weights, dtype=np.float64)
            if w.shape != (u.shape[0],) or not np.all(np.isfinite(w)) or np.any(w < 0):
                raise GreyboxError(f"experiment {self.name!r}: weights must be ({u.shape[0]},) finite and >= 0")
            self.weights = w

    @property
    def n_samples(self) -> int:
        return int(self.u.shape[0])


def _plant_module(base: PhysicalParams):
    return registry.get(type(base).plant).model


def _plants() -> dict[str, dict[str, Any]]:
    """Plants a grey-box fit can simulate: every registry plant whose model declares its sensor
    outputs and ``rest_state_from_measurement`` (the state at a record's first sample).

    Channels: the measured ones the model reads from a state or a state derivative, plus
    ``v`` (the velocity state) where the model names one; presets: the parameter class's
    ``PRESETS`` if any."""
    out: dict[str, dict[str, Any]] = {}
    for spec in registry.specs():
        if not spec.package or not spec.has_module("model"):
            continue
        model = spec.model
        if not hasattr(model, "rest_state_from_measurement"):
            continue
        units = {c.name: c.unit for c in spec.channels}
        chans = {name: OutputChannel(name, state=int(i), unit=units.get(name, ""))
                 for name, i in getattr(model, "STATE_OUTPUTS", {}).items()}
        chans.update({name: OutputChannel(name, derivative=int(i), unit=units.get(name, ""))
                      for name, i in getattr(model, "DERIVATIVE_OUTPUTS", {}).items()})
        computed = getattr(model, "computed_outputs", None)
        if computed is not None:  # functions of the state trajectory (names from a trial call)
            trial = computed(np.zeros((1, 1, len(spec.state_names))), spec.params_cls().to_array()[None, :])
            chans.update({name: OutputChannel(name, func=_computed_channel(computed, name), unit=units.get(name, ""))
                          for name in trial})
        if "v" in spec.state_names and "v" not in chans:
            chans["v"] = OutputChannel("v", state=spec.state_names.index("v"), unit="m/s")
        presets = getattr(model, "PRESETS", None)
        fit = tuple(getattr(model, "FIT_OUTPUTS", tuple(c for c in chans if c != "v")))
        out[spec.name] = {"params": spec.params_cls, "channels": chans,
                          "presets": tuple(presets) if presets else None, "fit_outputs": fit}
    return out


def _computed_channel(computed: Callable, name: str) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Channel ``name`` of a model's ``computed_outputs(states, P)``."""
    return lambda states, P: computed(states, P)[name]


def plant_setup(plant: str) -> dict[str, Any]:
    """``params`` class and output ``channels`` of a supported plant."""
    table = _plants()
    if plant not in table:
        raise GreyboxError(f"grey-box plant {plant!r} not supported; supported: {sorted(table)}")
    return table[plant]


def supported_plants() -> tuple[str, ...]:
    """Registry plants a grey-box fit can simulate (see :func:`_plants`)."""
    return tuple(_plants())


# ======================================================================================
# simulation of candidates
# ======================================================================================


@dataclasses.dataclass
class _Problem:
    base: PhysicalParams
    names: tuple[str, ...]
    idx: np.ndarray
    log: np.ndarray
    scale: np.ndarray  # linear parameters: theta = value / scale
    lo: np.ndarray
    hi: np.ndarray
    spec: Any  # the plant's registry entry
    experiments: list[Experiment]
    channels: list[OutputChannel]
    sigma: dict[str, float]
    U: np.ndarray
    n_steps: np.ndarray
    dts: np.ndarray
    n_states: int
    stiffness: Callable[[Any], Mapping[str, float]] | None
    fixed_nsub: int | None
    tie: Callable[[np.ndarray], None] | None = None
    offsets: tuple[str, ...] = ()

    def to_values(self, theta: np.ndarray) -> np.ndarray:
        return np.where(self.log, np.exp(theta), theta * self.scale)

    def to_theta(self, values: np.ndarray) -> np.ndarray:
        return np.where(self.log, np.log(np.maximum(values, 1e-300)), values / self.scale)

    def param_arrays(self, thetas: np.ndarray) -> np.ndarray:
        p0 = self.base.to_array()
        P = np.repeat(p0[None, :], thetas.shape[0], axis=0)
        P[:, self.idx] = self.to_values(thetas)
        if self.tie is not None:
            self.tie(P)
        cls = type(self.base)
        nf = len(cls.names())
        if P.shape[1] > nf:  # derived kernel columns (e.g. viscosity-dependent c, R) follow the fields
            for i in range(P.shape[0]):
                P[i] = _unvalidated(cls, P[i, :nf]).to_array()
        return P

    def nsub(self, P: np.ndarray) -> int:
        if self.fixed_nsub is not None:
            return self.fixed_nsub
        if self.stiffness is None:
            return 1
        dt = float(self.dts.max())
        n = 1
        names = type(self.base).names()
        for row in P:
            try:
                params = type(self.base)(**dict(zip(names, row)))
            except ParameterError:
                params = None
            if params is None:  # relations violated: use a raw namespace for the modes
                params = _RawParams(names, row, self.base)
            n = max(n, substeps_for_modes(self.stiffness(params), dt)[0])
        return n

    def states(self, P: np.ndarray, nsub: int | None = None):
        """Simulate every copy of ``P`` on every experiment: list per experiment of
        ``(states (c, T+1, ns), derivs or None, P)``."""
        n_exp = len(self.experiments)
        c = P.shape[0]
        Pall = np.ascontiguousarray(np.repeat(P, n_exp, axis=0))
        exp_idx = np.tile(np.arange(n_exp), c).astype(np.int64)
        Y0 = np.empty((c * n_exp, self.n_states))
        for i in range(c * n_exp):
            e = self.experiments[exp_idx[i]]
            if callable(e.y0):
                try:
                    prm = type(self.base)(**dict(zip(type(self.base).names(), Pall[i])))
                except ParameterError:
                    prm = self.base
                Y0[i] = e.y0(prm)
            else:
                Y0[i] = e.y0
        n = self.nsub(P) if nsub is None else nsub
        T = int(self.n_steps.max())
        want_d = any(ch.derivative is not None for ch in self.channels)
        res = []
        for e_i in range(n_exp):
            sel = exp_idx == e_i
            k = int(self.n_steps[e_i])
            Pe = np.ascontiguousarray(Pall[sel])
            out = np.zeros((Pe.shape[0], T + 1, self.n_states))  # rows past the record stay 0
            out[:, : k + 1] = simulate(self.spec, Pe, self.U[e_i, :k], Y0[sel], float(self.dts[e_i]), n_sub=n)
            dout = None
            if want_d:
                dout = np.zeros_like(out)
                Ue = np.ascontiguousarray(np.broadcast_to(self.U[e_i], (Pe.shape[0],) + self.U.shape[1:]))
                self.spec.kernels.derivatives(np.ascontiguousarray(out[:, : k + 1]), Ue, Pe, dout[:, : k + 1])
            res.append((out, dout, Pe))
        return res, n

    def offset_estimates(self, outs) -> dict[tuple[str, str], np.ndarray]:
        """Sensor offsets profiled out of the ``offsets`` channels: for every (group, channel)
        and copy, the weighted mean of ``y - y_hat`` over the group's samples (the least-squares
        value of a constant offset, given the model outputs)."""
        num: dict[tuple[str, str], np.ndarray] = {}
        den: dict[tuple[str, str], float] = {}
        for e, chans in zip(self.experiments, outs):
            w2 = np.ones(e.n_samples) if e.weights is None else e.weights**2
            for name, yhat in chans.items():
                if name in self.offsets:
                    key = (e.group, name)
                    num[key] = num.get(key, 0.0) + ((e.outputs[name][None, :] - yhat) * w2[None, :]).sum(axis=1)
                    den[key] = den.get(key, 0.0) + float(w2.sum())
        return {k: num[k] / den[k] for k in num if den[k] > 0}

    def outputs(self, P: np.ndarray, nsub: int | None = None):
        """Model outputs: list per experiment of {channel: (c, n_samples)}; and nsub used.
        Channels in ``offsets`` include their estimated sensor offset (:meth:`offset_estimates`)."""
        result, n = self._raw_outputs(P, nsub)
        if self.offsets:
            b = self.offset_estimates(result)
            for e, chans in zip(self.experiments, result):
                for name in chans:
                    if (e.group, name) in b:
                        chans[name] = chans[name] + b[(e.group, name)][:, None]
        return result, n

    def _raw_outputs(self, P: np.ndarray, nsub: int | None = None):
        sims, n = self.states(P, nsub)
        result = []
        for e, (S, D, Pe) in zip(self.experiments, sims):
            m = e.n_samples
            chans = {}
            for ch in self.channels:
                if ch.name not in e.outputs:
                    continue
                if ch.state is not None:
                    chans[ch.name] = S[:, :m, ch.state]
                elif ch.derivative is not None:
                    chans[ch.name] = D[:, :m, ch.derivative]
                else:
                    chans[ch.name] = np.asarray(ch.func(S[:, :m], Pe))
            result.append(chans)
        return result, n

    def residuals(self, P: np.ndarray, nsub: int | None = None) -> tuple[np.ndarray, int]:
        """Weighted residuals ``(c, N)`` (measured - model) / sigma, stacked over experiments
        and channels; non-finite model outputs give large finite residuals."""
        outs, n = self.outputs(P, nsub)
        parts = []
        for e, chans in zip(self.experiments, outs):
            for name, yhat in chans.items():
                r = (e.outputs[name][None, :] - yhat) / self.sigma[name]
                if e.weights is not None:
                    r = r * e.weights[None, :]
                parts.append(r)
        r = np.concatenate(parts, axis=1)
        return np.where(np.isfinite(r), r, 1e6), n


def _unvalidated(cls: type, row: np.ndarray) -> PhysicalParams:
    """An instance of ``cls`` holding ``row`` without running its checks (a candidate may
    violate a relation mid-fit); used only to recompute derived kernel columns."""
    obj = object.__new__(cls)
    for n_, v in zip(cls.names(), row):
        object.__setattr__(obj, n_, float(v))
    return obj


class _RawParams:
    """Attribute access to a packed parameter row (for ``stiffness_modes`` of candidates that
    violate a cross-field relation)."""

    def __init__(self, names, row, base):
        self._row = np.array(row, dtype=np.float64)
        for n_, v in zip(names, row):
            setattr(self, n_, float(v))
        for extra in ("mass",):
            if not hasattr(self, extra) and hasattr(base, extra):
                if hasattr(self, "platform_mass"):
                    setattr(self, extra, self.platform_mass + self.specimen_mass)

    def to_array(self) -> np.ndarray:
        return self._row.copy()


def _build_problem(base, fit, experiments, channels, sigma, log_scale, bounds,
                   n_substeps, tie=None, offsets=()) -> _Problem:
    if not isinstance(base, PhysicalParams):
        raise GreyboxError(f"base must be a PhysicalParams instance, got {type(base).__name__}")
    try:
        spec = registry.get(type(base).plant)
    except registry.UnknownPlantError:
        raise GreyboxError(f"base: {type(base).__name__} is not the parameter class of a registered plant") from None
    names_all = type(base).names()
    fit = tuple(fit)
    if not fit:
        raise GreyboxError("fit: give at least one parameter name")
    if len(set(fit)) != len(fit):
        raise GreyboxError(f"fit: duplicate parameter names in {list(fit)}")
    unknown = [n for n in fit if n not in names_all]
    if unknown:
        raise GreyboxError(f"fit: unknown parameter(s) {unknown} of {type(base).__name__}; known: {list(names_all)}")
    fields = {f.name: f for f in dataclasses.fields(base)}
    idx = np.array([names_all.index(n) for n in fit], dtype=np.int64)
    log = np.zeros(len(fit), dtype=bool)
    scale = np.ones(len(fit))
    lo = np.empty(len(fit))
    hi = np.empty(len(fit))
    bounds = dict(bounds or {})
    for i, n in enumerate(fit):
        meta = fields[n].metadata
        a, b = bounds.get(n, meta["allowed"])
        v = float(getattr(base, n))
        use_log = (log_scale.get(n) if isinstance(log_scale, Mapping) else log_scale)
        if use_log is None:
            use_log = v > 0 and b > 0
        if use_log:
            if v <= 0:
                raise GreyboxError(f"fit: {n} = {v} cannot be log-scaled (start value must be > 0)")
            a = max(a, v * 1e-6, 1e-300)
            if meta["open_low"] and a == meta["allowed"][0]:
                a = a * (1 + 1e-9) if a > 0 else v * 1e-6
            log[i] = True
            lo[i], hi[i] = math.log(a), math.log(b)
        else:
            s = abs(v) if v != 0 else max(abs(a) if math.isfinite(a) else 1.0, abs(b) if math.isfinite(b) else 1.0, 1.0)
            scale[i] = s
            span = (b - a) * 1e-9 if math.isfinite(b - a) else 0.0
            lo[i] = (a + (span if meta["open_low"] else 0.0)) / s
            hi[i] = (b - (span if meta["open_high"] else 0.0)) / s
        if not (lo[i] <= (math.log(v) if log[i] else v / scale[i]) <= hi[i]):
            raise GreyboxError(f"fit: start value {n} = {v} outside its bounds [{a}, {b}]")
    if isinstance(experiments, Experiment):
        experiments = [experiments]
    experiments = list(experiments)
    if not experiments:
        raise GreyboxError("experiments: give at least one")
    ch_map = {c.name: c for c in channels}
    used = set()
    for e in experiments:
        for k in e.outputs:
            if k not in ch_map:
                raise GreyboxError(f"experiment {e.name!r}: measured output {k!r} has no OutputChannel; "
                                   f"known: {sorted(ch_map)}")
            used.add(k)
    n_inputs = experiments[0].u.shape[1]
    if any(e.u.shape[1] != n_inputs for e in experiments):
        raise GreyboxError("experiments: all must have the same number of inputs")
    T = max(e.n_samples for e in experiments)
    U = np.zeros((len(experiments), T, n_inputs))
    for i, e in enumerate(experiments):
        U[i, : e.n_samples] = e.u
    sig: dict[str, float] = {}
    sigma = dict(sigma or {})
    for k in sorted(used):
        if k in sigma:
            s = float(sigma[k])
        else:
            y = np.concatenate([e.outputs[k] for e in experiments if k in e.outputs])
            s = float(np.sqrt(np.mean((y - y.mean()) ** 2)))
        if not (s > 0 and math.isfinite(s)):
            raise GreyboxError(f"channel {k!r}: scale sigma = {s} must be > 0 (constant record?)")
        sig[k] = s
    mod = _plant_module(base)
    n_states = int(getattr(mod, "N_STATES", len(getattr(mod, "STATE_NAMES", ()))))
    if n_states <= 0:
        raise GreyboxError(f"cannot find N_STATES of plant module {mod.__name__}")
    for e in experiments:
        if not callable(e.y0) and np.asarray(e.y0).shape != (n_states,):
            raise GreyboxError(f"experiment {e.name!r}: y0 must have {n_states} states")
        if not callable(e.y0):
            e.y0 = np.asarray(e.y0, dtype=np.float64)
    return _Problem(
        base=base, names=fit, idx=idx, log=log, scale=scale, lo=lo, hi=hi, spec=spec,
        experiments=experiments, channels=[ch_map[k] for k in ch_map if k in used], sigma=sig, U=U,
        n_steps=np.array([e.n_samples - 1 for e in experiments], dtype=np.int64),
        dts=np.array([e.dt for e in experiments], dtype=np.float64), n_states=n_states,
        stiffness=getattr(mod, "stiffness_modes", None), fixed_nsub=n_substeps, tie=tie,
        offsets=tuple(offsets),
    )


def simulate_outputs(base: PhysicalParams, experiments, channels,
                     values: Sequence[Mapping[str, float]] | None = None,
                     n_substeps: int | None = None, offsets: Sequence[str] = ()) -> list[list[dict[str, np.ndarray]]]:
    """Outputs of ``base`` (or of each override mapping in ``values``) on every experiment,
    in one batched kernel call: ``[copy][experiment] -> {channel: (n_samples,)}``.

    Experiments' ``outputs`` only name the channels to produce (their values are unused),
    except for ``offsets`` channels: their outputs include the sensor offset estimated from
    the measured values (per experiment group, see :func:`fit_greybox`)."""
    values = list(values) if values is not None else [{}]
    names = sorted({k for v in values for k in v}) or [type(base).names()[0]]
    prob = _build_problem(base, names, experiments, channels, {k: 1.0 for k in (c.name for c in channels)},
                          False, {n: (-np.inf, np.inf) for n in names}, n_substeps, offsets=offsets)
    P = np.repeat(base.to_array()[None, :], len(values), axis=0)
    nf = len(type(base).names())
    for i, v in enumerate(values):
        for k, x in v.items():
            P[i, type(base).index(k)] = x
        if v and P.shape[1] > nf:  # derived kernel columns follow the overridden fields
            P[i] = _unvalidated(type(base), P[i, :nf]).to_array()
    outs, _ = prob.outputs(P)
    return [[{k: o[k][i] for k in o} for o in outs] for i in range(len(values))]


# ======================================================================================
# result
# ======================================================================================


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
                 progress: Callable[[int, int], None] | None, max_calls: int) -> None:
        self.prob, self.fd_step, self.progress, self.max_calls = prob, fd_step, progress, max_calls
        self.p = len(prob.names)
        # the start values' sub-steps; a stiffer candidate raises it (per-call maximum)
        self.nsub = prob.nsub(base.to_array()[None, :]) if prob.fixed_nsub is None else prob.fixed_nsub
        self.nfev = 0
        self.njev = 0
        self.last: dict[str, Any] = {}

    def nsub_for(self, P: np.ndarray) -> int:
        prob = self.prob
        n = max(self.nsub, prob.nsub(P)) if prob.fixed_nsub is None else prob.fixed_nsub
        self.nsub = n
        return n

    def _tick(self) -> None:
        if self.progress is not None:
            self.progress(self.nfev + self.njev, self.max_calls)

    def fun(self, theta: np.ndarray) -> np.ndarray:
        self.nfev += 1
        self._tick()
        P = self.prob.param_arrays(theta[None, :])
        n = self.nsub_for(P)
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
    outs, _ = prob.outputs(P, nsub)
    offs = {f"{k}@{g}" if g else k: float(v[0])
            for (g, k), v in prob.offset_estimates(prob._raw_outputs(P, nsub)[0]).items()}
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
    """
    if jacobian not in ("central", "forward"):
        raise GreyboxError(f"jacobian must be 'central' or 'forward', got {jacobian!r}")
    t0 = time.perf_counter()
    prob = _build_problem(base, fit, experiments, channels, sigma,
                          True if log_scale is None else log_scale, bounds, n_substeps, tie, offsets)
    theta0 = prob.to_theta(np.array([getattr(base, n) for n in prob.names]))
    ev = _Evaluator(prob, base, fd_step, progress, (2 if reweight else 1) * 2 * max_nfev + 1)

    def solve(theta_start):
        return optimize.least_squares(ev.fun, theta_start, jac=ev.jac_forward if jacobian == "forward" else ev.jac,
                                      bounds=(prob.lo, prob.hi), method="trf",
                                      x_scale=1.0, ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev)

    sol = solve(np.clip(theta0, prob.lo, prob.hi))
    notes: list[str] = []
    if reweight and _reestimate_sigma(prob, sol.x, ev.nsub, set(sigma or {})):
        sol = solve(sol.x)
        notes.append("channel weights re-estimated from the residual RMS of a first fit (noise levels)")

    theta = sol.x
    st = _statistics(prob, theta, ev.jac(theta), sol.fun)
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
        message=str(sol.message), seconds=time.perf_counter() - t0, params=fitted, notes=notes, offsets=m["offsets"],
    )


def experiment_from_measured(data, plant: str, params: PhysicalParams, outputs: Sequence[str],
                             input_channel: str | Sequence[str] | None = None) -> Experiment:
    """An :class:`Experiment` from a :class:`hydro_envs.data.measured.MeasuredData` record.

    The sample time is the record's median step (the record must be uniformly sampled to
    1e-6 relative); the input columns are ``input_channel`` (one name or several, in the
    kernel's input order; default: the plant's registry inputs); the initial state is the
    plant's rest state at the first measured values (:func:`_initial_state`)."""
    t = np.asarray(data.t, dtype=float)
    dt = float(np.median(np.diff(t)))
    if np.max(np.abs(np.diff(t) - dt)) > 1e-6 * dt + 1e-12:
        raise GreyboxError("grey-box fits need a uniformly sampled record (constant time step)")
    if input_channel is None:
        inputs = list(registry.get(plant).inputs)
    else:
        inputs = [input_channel] if isinstance(input_channel, str) else list(input_channel)
    for name in inputs:
        if name not in data:
            raise GreyboxError(f"record has no input channel {name!r}")
    meas = {k: np.asarray(data[k], dtype=float) for k in outputs}
    x0 = float(meas["x"][0]) if "x" in meas else None
    return Experiment(dt=dt, u=np.stack([np.asarray(data[n], dtype=float) for n in inputs], axis=1),
                      y0=lambda prm: _initial_state(plant, prm, x0, meas), outputs=meas, name=str(data.metadata.get("name", "")))


def _initial_state(plant: str, params, x0: float | None, meas: Mapping[str, np.ndarray]) -> np.ndarray:
    """The plant's state at the record's first sample (its model's ``rest_state_from_measurement``)."""
    model = registry.get(plant).model
    if not hasattr(model, "rest_state_from_measurement"):
        raise GreyboxError(f"grey-box plant {plant!r} not supported; supported: {sorted(_plants())}")
    return model.rest_state_from_measurement(params, {k: float(v[0]) for k, v in meas.items()})
