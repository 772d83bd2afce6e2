"""What a plant is to the rest of the package: its :class:`PlantSpec`.

A plant lives in one folder, ``hydro_envs/plants/<name>/``, with modules of fixed names:

=================  ==========================================================================
``params.py``      the validated parameter dataclass (value, unit, range, source per field)
``model.py``       state layout, numba right-hand side and guard, stiffness bound, outputs;
                   its ``CONTRACT``: the :class:`~hydro_envs.contract.PlantModel` consumers read
``kernels.py``     its ``KERNELS``: the right-hand side bound to the shared RK4 integrator
                   (:func:`hydro_envs.sim.binding.bind_rk4`, compiled, cached), a
                   :class:`~hydro_envs.contract.KernelSet`
``energy.py``      energy/mass-balance terms and guard checks of the soak test
``validation.py``  rows comparing the model with numbers printed in its seed paper
``experiments.py`` virtual experiments of the rig (optional)
``randomization.yaml``  default domain randomisation (``configs/plants/<plant>/``)
``spec.py``        its ``SPEC``: the entry :mod:`hydro_envs.registry` lists
=================  ==========================================================================

A spec is plain data: importing it does not import numba or the model. Everything heavy is
loaded on first use through :meth:`PlantSpec.module`, the way gymnasium resolves an env's
``entry_point`` string.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import re
from importlib import resources
from types import ModuleType
from typing import Any

from hydro_envs.contract import KernelSet, PlantModel

__all__ = ["Channel", "TIME_CHANNEL", "EnvEntry", "PlantSpec", "FRICTION_TESTS"]

#: the friction command's tests a plant may declare (:attr:`PlantSpec.friction_test`)
FRICTION_TESTS = (None, "annulus", "two_areas", "strokes")

_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_UNIT_RE = re.compile(r"[^\[\],\r\n]*")


@dataclasses.dataclass(frozen=True)
class Channel:
    """One measured signal: its column name, SI unit and a one-line meaning."""

    name: str
    unit: str
    meaning: str

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME_RE.fullmatch(self.name):
            raise ValueError(
                f"channel name {self.name!r} is invalid: use letters, digits and '_' (not starting with a digit)"
            )
        if not isinstance(self.unit, str) or not _UNIT_RE.fullmatch(self.unit):
            raise ValueError(f"channel {self.name!r}: unit {self.unit!r} must not contain brackets, commas or line breaks")


#: The time column, first column of every measured-data file.
TIME_CHANNEL = Channel("t", "s", "time since start of record")


@dataclasses.dataclass(frozen=True)
class EnvEntry:
    """One Gymnasium registration of a task on this plant."""

    id: str
    entry_point: str
    vector_entry_point: str
    max_episode_steps: int


@dataclasses.dataclass(frozen=True)
class PlantSpec:
    """Everything a consumer asks of one plant (see the module docstring).

    ``package`` is the plant's folder as a module path; ``params_class`` the name of its
    parameter dataclass in ``<package>.params``. A spec without a package describes measured
    data only (channels, no model).
    """

    name: str
    title: str
    source: str
    channels: tuple[Channel, ...]
    inputs: tuple[str, ...] = ()
    package: str = ""
    params_class: str = ""
    envs: tuple[EnvEntry, ...] = ()
    experiments: tuple[str, ...] = ()
    #: the parameter that bounds the position channels (stroke) and the pressure ceiling, for
    #: plausibility checks of measured records (names of ``params_class`` fields)
    stroke_parameter: str | None = None
    pressure_parameter: str | None = None
    #: the parameters that make the plant's dry friction (Coulomb, static, Stribeck levels; not
    #: viscous friction): set to 0 they leave viscous friction alone, the plant a benchmark
    #: compares with to measure what dry friction costs (``friction_share``)
    dry_friction_parameters: tuple[str, ...] = ()
    #: plausibility bounds of measured records for what the parameters do not give
    #: (:mod:`hydro_envs.data.checks`): the largest median sample time [s] that still resolves
    #: the plant's dynamics (a coarser one is most likely ms read as s), and for a plant without
    #: a stroke / pressure parameter or a pressure-area force bound, its stroke [m], absolute
    #: pressure [Pa] and force [N] bounds; ``regular_clock=False``: the logger has no fixed clock
    #: (neither jitter nor gaps are checked, each window is fitted on its own time stamps)
    max_sample_time: float | None = None
    max_stroke: float | None = None
    max_pressure: float | None = None
    max_force: float | None = None
    regular_clock: bool = True
    #: the friction command's constant-velocity test on this plant (``hydro identify friction``):
    #: "annulus" (a double-rod cylinder's square wave, F = A (p1 - p2), A the annulus from --area,
    #: --bore with --rod or the record's piston_area metadata), "two_areas" (a single-rod
    #: cylinder's square wave, F = A1 p1 - A2 p2, from --bore with --rod, --params FILE or the
    #: record's param.bore / param.rod metadata), "strokes" (a seal bench's constant-speed
    #: strokes, F over one bore); None: no such test
    friction_test: str | None = None

    def __post_init__(self) -> None:
        if not _NAME_RE.fullmatch(self.name):
            raise ValueError(f"plant name {self.name!r} is invalid: use letters, digits and '_'")
        names = [c.name for c in self.channels]
        if len(set(names)) != len(names):
            raise ValueError(f"plant {self.name!r}: duplicate channel names in {names}")
        if TIME_CHANNEL.name in names:
            raise ValueError(f"plant {self.name!r}: channel name 't' is reserved for the time column")
        missing = [i for i in self.inputs if i not in names]
        if missing:
            raise ValueError(f"plant {self.name!r}: inputs {missing} are not channels {names}")
        if self.friction_test not in FRICTION_TESTS:
            raise ValueError(f"plant {self.name!r}: friction_test = {self.friction_test!r}; allowed one of {FRICTION_TESTS}")
        for f in ("max_sample_time", "max_stroke", "max_pressure", "max_force"):
            v = getattr(self, f)
            if v is not None and not (isinstance(v, (int, float)) and 0 < v < float("inf")):
                raise ValueError(f"plant {self.name!r}: {f} = {v!r}; allowed a finite number > 0 or None")

    # ------------------------------------------------------------------ lazy parts
    @property
    def has_model(self) -> bool:
        return bool(self.package)

    def module(self, part: str) -> ModuleType:
        """``<package>.<part>`` (``params``, ``model``, ``kernels``, ``energy``, ...)."""
        if not self.package:
            raise LookupError(f"plant {self.name!r} has measured channels only, no {part!r} module")
        return _import(f"{self.package}.{part}")

    def has_module(self, part: str) -> bool:
        if not self.package:
            return False
        try:
            return resources.files(self.package).joinpath(f"{part}.py").is_file()
        except (ModuleNotFoundError, TypeError):
            return False

    @property
    def params_cls(self) -> type:
        """The parameter dataclass (a :class:`hydro_envs.params.PhysicalParams`)."""
        return getattr(self.module("params"), self.params_class)

    @property
    def model(self) -> ModuleType:
        return self.module("model")

    @property
    def contract(self) -> PlantModel:
        """The model's typed contract (``model.CONTRACT``, :class:`hydro_envs.contract.PlantModel`)."""
        return _typed(self.model, "CONTRACT", PlantModel, self.name)

    @property
    def kernels(self) -> KernelSet:
        """The compiled kernels (``kernels.KERNELS``, :class:`hydro_envs.contract.KernelSet`)."""
        return _typed(self.module("kernels"), "KERNELS", KernelSet, self.name)

    @property
    def state_names(self) -> tuple[str, ...]:
        return self.contract.state_names

    @property
    def state_units(self) -> tuple[str, ...]:
        return self.contract.state_units

    @property
    def n_states(self) -> int:
        return self.contract.n_states

    @property
    def env_ids(self) -> tuple[str, ...]:
        return tuple(e.id for e in self.envs)

    @property
    def state_outputs(self) -> dict[str, int]:
        """Measured channel -> the state index its sensor reads (``PlantModel.state_outputs``)."""
        return dict(self.contract.state_outputs)

    @property
    def derivative_outputs(self) -> dict[str, int]:
        """Measured channel -> the state whose derivative its sensor reads (an accelerometer)."""
        return dict(self.contract.derivative_outputs)

    def sensor_outputs(self, states: Any, params_rows: Any, inputs: Any = None) -> dict[str, Any]:
        """Noise-free sensor outputs of trajectories ``states (c, T, n_states)`` under kernel
        parameter rows ``(c, n_params)``: state readings, computed outputs
        (``PlantModel.computed_outputs``) and, when ``inputs (c, T', n_in)`` are given, derivative
        readings (the right-hand side along the trajectory)."""
        import numpy as np

        states = np.asarray(states, dtype=np.float64)
        out = {c: states[:, :, j] for c, j in self.state_outputs.items()}
        computed = self.contract.computed_outputs
        if computed is not None:
            out.update(computed(states, np.asarray(params_rows)))
        if inputs is not None and self.derivative_outputs:
            d = np.zeros_like(states)
            self.kernels.derivatives(np.ascontiguousarray(states), np.ascontiguousarray(inputs, dtype=np.float64),
                                     np.ascontiguousarray(params_rows, dtype=np.float64), d)
            out.update({c: d[:, :, j] for c, j in self.derivative_outputs.items()})
        return out

    def channel(self, name: str) -> Channel:
        for c in self.channels:
            if c.name == name:
                return c
        raise KeyError(f"plant {self.name!r} has no channel {name!r}; channels: {[c.name for c in self.channels]}")

    def stiffness_modes(self, params: Any) -> dict[str, float]:
        """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] of ``params``."""
        return dict(self.contract.stiffness_modes(params))

    def without_dry_friction(self, values: Any) -> dict[str, float]:
        """A parameter mapping ``values`` (overrides of the nominal set) with every dry-friction
        parameter (:attr:`dry_friction_parameters`) set to 0; ``ValueError`` for a plant without
        dry friction."""
        if not self.dry_friction_parameters:
            raise ValueError(f"plant {self.name!r} declares no dry-friction parameters")
        out = {k: float(v) for k, v in dict(values).items()}
        out.update({k: 0.0 for k in self.dry_friction_parameters})
        return out

    def randomization_file(self) -> Any:
        """The default randomisation spec shipped with the plant (a Traversable), or None."""
        if not self.package:
            return None
        from hydro_envs.config_files import config_file

        path = config_file("plants", self.package.rsplit(".", 1)[-1], "randomization.yaml")
        return path if path.is_file() else None

    def validation_rows(self) -> list[Any]:
        """Rows of the plant's ``validation.py`` (``rows()``), or [] without one."""
        if not self.has_module("validation"):
            return []
        return list(self.module("validation").rows())

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready description (channels with units, inputs, states, envs, experiments)."""
        d: dict[str, Any] = {
            "name": self.name,
            "title": self.title,
            "source": self.source,
            "channels": [dataclasses.asdict(TIME_CHANNEL)] + [dataclasses.asdict(c) for c in self.channels],
            "inputs": list(self.inputs),
            "envs": [e.id for e in self.envs],
            "experiments": list(self.experiments),
            "model": self.has_model,
            "dry_friction_parameters": list(self.dry_friction_parameters),
        }
        if self.has_model:
            d["parameters_class"] = self.params_class
            d["states"] = [{"name": n, "unit": u} for n, u in zip(self.state_names, self.state_units)]
        return d


def _typed(module: ModuleType, attr: str, kind: type, plant: str) -> Any:
    """``module.<attr>``, which must be a ``kind`` (:mod:`hydro_envs.contract`) instance."""
    obj = module.__dict__.get(attr)
    if not isinstance(obj, kind):
        raise TypeError(f"plant {plant!r}: {module.__name__}.{attr} must be a hydro_envs.contract.{kind.__name__}, "
                        f"got {type(obj).__name__}")
    return obj


@functools.lru_cache(maxsize=None)
def _import(name: str) -> ModuleType:
    return importlib.import_module(name)
