"""The typed plant contract: what a plant's ``model.py`` and ``kernels.py`` give the package.

Each plant with a model exports exactly one :class:`PlantModel` from its ``model.py``
(``CONTRACT = PlantModel(...)``) and one :class:`KernelSet` from its ``kernels.py``
(``KERNELS = bind_rk4(...)``, :func:`hydro_envs.sim.binding.bind_rk4`). Every consumer -- the
registry's :class:`~hydro_envs.spec.PlantSpec`, :func:`hydro_envs.sim.simulate`, the envs,
identification, diagnosis, the soak test and the agents -- reads these typed fields; nothing
probes a plant module for optional attributes. An optional piece is an explicit ``None`` (or
an empty mapping): its docstring below says who uses it and what its absence means.

:func:`param_columns` gives the column indices of a parameter dataclass' packed kernel row,
generated from :func:`dataclasses.fields` (declaration order) and the derived column names,
so an index is looked up by field name instead of kept by hand in a parallel tuple.

:func:`conformance_problems` checks one plant against the contract (the test
``tests/test_plant_contract.py`` runs it over the registry). This module imports neither numba
nor a plant: importing it is cheap.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any

__all__ = ["PlantModel", "KernelSet", "param_columns", "conformance_problems"]


def _frozen_map(value: Mapping[str, int], field: str) -> Mapping[str, int]:
    if not isinstance(value, Mapping):
        raise TypeError(f"PlantModel.{field} must be a mapping channel -> state index, got {type(value).__name__}")
    return MappingProxyType(dict(value))


@dataclasses.dataclass(frozen=True)
class PlantModel:
    """The model side of a plant (``<plant>/model.py``'s ``CONTRACT``).

    Required:

    * ``state_names`` / ``state_units``: the state vector's layout (names, SI units), the same
      length; the count is :attr:`n_states`. Used by the registry (``PlantSpec.state_names``),
      ``sim.simulate`` (``x0`` check), the envs (state options, non-finite messages) and
      identification (initial states).
    * ``stiffness_modes(params) -> {mode: |eigenvalue| [1/s]}``: upper estimates of the
      Jacobian's eigenvalue magnitudes, from which every caller sizes its RK4 sub-step
      (``sim.substeps``, the envs, grey-box fits).

    Optional (``None`` / empty = the plant does not have it):

    * ``state_outputs``: measured channel -> the state index its sensor reads (the registry's
      ``sensor_outputs``, grey-box output channels, diagnosis).
    * ``derivative_outputs``: measured channel -> the state whose derivative its sensor reads
      (an accelerometer); the same users.
    * ``computed_outputs(states (c, T, n), P (c, n_params)) -> {channel: (c, T)}``: outputs
      that are functions of the state and parameters (e.g. a load cell behind a sensor model);
      the same users.
    * ``fit_outputs``: the channels a grey-box fit compares by default
      (``identification.greybox_problem``); ``None``: every output except ``v``.
    * ``presets``: named parameter sets of the parameter class a grey-box fit may start from
      (``hydro identify greybox --preset``); ``None``: the plant has none.
    * ``rest_state(params, ...)``: the state at rest, further arguments (a position, an
      operating point) the plant's own; the conformance check calls ``rest_state(params)``
      when the plant has no ``rest_state_from_measurement``.
    * ``rest_state_from_measurement(params, first: {channel: value})``: the state at a
      record's first sample, every channel not in ``first`` at the plant's default (grey-box
      fits and diagnosis; the conformance check's start with ``first = {}``); ``None``: the
      plant cannot be fitted to records.
    * A plant gives at least one of the two.
    * ``n_states_for(params) -> int``: for a plant whose state width depends on its
      parameters (pipe segments), the width of that set (``sim.simulate`` accepts it);
      ``None``: always :attr:`n_states`.
    * ``relief_bounds(P) -> (state indices, (n, k) [Pa])``: chamber pressures and their
      reliefs' full-flow pressure, checked by the soak test (``hydro_envs.soak``).
    * ``soak_temperatures(Y, P) -> (n, k) [K]`` and ``soak_temperature_floor(P) -> (n,) [K]``:
      pneumatic chamber temperatures and the lowest the physics allows, checked by the soak
      test; both or neither.
    * ``piston_area(params) -> m^2``: the area that turns chamber pressures into force, for a
      plant whose parameter set has no ``piston_area`` field (the agents' friction-model fit,
      ``agents.controllers.friction_models``).
    * ``load_params(source) -> params``: the plant's reader of a parameter file with units (a
      data sheet: path, shipped name or mapping), converting and checking each value once
      (``--params FILE`` of ``hydro identify`` and ``hydro diagnose``, the friction command's
      geometry); ``None``: a parameter file is a preset (``plant:``, ``parameters:``, each
      ``{value, unit, source}``, :func:`identification.ranges.load_preset`).
    """

    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    stiffness_modes: Callable[[Any], Mapping[str, float]]
    state_outputs: Mapping[str, int] = dataclasses.field(default_factory=dict)
    derivative_outputs: Mapping[str, int] = dataclasses.field(default_factory=dict)
    computed_outputs: Callable[[Any, Any], Mapping[str, Any]] | None = None
    fit_outputs: tuple[str, ...] | None = None
    presets: tuple[str, ...] | None = None
    rest_state: Callable[..., Any] | None = None
    rest_state_from_measurement: Callable[[Any, dict[str, float]], Any] | None = None
    n_states_for: Callable[[Any], int] | None = None
    relief_bounds: Callable[[Any], tuple[Any, Any]] | None = None
    soak_temperatures: Callable[[Any, Any], Any] | None = None
    soak_temperature_floor: Callable[[Any], Any] | None = None
    piston_area: Callable[[Any], float] | None = None
    load_params: Callable[[Any], Any] | None = None

    def __post_init__(self) -> None:
        for f in ("state_names", "state_units"):
            v = getattr(self, f)
            if not isinstance(v, tuple) or not v or not all(isinstance(s, str) for s in v):
                raise TypeError(f"PlantModel.{f} must be a non-empty tuple of str, got {v!r}")
        if len(self.state_units) != len(self.state_names):
            raise ValueError(f"PlantModel.state_units has {len(self.state_units)} entries; allowed: one per state "
                             f"({len(self.state_names)}: {', '.join(self.state_names)})")
        if len(set(self.state_names)) != len(self.state_names):
            raise ValueError(f"PlantModel.state_names has duplicates: {self.state_names}")
        object.__setattr__(self, "state_outputs", _frozen_map(self.state_outputs, "state_outputs"))
        object.__setattr__(self, "derivative_outputs", _frozen_map(self.derivative_outputs, "derivative_outputs"))
        for f in ("state_outputs", "derivative_outputs"):
            for name, i in getattr(self, f).items():
                if not isinstance(i, int) or isinstance(i, bool) or not 0 <= i < self.n_states:
                    raise ValueError(f"PlantModel.{f}[{name!r}] = {i!r}; allowed a state index 0..{self.n_states - 1}")
        for f in ("fit_outputs", "presets"):
            v = getattr(self, f)
            if v is not None and (not isinstance(v, tuple) or not all(isinstance(s, str) for s in v)):
                raise TypeError(f"PlantModel.{f} must be a tuple of str or None, got {v!r}")
        for f in _CALLABLES:
            v = getattr(self, f)
            if v is not None and not callable(v):
                raise TypeError(f"PlantModel.{f} must be callable or None, got {type(v).__name__}")
        if not callable(self.stiffness_modes):
            raise TypeError(f"PlantModel.stiffness_modes must be callable, got {type(self.stiffness_modes).__name__}")
        if (self.soak_temperatures is None) != (self.soak_temperature_floor is None):
            raise ValueError("PlantModel.soak_temperatures and soak_temperature_floor: give both or neither")

    @property
    def n_states(self) -> int:
        """The state count (the largest, for a plant with :attr:`n_states_for`)."""
        return len(self.state_names)

    @property
    def output_names(self) -> tuple[str, ...]:
        """Channels read from a state or a state derivative (computed outputs not included)."""
        return tuple(self.state_outputs) + tuple(self.derivative_outputs)


_CALLABLES = ("computed_outputs", "rest_state", "rest_state_from_measurement", "n_states_for", "relief_bounds",
              "soak_temperatures", "soak_temperature_floor", "piston_area", "load_params")


@dataclasses.dataclass(frozen=True)
class KernelSet:
    """The compiled kernels of a plant (``<plant>/kernels.py``'s ``KERNELS``), layouts as in
    :mod:`hydro_envs.sim.rk4`.

    * ``step_serial`` / ``step_parallel(Y, U, P, dt, NSUB, W, clamps)``: one env step of a batch
      (the envs, serial for a single env);
    * ``trajectories(Y0, U, P, dt, NSUB, W, OUT, clamps)``: whole input sequences
      (``sim.simulate``, grey-box fits);
    * ``derivatives(X, U, P, OUT)``: the right-hand side along trajectories (accelerometer
      outputs, linearisation);
    * ``rhs(y, u, p, dy)`` / ``guard(y, p)``: the plant's compiled right-hand side and guard
      (reference integrations, tests);
    * ``name``: the set's name (an env's step-and-observe kernel for it is chosen by name);
    * ``for_params(P) -> KernelSet``: optional, for a plant with step kernels specialised to
      its parameter rows (the envs call it after the rows change); ``None``: one set serves
      every row.
    """

    step_serial: Callable[..., Any]
    step_parallel: Callable[..., Any]
    trajectories: Callable[..., Any]
    derivatives: Callable[..., Any]
    rhs: Callable[..., Any]
    guard: Callable[..., Any]
    for_params: Callable[[Any], KernelSet] | None = None
    #: the set's name (``bind_rk4``'s): an env picks its step-and-observe kernel by it
    name: str = ""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name == "name":
                continue
            v = getattr(self, f.name)
            if not (callable(v) or (v is None and f.name == "for_params")):
                raise TypeError(f"KernelSet.{f.name} must be callable, got {type(v).__name__}")

    def pick(self, P: Any) -> KernelSet:
        """The kernels for parameter rows ``P`` (:attr:`for_params`, else this set)."""
        return self if self.for_params is None else self.for_params(P)


def param_columns(cls: type) -> dict[str, int]:
    """Column of every field of parameter dataclass ``cls`` in its packed kernel row
    (``to_array()``): the fields in declaration order (:func:`dataclasses.fields`), then
    ``cls.derived_names``. Index a column by name: ``I_MASS = param_columns(P)["mass"]``."""
    if not dataclasses.is_dataclass(cls):
        raise TypeError(f"param_columns: {cls!r} is not a dataclass")
    names = [f.name for f in dataclasses.fields(cls)] + list(getattr(cls, "derived_names", ()))
    if len(set(names)) != len(names):
        raise ValueError(f"{cls.__name__}: a derived column repeats a field name: {names}")
    return {n: i for i, n in enumerate(names)}


def conformance_problems(spec: Any, run_kernels: bool = True) -> list[str]:
    """What plant ``spec`` (a :class:`~hydro_envs.spec.PlantSpec` with a model) lacks or has
    wrong against the contract, one message per piece, each naming the plant and the piece;
    [] when it conforms. ``run_kernels``: also advance the nominal rest state one step of 1 ms
    and evaluate the right-hand side there (finite results)."""
    import numpy as np

    name = spec.name
    out: list[str] = []
    try:
        model = spec.contract
    except Exception as e:  # noqa: BLE001 -- reported, not raised
        return [f"plant {name!r}: model.CONTRACT: {e}"]
    if not isinstance(model, PlantModel):
        return [f"plant {name!r}: model.CONTRACT is a {type(model).__name__}, not a PlantModel"]
    try:
        kernels = spec.kernels
    except Exception as e:  # noqa: BLE001
        kernels = None
        out.append(f"plant {name!r}: kernels.KERNELS: {e}")
    if kernels is not None and not isinstance(kernels, KernelSet):
        out.append(f"plant {name!r}: kernels.KERNELS is a {type(kernels).__name__}, not a KernelSet")
        kernels = None
    cls = spec.params_cls
    p = cls()
    row = np.asarray(p.to_array(), dtype=np.float64)
    cols = param_columns(cls)
    if row.shape != (len(cols),):
        out.append(f"plant {name!r}: parameter row has shape {row.shape}; the dataclass gives {len(cols)} columns")
    out += _output_problems(name, model, spec)
    y0 = _rest(name, model, p, out)
    modes = model.stiffness_modes(p)
    if not isinstance(modes, Mapping) or not modes or not all(math.isfinite(float(v)) and v >= 0 for v in modes.values()):
        out.append(f"plant {name!r}: stiffness_modes(nominal) = {modes!r}; allowed a non-empty mapping of finite values >= 0")
    if run_kernels and kernels is not None and y0 is not None and not out:
        out += _kernel_problems(name, spec, kernels, y0, row, modes)
    return out


def _output_problems(name: str, model: PlantModel, spec: Any) -> list[str]:
    out = []
    chans = {c.name for c in spec.channels}
    for ch in model.output_names:
        if ch not in chans:
            out.append(f"plant {name!r}: output {ch!r} is not a registry channel {sorted(chans)}")
    if model.fit_outputs is not None:
        known = set(model.output_names) | chans
        bad = [c for c in model.fit_outputs if c not in known]
        if bad:
            out.append(f"plant {name!r}: fit_outputs {bad} are neither outputs nor channels")
    for k in model.presets or ():
        try:
            spec.params_cls.preset(k)
        except Exception as e:  # noqa: BLE001 -- reported, not raised
            out.append(f"plant {name!r}: presets: {spec.params_cls.__name__}.preset({k!r}) raised {type(e).__name__}: {e}")
    return out


def _rest(name: str, model: PlantModel, p: Any, out: list[str]) -> Any:
    import numpy as np

    if model.rest_state_from_measurement is not None:  # every channel unmeasured: the plant's own defaults
        what, rest = "rest_state_from_measurement", lambda q: model.rest_state_from_measurement(q, {})  # type: ignore[misc]
    elif model.rest_state is not None:
        what, rest = "rest_state", model.rest_state
    else:
        out.append(f"plant {name!r}: neither rest_state nor rest_state_from_measurement: no state to start from")
        return None
    try:
        y0 = np.asarray(rest(p), dtype=np.float64)
    except Exception as e:  # noqa: BLE001
        out.append(f"plant {name!r}: {what}(nominal) raised {type(e).__name__}: {e}")
        return None
    n = model.n_states if model.n_states_for is None else int(model.n_states_for(p))
    if y0.shape != (n,) or not np.all(np.isfinite(y0)):
        out.append(f"plant {name!r}: {what}(nominal) has shape {y0.shape} and finite={bool(np.all(np.isfinite(y0)))}; "
                   f"allowed ({n},) finite")
        return None
    return y0


def _kernel_problems(name: str, spec: Any, kernels: KernelSet, y0: Any, row: Any, modes: Mapping[str, float]) -> list[str]:
    import numpy as np

    from hydro_envs.sim.stiffness import substeps_from_stiffness

    n_in = max(1, len(spec.inputs))
    n_sub = substeps_from_stiffness(modes, 1e-3, 0.5)[0]
    Y = y0[None, :].copy()
    U = np.zeros((1, n_in))
    P = row[None, :].copy()
    k = kernels.pick(P)
    k.step_serial(Y, U, P, 1e-3, np.array([n_sub], dtype=np.int64), np.zeros((1, 5, Y.shape[1])),
                  np.zeros(1, dtype=np.int64))
    dy = np.zeros_like(y0)
    kernels.rhs(y0.copy(), U[0], row, dy)
    if not (np.all(np.isfinite(Y)) and np.all(np.isfinite(dy))):
        return [f"plant {name!r}: one kernel step from rest_state is not finite (state {Y[0].tolist()}, rhs {dy.tolist()})"]
    return []
