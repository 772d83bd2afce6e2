r"""Position tracking with the valve-controlled servo cylinder (seed 002).

``hydro_envs/ServoCylinderPosition-v0``: the agent commands the servo-valve of a double-rod
cylinder (Moog D765, 6.63 cm^2, 69.6 mm stroke) so the piston follows a reference position.
Plant physics: :mod:`hydro_envs.plants.servo_cylinder` (002 eq (8), Table 1).

**Action** ``Box(-1, 1, (1,), float32)``: valve command as a fraction of +-10 V (full spool
stroke). Out-of-range actions are clipped; NaN or inf raise ``ValueError``.

**Observation** ``Box(float32, (11,))`` (position-like entries normalised as
``(s - L/2) / (L/2)``, so the stroke maps to [-1, 1])::

    0     tracking error (r - x_meas) / error_scale
    1     reference r, normalised
    2-6   reference preview at +10, +20, +30, +40, +50 ms, normalised
    7     measured position x_meas, normalised (encoder: 0.03 mm quantisation, 002 sec. 3)
    8-9   measured chamber pressures p1, p2 / supply pressure (absolute)
    10    last action

**Reward** ``-(e / error_scale)^2 - action_rate_penalty * (a_k - a_{k-1})^2`` with the *true*
position error ``e`` after the step (sensor noise does not enter the reward).

**Episode**: 1 kHz control (``dt = 1 ms``), truncated after 2000 steps (2 s) by the registered
``max_episode_steps``; no termination (the stops and guards keep the state physical).

**Reset**: draws the plant parameters from the plant's ``randomization.yaml``
(unless ``randomize=False``), a reference (``steps``, ``smooth``, ``sine``, ``chirp`` or
``mixed``) and a rest state with the piston in the middle half of the stroke and both chambers
at the valve's null pressure ``(p_s + p_R)/2``. ``reset(options=...)`` accepts ``params`` (a
mapping of parameter overrides, applied after the draw), ``state`` (mapping of state names to
values) and ``reference`` (a kind name or an array of positions [m], one per step).

**Info** at every step: ``state`` (plant state as SI quantities ``x, v, p1, p2, xv, vv, z``; ``z``
the seals' bristle deflection, :mod:`hydro_envs.plants.servo_cylinder.model`) and
``params`` (this episode's parameter set).

**Numerics**: every env step is one call of the compiled batch kernel; the number of RK4
sub-steps is chosen each episode from the drawn parameters' stiffness bound
(:func:`hydro_envs.plants.servo_cylinder.stiffness_modes`,
:func:`hydro_envs.sim.stiffness.substeps_from_stiffness`): 2 for the nominal plant (h = 0.5 ms).
"""

from __future__ import annotations

from typing import Any, Mapping

import numba as nb
import numpy as np

from hydro_envs.envs.base import VELOCITY_FACTOR, BatchedEnv, BatchedVectorEnv
from hydro_envs.envs.friction_tasks import friction_task_classes
from hydro_envs.envs.cylinder_tracking import (
    OBS_DIM,
    PREVIEW_STEPS,
    CylinderTrackingBatch,
    observation_space,
    step_observe_blocks,
)
from hydro_envs.envs.references import REFERENCE_KINDS, FrictionReference, generate_reference
from hydro_envs.plants.servo_cylinder import kernels
from hydro_envs.plants.servo_cylinder import model as plant
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.plants.servo_cylinder.spec import SPEC

__all__ = ["ServoCylinderPositionEnv", "ServoCylinderPositionVectorEnv", "ServoCylinderBatch", "observation_space",
           "OBS_DIM", "PREVIEW_STEPS"]

DT = 1e-3
EPISODE_STEPS = 2000
# Reference band inside the stroke and the largest reference rate (fractions of L and of the
# orifice-law no-load speed), so the task is feasible for every randomised plant.
REF_BAND = (0.1, 0.9)
REF_RATE_FRACTION = 0.6


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_observe_parallel(a):
    """One env step of every copy in one parallel region, stepped by the plant's
    :func:`~hydro_envs.plants.servo_cylinder.kernels.step_serial`
    (:func:`~hydro_envs.envs.cylinder_tracking.step_observe_blocks`)."""
    step_observe_blocks(kernels.step_serial, a)


