r"""Position tracking with the valve-controlled differential cylinder (issue 54's data-sheet rig).

``hydro_envs/DifferentialCylinderPosition-v0``: the agent commands the 4/3 proportional valve of
a single-rod cylinder (63/36 x 300 mm, 160 bar, 40 L/min at 70 bar, 60 Hz) so the piston follows
a reference position. Plant physics: :mod:`hydro_envs.plants.differential_cylinder`. The same
conventions as ``ServoCylinderPosition-v0`` (:mod:`hydro_envs.envs.servo_cylinder`).

**Action** ``Box(-1, 1, (1,), float32)``: valve command as a fraction of +-command_max (10 V,
full opening; > 0 extends). Out-of-range actions are clipped; NaN or inf raise ``ValueError``.

**Observation** ``Box(float32, (11,))`` (position-like entries normalised as
``(s - L/2) / (L/2)``, so the stroke maps to [-1, 1])::

    0     tracking error (r - x_meas) / error_scale
    1     reference r, normalised
    2-6   reference preview at +10, +20, +30, +40, +50 ms, normalised
    7     measured position x_meas, normalised (encoder: 10 um quantisation, assumed)
    8-9   measured cap- and rod-side pressures p1, p2 / supply pressure (absolute)
    10    last action

**Reward** ``-(e / error_scale)^2 - action_rate_penalty * (a_k - a_{k-1})^2`` with the *true*
position error ``e`` after the step (sensor noise does not enter the reward).

**Episode**: 1 kHz control (``dt = 1 ms``), truncated after 2000 steps (2 s) by the registered
``max_episode_steps``; no termination (the stops and guards keep the state physical).

**Reset**: draws the plant parameters from the plant's ``randomization.yaml`` (scale factors
around the nominal rig; unless ``randomize=False``), a reference (``steps``, ``smooth``,
``sine``, ``chirp`` or ``mixed``; centred on mid-stroke, as wide as the retracting no-load speed
crosses in 0.15 s: 49 mm on the nominal rig) and a rest state with the piston in the middle half of the
stroke, the rod side at the valve's null pressure ``(p_s + p_T)/2`` and the cap side at the
pressure that balances it and the load (:func:`~hydro_envs.plants.differential_cylinder.model.rest_state`).
``reset(options=...)`` accepts ``params``, ``state`` and ``reference`` as the servo env.

**Parameters from a file**: ``gym.make(id, params=FILE_OR_MAPPING)`` also takes a parameter file
with units (a path, or the name of a shipped file such as ``differential_cylinder_63_36_300``) or
a mapping with units or ``valve``/``friction`` sections
(:mod:`hydro_envs.plants.differential_cylinder.datasheet`): the file's rig is the nominal set and
the randomisation draws around it (nothing is held fixed).

**Info** at every step: ``state`` (``x, v, p1, p2, xv, vv, z``) and ``params``.

**Numerics**: RK4 sub-steps from the drawn parameters' stiffness bound
(:func:`hydro_envs.plants.differential_cylinder.model.stiffness_modes`): 5 for the nominal rig,
set by the laminar core of the valve's orifice law into the 100 cm^3 dead volumes.

Friction tasks ``DifferentialCylinderSlowSine-v0`` and ``DifferentialCylinderMicroPosition-v0``
(:mod:`hydro_envs.envs.friction_tasks`): creep through reversals at 0.3-3 mm/s and micro steps of
50-300 um, 8000 steps, a 1 um scale.
"""

from __future__ import annotations

from typing import Any, Mapping

import numba as nb
import numpy as np

from hydro_envs.envs.base import VELOCITY_FACTOR, BatchedEnv, BatchedVectorEnv
from hydro_envs.envs.cylinder_tracking import OBS_DIM, CylinderTrackingBatch, observation_space, step_observe_blocks
from hydro_envs.envs.friction_tasks import friction_task_classes
from hydro_envs.envs.references import REFERENCE_KINDS, FrictionReference, generate_reference
from hydro_envs.plants.differential_cylinder import kernels
from hydro_envs.plants.differential_cylinder import model as plant
from hydro_envs.plants.differential_cylinder.datasheet import is_rig_source, load_rig
from hydro_envs.plants.differential_cylinder.params import DifferentialCylinderParams
from hydro_envs.plants.differential_cylinder.spec import SPEC

__all__ = ["DifferentialCylinderPositionEnv", "DifferentialCylinderPositionVectorEnv", "DifferentialCylinderBatch",
           "observation_space", "OBS_DIM"]

DT = 1e-3
EPISODE_STEPS = 2000
#: band of the friction tasks' references (fractions of the stroke)
REF_BAND = (0.1, 0.9)
#: the tracking references' band: centred on mid-stroke, as wide as the retracting no-load speed
#: crosses in this time [s] (at most REF_BAND): a long stroke's steps would otherwise be ramps at
#: full opening for most of their 0.2-0.6 s holds (0.24 m at 0.33 m/s on the 300 mm rig)
REF_CROSSING_TIME = 0.15
#: the largest reference rate as a fraction of the slower (retracting) no-load speed
REF_RATE_FRACTION = 0.6


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_observe_parallel(a):
    """One env step of every copy in one parallel region
    (:func:`~hydro_envs.envs.cylinder_tracking.step_observe_blocks`)."""
    step_observe_blocks(kernels.step_serial, a)


