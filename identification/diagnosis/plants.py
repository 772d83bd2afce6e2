r"""What the diagnosis workflow needs to know about each plant.

A :class:`DiagnosisPlant` names the plant's parameter dataclass, its input and
measured channels (:mod:`hydro_envs.data.channels` names), the *base-fit* parameters that are
calibrated in every model (quantities every rig needs calibrated whatever effects it has:
mass, viscous damping, oil stiffness, valve gain), how to estimate the full state at the
start of a record segment from the measured channels (unmeasured states at their quasi-static
values), realistic sensor noise, and the closed-loop experiment the hidden-effect tests and the
demo record (a position loop around the plant tracking a multisine plus slow ramps, so the
record covers both directions, low and high speed and several pressure levels without
reaching the end stops).

Sensor offsets: pressure channels (``sensor_offsets``) may carry an unknown constant offset --
a transducer's zero error of 0.1-0.5 % of full scale is 0.25-1.2 bar on a 250-bar sensor, as
large as a leakage's pressure sag, and a common-mode offset on both chamber pressures looks
like external leakage. The workflow proposes "sensor_offsets" (one constant per channel,
profiled out of the refit: identification.greybox ``offsets``) as a measuring-chain candidate
beside the catalogue's effects; when it wins on held-out data it is kept as a correction,
flagged, and the search for physical effects goes on. Estimating offsets in every fit instead
was tried and rejected: they absorb the constant part of real effects (hidden servo friction
asymmetry: held-out shrink 0.78 -> 0.28).

Two comparison choices are per plant and physical: ``offset_free`` channels (positions of
integrating plants) are compared without their per-window mean -- a window replayed open-loop
from an estimated start velocity carries a constant position offset that is a start-state
error, not a model error; and held-out scores low-pass the error at ``score_bandwidth``
(the band of the test motion and of the position loop: 50 Hz for the cylinders and the slider,
the excitation band for the open-loop rigs), so white sensor noise above it does not set the
floor of the score.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Mapping
import numpy as np

from hydro_envs.params import PhysicalParams

__all__ = ["DiagnosisPlant", "PLANTS", "demo_cases", "diagnosis_plant", "reference_signal"]


@dataclasses.dataclass(frozen=True)
class DiagnosisPlant:
    """Plant description for the diagnosis workflow (see the module docstring)."""

    name: str
    params_factory: Callable[[], PhysicalParams]  # nominal parameters
    n_states: int
    inputs: tuple[str, ...]
    outputs: Mapping[str, int | Callable[[np.ndarray, np.ndarray], np.ndarray]]  # channel -> state index
    # or function (states (c, T, n_states), params (c, n_params)) -> (c, T)
    derivative_outputs: Mapping[str, int]  # measured channel -> derivative of state index
    required: tuple[str, ...]  # channels a record must have
    base_fit: tuple[str, ...]
    noise: Mapping[str, float]  # realistic sensor noise (std) per channel, synthetic data
    initial_state: Callable[[PhysicalParams, Mapping[str, float]], np.ndarray]
    controller: Callable[[np.ndarray, float, PhysicalParams], float]  # (meas, ref) -> input
    position_channel: str
    reference_centre: Callable[[PhysicalParams], float]  # m, centre of the test motion
    reference_amplitude: float  # m
    reference_speed: float  # m/s, ramp speed of the slow passes
    segment_seconds: float
    # unscored start of every window: >= ~3 time constants of the slowest lightly damped mode
    # the start-state estimate excites (slider m/b = 50 ms; servo oil column 1/(zeta_h omega_h)
    # = 0.1 s; shaking-table oil column ~0.18 s; rodless: friction-damped air spring), so the
    # scored part sees the model, not the start transient (truth-model floor of the table's
    # held-out NRMSE: 0.05 with 0.1 s, 0.0015 with 0.3 s, measured)
    warmup_seconds: float
    position_state: int
    velocity_state: int
    score_bandwidth: float  # Hz: held-out scores low-pass the error here (sensor noise above is not model error)
    offset_free: tuple[str, ...] = ()  # channels compared without their per-window mean (integrating outputs)
    # channels with an unknown constant sensor offset per record (pressure transducers' zero
    # error, 0.1-0.5 % of full scale): a nuisance parameter of every fit and score
    sensor_offsets: tuple[str, ...] = ()
    kernel_inputs: int = 1  # width of the kernel's input vector (extra columns held at 0)
    reference: Callable[[np.ndarray, np.random.Generator], np.ndarray] | None = None  # test signal override
    sample_time: float = 1e-3  # s, of the synthetic test records (the plant's control period)
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)  # channel -> SI unit (registry)
    # verdict ``unexplained`` above this many noise floors of held-out residual (floor.py): the
    # default, or per plant where correct models leave more (start-state errors of stiff or
    # slow plants, measured on the hidden-effect records; the setting's comment gives the value)
    unexplained_factor: float = 10.0
    # time constant [s] of the slowest start-state error of a base model (a rigid axis: m / b);
    # windows warm up for at least 3 of them and score at least 5 (None: the fixed settings)
    settling_time: Callable[[PhysicalParams], float] | None = None
    # name of the estimator (identification.diagnosis.base_estimates.ESTIMATORS) that reads the
    # base model's calibration (mass, damping, stroke) off the records when no preset is given
    base_from_data: str | None = None
    # unmeasured states implied by a record: ``(params, smoothed channels, inputs, dt) ->
    # {name: per-sample values}``, evaluated for the parameters being simulated and passed to
    # ``initial_state`` under ``name`` at each window start (the rodless cylinder's chamber
    # temperatures); None: the rest state's values
    hidden_states: Callable[[PhysicalParams, Mapping[str, np.ndarray], np.ndarray, float],
                            Mapping[str, np.ndarray]] | None = None

    @property
    def params_cls(self) -> type:
        return type(self.params_factory())


def reference_signal(t: np.ndarray, amplitude: float, speed: float, rng: np.random.Generator) -> np.ndarray:
    """Position reference [m]: slow triangle passes (constant speed ``speed`` and ``speed/4``,
    both directions) plus a random-phase multisine of 0.3-8 Hz, zero mean, peak <= amplitude.

    The ramps give long constant-velocity passes (where friction levels show), the multisine
    the dynamics (oil spring, valve) and many velocity reversals."""
    t = np.asarray(t, dtype=float)
    dur = float(t[-1] - t[0]) if t.size > 1 else 1.0
    a_tri = 0.45 * amplitude
    slow = np.zeros_like(t)
    half = dur / 2
    for k, (sp, sl) in enumerate(((speed, slice(None)), (speed / 4, slice(None)))):
        period = 4 * a_tri / sp
        phase = (t - t[0]) / period + rng.uniform()
        tri = a_tri * (2 * np.abs(2 * (phase - np.floor(phase + 0.5))) - 1)
        mask = (t - t[0] < half) if k == 0 else (t - t[0] >= half)
        slow[mask] = tri[mask]
    freqs = np.array([0.3, 0.7, 1.3, 2.1, 3.4, 5.5, 8.0])
    amps = 0.2 * amplitude / (1 + freqs)
    ph = rng.uniform(0, 2 * np.pi, freqs.size)
    ms = (amps[None, :] * np.sin(2 * np.pi * freqs[None, :] * (t - t[0])[:, None] + ph[None, :])).sum(axis=1)
    return slow + ms


def _multisine(f_lo: float, f_hi: float, n: int):
    """Reference generator: a random-phase multisine of ``n`` log-spaced frequencies from
    ``f_lo`` to ``f_hi`` Hz, peak-normalised to 1."""
    def reference(t, rng):
        f = np.geomspace(f_lo, f_hi, n)
        ph = rng.uniform(0, 2 * np.pi, f.size)
        sig = np.sin(2 * np.pi * f[None, :] * (t - t[0])[:, None] + ph[None, :]).sum(axis=1)
        return sig / np.max(np.abs(sig))
    return reference


_IGNORED = frozenset({"effects", "demo", "pressure_difference", "parameters", "multisine", "outputs",
                      "output_functions"})


def _build(spec, base: str, settings: Mapping) -> DiagnosisPlant:
    """A :class:`DiagnosisPlant` from the registry entry ``spec`` and one of the plain-data
    base-model settings of its folder's ``diagnosis`` module (``BASES[base]``)."""
    cls = spec.params_cls
    overrides = dict(settings.get("parameters", {}))
    params_factory = functools.partial(cls, **overrides) if overrides else cls
    states = spec.state_names
    state_outputs = spec.state_outputs
    keep = settings.get("outputs")
    outputs: dict = {c: j for c, j in state_outputs.items() if keep is None or c in keep}
    outputs.update(settings.get("output_functions", {}))  # channel -> f(states, param rows)
    position = settings["position_channel"]
    pos = states.index(settings["position_state"])
    kwargs = {k: v for k, v in settings.items() if k not in _IGNORED and k != "position_state"}
    if "multisine" in settings:
        kwargs["reference"] = _multisine(*settings["multisine"])
    kwargs.setdefault("reference_amplitude", 1.0)
    kwargs.setdefault("reference_speed", 1.0)
    return DiagnosisPlant(
        name=base, params_factory=params_factory, n_states=spec.n_states, inputs=tuple(spec.inputs),
        outputs=outputs, derivative_outputs=spec.derivative_outputs,
        required=tuple(spec.inputs) + (position,), position_state=pos, velocity_state=pos + 1,
        units={c.name: c.unit for c in spec.channels}, **kwargs)


def _bases() -> dict[str, tuple]:
    """Base name -> (registry spec, settings) for every plant folder with a ``diagnosis`` module."""
    from hydro_envs import registry

    out = {}
    for spec in registry.specs():
        if spec.has_module("diagnosis"):
            for base, settings in spec.module("diagnosis").BASES.items():
                out[base] = (spec, settings)
    return out


_BASES = _bases()
PLANTS = tuple(_BASES)
_CACHE: dict[str, DiagnosisPlant] = {}


def diagnosis_plant(name: str) -> DiagnosisPlant:
    """The :class:`DiagnosisPlant` of ``name`` (clear error listing the supported plants)."""
    if name not in _BASES:
        raise KeyError(f"diagnosis: plant {name!r} not supported; supported: {sorted(_BASES)}")
    if name not in _CACHE:
        _CACHE[name] = _build(_BASES[name][0], name, _BASES[name][1])
    return _CACHE[name]


def demo_cases() -> tuple[tuple[str, str, int], ...]:
    """(base, hidden effect, seed) of every base whose settings name a demo case, registry order."""
    return tuple((base, *settings["demo"]) for base, (_, settings) in _BASES.items() if "demo" in settings)
