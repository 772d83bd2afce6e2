r"""Tasks where friction decides the tracking error: slow sines through velocity reversals and
micro-positioning, on the servo cylinder (seed 002) and the pneumatic rodless cylinder (004).

The plants, actions, observations and rewards are those of
:mod:`hydro_envs.envs.servo_cylinder` and :mod:`hydro_envs.envs.rodless_cylinder`; only the
reference (``hydro_envs.envs.references.generate_friction_reference``), the episode length and
the start differ. Each episode starts at rest *on* the reference, so the error is made by the
plant's friction, not by an initial transient.

=====================================  ==================================================  ========
env id                                 reference                                           steps
=====================================  ==================================================  ========
``ServoCylinderSlowSine-v0``           slow sine or triangle, 0.2-0.5 Hz, 5-20 % of the    4000
                                       half band: reversals through the Stribeck dip       (4 s)
``RodlessCylinderSlowSine-v0``         the same on the rodless cylinder                    4000
``ServoCylinderMicroPosition-v0``      steps of 3-30 encoder resolutions (0.09-0.9 mm),    3000
                                       held 0.3-0.8 s: steady-state error, stick, hunting  (3 s)
``RodlessCylinderMicroPosition-v0``    steps of 3-30 ruler resolutions (15-150 um)          3000
=====================================  ==================================================  ========

**Reward**, **observation**, **action**: as the plant's tracking env (error normalised by
``error_scale``, default 10 mm; the benchmark reports RMSE, reversal error, steady-state error,
limit-cycle amplitude and stick time beside the reward). **Termination**: none; truncation
after the steps above (registered ``max_episode_steps``).

``reset(options=...)`` accepts ``params``, ``state`` and ``reference`` as the base envs do; a
reference kind (``slow``, ``slow_sine``, ``slow_triangle``, ``micro_steps``) or an array.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from hydro_envs.envs.base import BatchedEnv, BatchedVectorEnv
from hydro_envs.envs.references import FRICTION_REFERENCE_KINDS, generate_friction_reference
from hydro_envs.envs.rodless_cylinder import REF_BAND as RODLESS_BAND
from hydro_envs.envs.rodless_cylinder import RodlessCylinderBatch
from hydro_envs.envs.servo_cylinder import REF_BAND as SERVO_BAND
from hydro_envs.envs.servo_cylinder import ServoCylinderBatch

__all__ = [
    "ServoCylinderSlowSineEnv", "ServoCylinderSlowSineVectorEnv",
    "RodlessCylinderSlowSineEnv", "RodlessCylinderSlowSineVectorEnv",
    "ServoCylinderMicroPositionEnv", "ServoCylinderMicroPositionVectorEnv",
    "RodlessCylinderMicroPositionEnv", "RodlessCylinderMicroPositionVectorEnv",
    "SLOW_SINE_STEPS", "MICRO_STEPS",
]

SLOW_SINE_STEPS = 4000
MICRO_STEPS = 3000
_KINDS = FRICTION_REFERENCE_KINDS + ("slow",)


class _FrictionTask:
    """Mixin: draws a friction reference and starts the plant at rest on it."""

    friction_kind: str
    band: tuple[float, float]
    position_name: str

    def _init_task(self, reference: str | None) -> None:
        kind = reference or self.friction_kind
        if kind not in _KINDS:
            raise ValueError(f"reference = {kind!r}; allowed {_KINDS}")
        self.friction_kind = kind

    def reset_task(self, i: int, rng: np.random.Generator, p: Any, options: Mapping[str, Any]) -> None:
        opts = dict(options)
        ref = opts.get("reference")
        if ref is None or isinstance(ref, str):
            kind = ref or self.friction_kind
            if kind not in _KINDS:
                raise ValueError(f"options['reference'] = {kind!r}; allowed {_KINDS} or an array [m]")
            L = p.stroke
            ref = generate_friction_reference(kind, rng, self.REF.shape[1], self.dt, self.band[0] * L,
                                              self.band[1] * L, self.quant)
            opts["reference"] = ref
        if not opts.get("state"):
            opts["state"] = {self.position_name: float(np.asarray(ref, dtype=float).reshape(-1)[0])}
        super().reset_task(i, rng, p, opts)  # type: ignore[misc]


class _ServoFriction(_FrictionTask, ServoCylinderBatch):
    band = SERVO_BAND
    position_name = "x"

    def __init__(self, n: int, *, parallel: bool, reference: str | None = None, **kwargs: Any) -> None:
        super().__init__(n, parallel=parallel, **kwargs)
        self._init_task(reference)


class _RodlessFriction(_FrictionTask, RodlessCylinderBatch):
    band = RODLESS_BAND
    position_name = "y"

    def __init__(self, n: int, *, parallel: bool, reference: str | None = None, **kwargs: Any) -> None:
        super().__init__(n, parallel=parallel, **kwargs)
        self._init_task(reference)


class ServoCylinderSlowSineBatch(_ServoFriction):
    friction_kind = "slow"
    episode_steps_default = SLOW_SINE_STEPS


class RodlessCylinderSlowSineBatch(_RodlessFriction):
    friction_kind = "slow"
    episode_steps_default = SLOW_SINE_STEPS


class ServoCylinderMicroPositionBatch(_ServoFriction):
    friction_kind = "micro_steps"
    episode_steps_default = MICRO_STEPS


class RodlessCylinderMicroPositionBatch(_RodlessFriction):
    friction_kind = "micro_steps"
    episode_steps_default = MICRO_STEPS


class ServoCylinderSlowSineEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = ServoCylinderSlowSineBatch


class ServoCylinderSlowSineVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ServoCylinderSlowSineBatch


class RodlessCylinderSlowSineEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = RodlessCylinderSlowSineBatch


class RodlessCylinderSlowSineVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = RodlessCylinderSlowSineBatch


class ServoCylinderMicroPositionEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = ServoCylinderMicroPositionBatch


class ServoCylinderMicroPositionVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = ServoCylinderMicroPositionBatch


class RodlessCylinderMicroPositionEnv(BatchedEnv):
    __doc__ = __doc__
    batch_cls = RodlessCylinderMicroPositionBatch


class RodlessCylinderMicroPositionVectorEnv(BatchedVectorEnv):
    __doc__ = BatchedVectorEnv.__doc__
    batch_cls = RodlessCylinderMicroPositionBatch