class DifferentialCylinderBatch(CylinderTrackingBatch):
    """Differential-cylinder position-tracking episodes (see the module docstring)."""

    plant_spec = SPEC
    plant = plant
    params_cls = DifferentialCylinderParams
    dt = DT
    episode_steps_default = EPISODE_STEPS
    step_observe_kernels = {kernels.KERNELS.name: _step_observe_parallel}
    position_index = plant.X
    pressure_indices = (plant.P1, plant.P2)
    stroke_index = plant.I_L
    supply_index = plant.I_PS
    channel_names = ("u", "x", "p1", "p2")

    def __init__(self, n: int, *, parallel: bool, reference: str = "mixed", position_quantization: float = 1e-5,
                 params: Any = None, **kwargs: Any) -> None:
        if reference not in REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {REFERENCE_KINDS + ('mixed',)}")
        self.rig_from_file = is_rig_source(params)
        if self.rig_from_file:
            params = load_rig(params)
        super().__init__(n, parallel=parallel, position_quantization=position_quantization, params=params, **kwargs)
        self.reference_kind = reference

    def hold_params(self, names, *, warn: bool = True) -> None:
        """A rig from a parameter file is the nominal set the (scale-factor) randomisation draws
        around: nothing is held; the ranges' corners around it must be valid parameter sets."""
        if not self.rig_from_file:
            super().hold_params(names, warn=warn)
        elif self.spec is not None:
            try:
                self.spec.check_corners(base=self.base_params)
            except ValueError as exc:
                raise ValueError(f"params from a parameter file with randomisation on: {exc}; pass randomize=False "
                                 "or a rig whose randomised corners are valid") from None

    def state_limits(self, p: DifferentialCylinderParams) -> dict[str, tuple[float, float, str]]:
        lim = super().state_limits(p)
        vmax = VELOCITY_FACTOR * plant.no_load_velocity(p, 1)
        self.narrow(lim, "v", -vmax, vmax, f"{VELOCITY_FACTOR:g} x the extending no-load velocity")
        return lim

    def reset_task(self, i: int, rng: np.random.Generator, p: DifferentialCylinderParams,
                   options: Mapping[str, Any]) -> None:
        L = p.stroke
        y = plant.rest_state(p, rng.uniform(0.25 * L, 0.75 * L))
        self.state_from_options(y, options)
        if not (0.0 <= y[plant.X] <= L):
            raise ValueError(f"options['state']['x'] = {y[plant.X]} m lies outside the stroke [0, {L}] m")
        for name, j in (("p1", plant.P1), ("p2", plant.P2)):
            if y[j] < p.pressure_floor:
                raise ValueError(f"options['state'][{name!r}] = {y[j]} Pa is below the pressure floor "
                                 f"{p.pressure_floor} Pa (pressures are absolute)")
        self.Y[i] = y
        v_ret = plant.no_load_velocity(p, -1)
        half = min(0.5 * (REF_BAND[1] - REF_BAND[0]) * L, 0.5 * REF_CROSSING_TIME * v_ret)
        rate = REF_RATE_FRACTION * v_ret
        self.set_reference(i, options.get("reference"), lambda kind, n: generate_reference(
            kind or self.reference_kind, rng, n, DT, 0.5 * L - half, 0.5 * L + half, rate))
        self.draw_noise(i, rng)

    def apply_actions(self) -> None:
        # action in [-1, 1] -> valve command in V (full opening at +-command_max)
        np.multiply(self.last_a[:, 0], self.P[:, plant.I_UMAX], out=self.U[:, 0])


class _RigFromFile:
    """Env mixin: ``params`` may be a parameter file or a mapping with units (:func:`_rig_kwargs`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **_rig_kwargs(kwargs))


class DifferentialCylinderPositionEnv(_RigFromFile, BatchedEnv):
    __doc__ = __doc__
    batch_cls = DifferentialCylinderBatch


class DifferentialCylinderPositionVectorEnv(_RigFromFile, BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = DifferentialCylinderBatch


def _rig_kwargs(kwargs: dict[str, Any]) -> dict[str, Any]:
    """``params`` given as a parameter file or a mapping with units, read once here: the batch gets
    the rig's SI values under the ``plant`` key (a parameter mapping, so nothing is held fixed)."""
    params = kwargs.get("params")
    if is_rig_source(params):
        kwargs = {**kwargs, "params": {"plant": SPEC.name, **load_rig(params).as_dict()}}
    return kwargs


# ------------------------------------------------------------------ friction-critical tasks
#: the servo plant's friction references (creep at 0.3-3 mm/s below the 10 mm/s Stribeck velocity,
#: micro steps of 50-300 um, 2-10 times the seals' 30 um pre-sliding displacement, held 2-3 s)
FRICTION_REFERENCE = FrictionReference(frequency=(0.2, 0.4), amplitude=(0.2e-3, 1.0e-3), step=(50e-6, 300e-6),
                                       hold=(2.0, 3.0))
FRICTION_STEPS = 8000
(
    DifferentialCylinderSlowSineBatch, DifferentialCylinderMicroPositionBatch, *_task_envs,
) = friction_task_classes("DifferentialCylinder", DifferentialCylinderBatch, REF_BAND, "x", __name__,
                          steps=(FRICTION_STEPS, FRICTION_STEPS), ranges=FRICTION_REFERENCE,
                          defaults={"position_quantization": 1e-6, "error_scale": 1e-4})


class DifferentialCylinderSlowSineEnv(_RigFromFile, BatchedEnv):
    __doc__ = __doc__
    batch_cls = DifferentialCylinderSlowSineBatch


class DifferentialCylinderSlowSineVectorEnv(_RigFromFile, BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = DifferentialCylinderSlowSineBatch


class DifferentialCylinderMicroPositionEnv(_RigFromFile, BatchedEnv):
    __doc__ = __doc__
    batch_cls = DifferentialCylinderMicroPositionBatch


class DifferentialCylinderMicroPositionVectorEnv(_RigFromFile, BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = DifferentialCylinderMicroPositionBatch