class ServoCylinderBatch(CylinderTrackingBatch):
    """Servo-cylinder position-tracking episodes (see the module docstring)."""

    plant_spec = SPEC
    plant = plant
    params_cls = ServoCylinderParams
    dt = DT
    episode_steps_default = EPISODE_STEPS
    step_observe_kernels = {kernels.KERNELS.name: _step_observe_parallel}
    position_index = plant.X
    pressure_indices = (plant.P1, plant.P2)
    stroke_index = plant.I_L
    supply_index = plant.I_PS
    channel_names = ("u", "x", "p1", "p2")

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        reference: str = "mixed",
        position_quantization: float = 3e-5,
        **kwargs: Any,
    ) -> None:
        if reference not in REFERENCE_KINDS + ("mixed",):
            raise ValueError(f"reference = {reference!r}; allowed {REFERENCE_KINDS + ('mixed',)}")
        super().__init__(n, parallel=parallel, position_quantization=position_quantization, **kwargs)
        self.reference_kind = reference

    def state_limits(self, p: ServoCylinderParams) -> dict[str, tuple[float, float, str]]:
        lim = super().state_limits(p)
        vmax = VELOCITY_FACTOR * plant.no_load_velocity(p)
        self.narrow(lim, "v", -vmax, vmax, f"{VELOCITY_FACTOR:g} x the no-load velocity")
        return lim

    def reset_task(self, i: int, rng: np.random.Generator, p: ServoCylinderParams, options: Mapping[str, Any]) -> None:
        L = p.stroke
        # initial rest state: piston in the middle half, chambers at the valve's null pressure
        y = np.zeros(plant.N_STATES)
        y[plant.X] = rng.uniform(0.25 * L, 0.75 * L)
        y[plant.P1] = y[plant.P2] = 0.5 * (p.supply_pressure + p.tank_pressure)
        self.state_from_options(y, options)
        if not (0.0 <= y[plant.X] <= L):
            raise ValueError(f"options['state']['x'] = {y[plant.X]} m lies outside the stroke [0, {L}] m")
        for name, j in (("p1", plant.P1), ("p2", plant.P2)):
            if y[j] < p.pressure_floor:
                raise ValueError(
                    f"options['state'][{name!r}] = {y[j]} Pa is below the pressure floor "
                    f"{p.pressure_floor} Pa (pressures are absolute)"
                )
        self.Y[i] = y
        rate = REF_RATE_FRACTION * plant.no_load_velocity(p)
        self.set_reference(
            i,
            options.get("reference"),
            lambda kind, n: generate_reference(
                kind or self.reference_kind, rng, n, DT, REF_BAND[0] * L, REF_BAND[1] * L, rate
            ),
        )
        self.draw_noise(i, rng)

    def apply_actions(self) -> None:
        # action in [-1, 1] -> valve command in V (full spool stroke at +-command_max)
        np.multiply(self.last_a[:, 0], self.P[:, plant.I_UMAX], out=self.U[:, 0])


class ServoCylinderPositionEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = ServoCylinderBatch


class ServoCylinderPositionVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ServoCylinderBatch


# ------------------------------------------------------------------ friction-critical tasks
#: the friction tasks' references: creep through reversals at 0.3-3 mm/s (below the 10 mm/s
#: Stribeck velocity of the seals: the triangle's speed 4 A f, the sine's peak 2 pi A f), 2-8
#: reversals per 8 s episode; micro steps of 50-300 um (2-10 times the seals' 30 um pre-sliding
#: displacement, so every step breaks the seals away) held 2-3 s, long enough to show hunting
FRICTION_REFERENCE = FrictionReference(frequency=(0.2, 0.4), amplitude=(0.2e-3, 1.0e-3), step=(50e-6, 300e-6),
                                       hold=(2.0, 3.0))
#: episode length of both friction tasks [steps]
FRICTION_STEPS = 8000
#: a precision axis for the friction tasks: a 1 um linear scale instead of the 30 um encoder of 002
FRICTION_SCALE = 1e-6
#: error scale of the friction tasks' observation and reward [m]: their errors are tens of um
FRICTION_ERROR_SCALE = 1e-4
(
    ServoCylinderSlowSineBatch, ServoCylinderMicroPositionBatch,
    ServoCylinderSlowSineEnv, ServoCylinderSlowSineVectorEnv,
    ServoCylinderMicroPositionEnv, ServoCylinderMicroPositionVectorEnv,
) = friction_task_classes("ServoCylinder", ServoCylinderBatch, REF_BAND, "x", __name__,
                          steps=(FRICTION_STEPS, FRICTION_STEPS), ranges=FRICTION_REFERENCE,
                          defaults={"position_quantization": FRICTION_SCALE, "error_scale": FRICTION_ERROR_SCALE})
