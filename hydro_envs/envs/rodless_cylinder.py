r"""Point-to-point positioning and tracking with the pneumatic rodless cylinder (seed 004).

``hydro_envs/RodlessCylinder-v0``: the agent commands a FESTO MPYE-5 proportional valve
(0-10 V, closed centre at 5 V) driving an SMC MYC25G-110L mechanical rodless cylinder (bore
25 mm, stroke 110 mm, 0.6 MPa supply) so that the slider follows a reference position.
Plant physics: :mod:`hydro_envs.plants.rodless_cylinder` (004 eqs (1)-(18), Tables 1-2).

**Action** ``Box(-1, 1, (1,), float32)``: valve command ``u = 5 V + 5 V * a`` (a = -1 -> 0 V,
0 -> the 5 V centre, +1 -> 10 V). Out-of-range actions are clipped; NaN or inf raise
``ValueError``.

**Observation** ``Box(float32, (11,))`` (position-like entries normalised as
``(s - L/2) / (L/2)``, so the stroke maps to [-1, 1])::

    0     tracking error (r - y_meas) / error_scale
    1     reference r, normalised
    2-6   reference preview at +10, +20, +30, +40, +50 ms, normalised
    7     measured slider position y_meas, normalised (grating ruler: 5 um quantisation)
    8-9   measured chamber pressures pa, pb / supply pressure (absolute)
    10    last action

**Reward** ``-(e / error_scale)^2 - action_rate_penalty * (a_k - a_{k-1})^2`` with the *true*
position error ``e`` after the step (sensor noise does not enter the reward).

**Tasks** (constructor ``task``): ``"positioning"`` -- point-to-point: random set points held
0.2-0.6 s (``steps`` references); ``"tracking"`` -- a smooth reference per episode
(``smooth``, ``sine`` or ``chirp``); ``"mixed"`` (default) -- either, drawn per episode.
Smooth references stay below 0.15 m/s, under half the full-opening speed of the weakest
randomised plant (0.35 m/s).

**Episode**: 1 kHz control (``dt = 1 ms``), truncated after 2000 steps (2 s) by the registered
``max_episode_steps``; no termination (stops and guards keep the state physical).

**Reset**: draws the plant parameters from the plant's ``randomization.yaml``
(Stribeck parameters +-30 %, slider + payload mass 0.4-2 kg, supply 0.4-0.7 MPa gauge) unless
``randomize=False``, a reference, and a rest state: slider in the middle half of the stroke,
spool at the centre, both chambers at the valve's centre equilibrium pressure p_0 (leakage in
= leakage out, about 0.81 p_s) and at the supply temperature, unloaded seals (z = 0).
``reset(options=...)`` accepts ``params`` (parameter overrides, applied after the draw),
``state`` (state names to values; chamber masses not given are set for the supply
temperature at the final pressures and position) and ``reference`` (a kind name or an array
of positions [m], one per step).

**Info** at every step: ``state`` (``y, v, pa, pb, ma, mb, xv, vv, z`` in SI units; chamber
temperatures follow as ``p V / (m R)``, :func:`hydro_envs.plants.rodless_cylinder.chamber_temperatures`)
and ``params`` (this episode's parameter set).

**Constant-velocity operation** (004 sec. 3, eq (1)): a constant action holds the valve
opening, and the slider settles at a constant speed where ``A (p_a - p_b)`` equals the
Table 2 friction; :func:`hydro_envs.plants.rodless_cylinder.constant_command_run` runs that
experiment on the plant directly.

**Numerics**: every env step is one call of the compiled batch kernel; the RK4 sub-steps come
from the drawn parameters' stiffness bound: 5 per 1 ms for the nominal plant, 4-5 for 90 % of
the draws, at most 10 at the light, low-friction, high-supply corner (the LuGre bristle
relaxation at the speed bound, :func:`hydro_envs.plants.rodless_cylinder.stiffness_modes`).
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
from hydro_envs.envs.references import REFERENCE_KINDS, generate_reference
from hydro_envs.jit import njit_noalloc
from hydro_envs.plants.rodless_cylinder import kernels
from hydro_envs.plants.rodless_cylinder import model as plant
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.spec import SPEC

__all__ = [
    "RodlessCylinderEnv",
    "RodlessCylinderVectorEnv",
    "RodlessCylinderBatch",
    "observation_space",
    "TASKS",
    "OBS_DIM",
    "PREVIEW_STEPS",
]

DT = 1e-3
EPISODE_STEPS = 2000
REF_BAND = (0.1, 0.9)
REF_MAX_RATE = 0.15  # m/s
TASKS = ("positioning", "tracking", "mixed")
_TRACKING_KINDS = ("smooth", "sine", "chirp")


@njit_noalloc
def _apply_actions(last_a, P, U):
    """a in [-1, 1] -> U = centre + a (max - centre): 0..10 V with the 5 V closed centre."""
    for i in range(U.shape[0]):
        uc = P[i, plant.I_UC]
        U[i, 0] = uc + last_a[i, 0] * (P[i, plant.I_UMAX] - uc)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_observe_parallel(a):
    """One env step of every copy in one parallel region, stepped by the plant's
    general :func:`~hydro_envs.plants.rodless_cylinder.kernels.step_serial`
    (:func:`~hydro_envs.envs.cylinder_tracking.step_observe_blocks`)."""
    step_observe_blocks(kernels.step_serial, a)


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _step_observe_parallel_default(a):
    """One env step of every copy in one parallel region, stepped by the plant's
    step for a stiff supply and LuGre bristles in every row (every default set,
    :func:`~hydro_envs.plants.rodless_cylinder.kernels.step_serial_stiff_supply_lugre`)
    (:func:`~hydro_envs.envs.cylinder_tracking.step_observe_blocks`)."""
    step_observe_blocks(kernels.step_serial_stiff_supply_lugre, a)


class RodlessCylinderBatch(CylinderTrackingBatch):
    """Rodless-cylinder positioning / tracking episodes (see the module docstring)."""

    plant_spec = SPEC
    plant = plant
    refinement_bound = staticmethod(plant.local_mode_refinement)  # the kernels' m: counts in the sub-step cap
    params_cls = RodlessCylinderParams
    dt = DT
    episode_steps_default = EPISODE_STEPS
    step_observe_kernels = {kernels.STIFF_SUPPLY_LUGRE.name: _step_observe_parallel_default}
    step_observe_general = staticmethod(_step_observe_parallel)
    position_index = plant.Y
    pressure_indices = (plant.PA, plant.PB)
    stroke_index = plant.I_L
    supply_index = plant.I_PS
    channel_names = ("u", "y", "pa", "pb")

    def __init__(
        self,
        n: int,
        *,
        parallel: bool,
        task: str = "mixed",
        position_quantization: float = 5e-6,
        **kwargs: Any,
    ) -> None:
        if task not in TASKS:
            raise ValueError(f"task = {task!r}; allowed {TASKS}")
        super().__init__(n, parallel=parallel, position_quantization=position_quantization, **kwargs)
        self.task = task
        self._p0_cache: dict[tuple[float, ...], float] = {}

    def _centre_pressure(self, p: RodlessCylinderParams) -> float:
        key = (p.supply_pressure, p.exhaust_pressure, p.supply_temperature, p.heat_capacity_ratio,
               p.gas_constant, p.laminar_pressure_ratio, p.flow_model, p.critical_pressure_ratio)
        if key not in self._p0_cache:
            if len(self._p0_cache) > 4096:
                self._p0_cache.clear()
            self._p0_cache[key] = plant.centre_pressure(p)
        return self._p0_cache[key]

    def _reference_kind(self, rng: np.random.Generator) -> str:
        if self.task == "positioning":
            return "steps"
        if self.task == "tracking":
            return _TRACKING_KINDS[int(rng.integers(len(_TRACKING_KINDS)))]
        return REFERENCE_KINDS[int(rng.integers(len(REFERENCE_KINDS)))]

    def state_limits(self, p: RodlessCylinderParams) -> dict[str, tuple[float, float, str]]:
        lim = super().state_limits(p)
        vmax = VELOCITY_FACTOR * plant.speed_bound(p)
        self.narrow(lim, "v", -vmax, vmax, f"{VELOCITY_FACTOR:g} x the speed bound of the plant model")
        # LuGre: sigma0 z never exceeds the largest friction level when it starts inside it
        if p.bristle_stiffness > 0.0:  # 0: no bristle state (friction-free carriage), z stays generic
            zmax = max(p.static_friction, p.coulomb_friction) / p.bristle_stiffness
            self.narrow(lim, "z", -zmax, zmax,
                        "bristle deflection at most max(static, Coulomb friction) / bristle_stiffness")
        return lim

    def reset_task(self, i: int, rng: np.random.Generator, p: RodlessCylinderParams, options: Mapping[str, Any]) -> None:
        L = p.stroke
        p0 = self._centre_pressure(p)
        y = np.zeros(plant.N_STATES)
        y[plant.Y] = rng.uniform(0.25 * L, 0.75 * L)
        y[plant.PA] = y[plant.PB] = p0
        given = set((options.get("state") or {}).keys())
        self.state_from_options(y, options)
        if not (0.0 <= y[plant.Y] <= L):
            raise ValueError(f"options['state']['y'] = {y[plant.Y]} m lies outside the stroke [0, {L}] m")
        for name, j in (("pa", plant.PA), ("pb", plant.PB)):
            if y[j] < p.pressure_floor:
                raise ValueError(
                    f"options['state'][{name!r}] = {y[j]} Pa is below the pressure floor "
                    f"{p.pressure_floor} Pa (pressures are absolute)"
                )
        va, vb = plant.chamber_volumes(y, p)
        rt = p.gas_constant * p.supply_temperature
        if "ma" not in given:
            y[plant.MA] = y[plant.PA] * va[0] / rt
        if "mb" not in given:
            y[plant.MB] = y[plant.PB] * vb[0] / rt
        for name, j in (("ma", plant.MA), ("mb", plant.MB)):
            if not y[j] > p.min_gas_mass:
                raise ValueError(f"options['state'][{name!r}] = {y[j]} kg must exceed min_gas_mass {p.min_gas_mass} kg")
        self.Y[i] = y
        L = p.stroke
        self.set_reference(
            i,
            options.get("reference"),
            lambda kind, n: generate_reference(
                kind or self._reference_kind(rng), rng, n, DT, REF_BAND[0] * L, REF_BAND[1] * L, REF_MAX_RATE
            ),
        )
        self.draw_noise(i, rng)

    def apply_actions(self) -> None:
        _apply_actions(self.last_a, self.P, self.U)


class RodlessCylinderEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = RodlessCylinderBatch


class RodlessCylinderVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = RodlessCylinderBatch


# ------------------------------------------------------------------ friction-critical tasks
(
    RodlessCylinderSlowSineBatch, RodlessCylinderMicroPositionBatch,
    RodlessCylinderSlowSineEnv, RodlessCylinderSlowSineVectorEnv,
    RodlessCylinderMicroPositionEnv, RodlessCylinderMicroPositionVectorEnv,
) = friction_task_classes("RodlessCylinder", RodlessCylinderBatch, REF_BAND, "y", __name__)
