r"""The grey-box problem: output channels, experiments, the plants it fits, and the batched
simulation of candidate parameter sets (residuals and outputs) that :mod:`identification.greybox`
minimises.

:func:`plant_setup` reads a plant's output channels and its first-sample state from its model
(``FIT_OUTPUTS``, ``STATE_OUTPUTS``, ``DERIVATIVE_OUTPUTS``, ``computed_outputs``,
``rest_state_from_measurement``) through the registry; :func:`experiment_from_measured` turns a
measured record into an :class:`Experiment` (inputs held over each sample, states at the
samples); :func:`simulate_outputs` simulates the channels of a parameter set.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from hydro_envs import registry
from hydro_envs.contract import PlantModel
from hydro_envs.params import ParameterError, PhysicalParams
from hydro_envs.sim.simulate import simulate
from hydro_envs.sim.stiffness import substeps_from_stiffness as substeps_for_modes

__all__ = [
    "GreyboxError",
    "OutputChannel",
    "Experiment",
    "plant_setup",
    "supported_plants",
    "simulate_outputs",
    "experiment_from_measured",
]


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


def _plant_model(base: PhysicalParams) -> PlantModel:
    return registry.get(type(base).plant).contract


def _plants() -> dict[str, dict[str, Any]]:
    """Plants a grey-box fit can simulate: every registry plant whose contract
    (:class:`hydro_envs.contract.PlantModel`) gives ``rest_state_from_measurement`` (the state
    at a record's first sample).

    Channels: the measured ones the model reads from a state or a state derivative or computes,
    plus ``v`` (the velocity state) where the model names one; presets: the contract's
    ``presets`` if any."""
    out: dict[str, dict[str, Any]] = {}
    for spec in registry.specs():
        if not spec.package or not spec.has_module("model"):
            continue
        model = spec.contract
        if model.rest_state_from_measurement is None:
            continue
        units = {c.name: c.unit for c in spec.channels}
        chans = {name: OutputChannel(name, state=int(i), unit=units.get(name, ""))
                 for name, i in model.state_outputs.items()}
        chans.update({name: OutputChannel(name, derivative=int(i), unit=units.get(name, ""))
                      for name, i in model.derivative_outputs.items()})
        computed = model.computed_outputs
        if computed is not None:  # functions of the state trajectory (names from a trial call)
            trial = computed(np.zeros((1, 1, len(spec.state_names))), spec.params_cls().to_array()[None, :])
            chans.update({name: OutputChannel(name, func=_computed_channel(computed, name), unit=units.get(name, ""))
                          for name in trial})
        if "v" in spec.state_names and "v" not in chans:
            chans["v"] = OutputChannel("v", state=spec.state_names.index("v"), unit="m/s")
        presets = model.presets
        fit = model.fit_outputs if model.fit_outputs is not None else tuple(c for c in chans if c != "v")
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
        # exp only of the log-scaled entries (a linear one's theta can exceed exp's range)
        return np.where(self.log, np.exp(np.where(self.log, theta, 0.0)), theta * self.scale)

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
        names = type(self.base).names()
        prms: dict[int, PhysicalParams] = {}  # one validated parameter set per copy, shared by its windows
        for i in range(c * n_exp):
            e = self.experiments[exp_idx[i]]
            if callable(e.y0):
                copy = i // n_exp
                prm = prms.get(copy)
                if prm is None:
                    try:
                        prm = type(self.base)(**dict(zip(names, Pall[i])))
                    except ParameterError:
                        prm = self.base
                    prms[copy] = prm
                Y0[i] = e.y0(prm)
            else:
                Y0[i] = e.y0
        n = self.nsub(P) if nsub is None else nsub
        T = int(self.n_steps.max())
        want_d = any(ch.derivative is not None for ch in self.channels)
        res: list = [None] * n_exp
        # experiments of equal sample time and length run in one batched (threaded) call
        groups: dict[tuple[float, int], list[int]] = {}
        for e_i in range(n_exp):
            groups.setdefault((float(self.dts[e_i]), int(self.n_steps[e_i])), []).append(e_i)
        for (dt, k), members in groups.items():
            sels = [np.flatnonzero(exp_idx == e_i) for e_i in members]
            Pg = np.ascontiguousarray(np.concatenate([Pall[s] for s in sels]))
            Ug = np.concatenate([np.broadcast_to(self.U[e_i, :k], (s.size, k, self.U.shape[2]))
                                 for e_i, s in zip(members, sels)])
            Yg = np.concatenate([Y0[s] for s in sels])
            Sg = simulate(self.spec, Pg, np.ascontiguousarray(Ug), Yg, dt, n_sub=n)
            Dg = None
            if want_d:
                Dg = np.zeros_like(Sg)
                self.spec.kernels.derivatives(Sg, np.ascontiguousarray(Ug), Pg, Dg)
            j = 0
            for e_i, s in zip(members, sels):
                out = np.zeros((s.size, T + 1, self.n_states))  # rows past the record stay 0
                out[:, : k + 1] = Sg[j : j + s.size]
                dout = None
                if want_d:
                    dout = np.zeros_like(out)
                    dout[:, : k + 1] = Dg[j : j + s.size]
                res[e_i] = (out, dout, np.ascontiguousarray(Pg[j : j + s.size]))
                j += s.size
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
        self.add_offsets(result)
        return result, n

    def add_offsets(self, outs) -> dict[tuple[str, str], np.ndarray]:
        """Add the profiled sensor offsets (:meth:`offset_estimates`) to the ``offsets``
        channels of raw outputs ``outs`` in place; returns the offsets."""
        b = self.offset_estimates(outs) if self.offsets else {}
        for e, chans in zip(self.experiments, outs):
            for name in chans:
                if (e.group, name) in b:
                    chans[name] = chans[name] + b[(e.group, name)][:, None]
        return b

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
    mod = _plant_model(base)
    n_states = mod.n_states
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
        stiffness=mod.stiffness_modes, fixed_nsub=n_substeps, tie=tie,
        offsets=tuple(offsets),
    )


def simulate_outputs(base: PhysicalParams, experiments, channels,
                     values: Sequence[Mapping[str, float]] | None = None,
                     n_substeps: int | None = None, offsets: Sequence[str] = (),
                     per_copy_substeps: bool = False) -> list[list[dict[str, np.ndarray]]]:
    """Outputs of ``base`` (or of each override mapping in ``values``) on every experiment,
    in one batched kernel call: ``[copy][experiment] -> {channel: (n_samples,)}``.

    Experiments' ``outputs`` only name the channels to produce (their values are unused),
    except for ``offsets`` channels: their outputs include the sensor offset estimated from
    the measured values (per experiment group, see :func:`fit_greybox`).
    ``per_copy_substeps``: each copy integrated with its own stiffness bound's sub-steps
    (copies of equal count share a batched call) instead of the largest of all copies."""
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
    if per_copy_substeps and n_substeps is None and len(values) > 1:
        counts = np.array([prob.nsub(P[i:i + 1]) for i in range(len(values))])
        res: list = [None] * len(values)
        for n in np.unique(counts):
            idx = np.flatnonzero(counts == n)
            outs, _ = prob.outputs(np.ascontiguousarray(P[idx]), int(n))
            for j, i in enumerate(idx):
                res[i] = [{k: o[k][j] for k in o} for o in outs]
        return res
    outs, _ = prob.outputs(P)
    return [[{k: o[k][i] for k in o} for o in outs] for i in range(len(values))]


# ======================================================================================
# result
# ======================================================================================


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
    rest = registry.get(plant).contract.rest_state_from_measurement
    if rest is None:
        raise GreyboxError(f"grey-box plant {plant!r} not supported; supported: {sorted(_plants())}")
    return rest(params, {k: float(v[0]) for k, v in meas.items()})
