r"""Tasks where friction decides the tracking error: slow sines through velocity reversals and
micro-positioning, on the servo cylinder (seed 002) and the pneumatic rodless cylinder (004).

The plants, actions, observations and rewards are those of the plants' tracking envs (their
env modules define the task classes with :class:`FrictionTask`); only the
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
``ForceActuatorSmallForce-v0``         small forces against the seals' stiction (seed      5000
                                       001): sines / triangles of 10-60 N through zero     (1 s)
                                       at 1-4 Hz, or steps of 10-60 N held 0.1-0.3 s, on
                                       the free piston pushing a compliant environment
=====================================  ==================================================  ========

The force actuator's task (:class:`SmallForceTask`, :func:`generate_small_force_reference`) is
a force, not a position, reference: every sign change of the force reverses the piston's
motion against the environment spring, so the seals stick and must break away (001 sec. 2:
"force control resolution is limited by the residual solid friction forces as seen at the
piston rod"). It starts at rest at zero force, where its reference starts.

**Reward**, **observation**, **action**: as the plant's tracking env (error normalised by
``error_scale``, default 10 mm; the benchmark reports RMSE, reversal error, steady-state error,
limit-cycle amplitude and stick time beside the reward). **Termination**: none; truncation
after the steps above (registered ``max_episode_steps``).

``reset(options=...)`` accepts ``params``, ``state`` and ``reference`` as the base envs do; a
reference kind (``slow``, ``slow_sine``, ``slow_triangle``, ``micro_steps``) or an array.
"""

from __future__ import annotations

from typing import Any, Mapping

import dataclasses
import math

import numpy as np

from hydro_envs.envs.references import FRICTION_REFERENCE_KINDS, FrictionReference, generate_friction_reference

__all__ = ["FrictionTask", "friction_task_classes", "SLOW_SINE_STEPS", "MICRO_STEPS", "SmallForceReference",
           "generate_small_force_reference", "SMALL_FORCE_KINDS", "SMALL_FORCE_STEPS"]

SLOW_SINE_STEPS = 4000
MICRO_STEPS = 3000
SMALL_FORCE_STEPS = 5000
SMALL_FORCE_KINDS = ("small_sine", "small_triangle", "small_steps")
_KINDS = FRICTION_REFERENCE_KINDS + ("slow",)


class FrictionTask:
    """Mixin of a cylinder-tracking batch: draws a friction reference and starts the plant at
    rest on it. The plant's env module sets ``friction_kind``, ``band`` (fractions of the
    stroke), ``position_name`` (state name) and ``episode_steps_default``."""

    friction_kind: str
    band: tuple[float, float]
    position_name: str
    #: the plant's reference ranges (None: the band-relative defaults)
    friction_ranges: FrictionReference | None = None

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
                                              self.band[1] * L, self.quant or 1e-6, self.friction_ranges)
            opts["reference"] = ref
        if not opts.get("state"):
            opts["state"] = {self.position_name: float(np.asarray(ref, dtype=float).reshape(-1)[0])}
        super().reset_task(i, rng, p, opts)  # type: ignore[misc]


def friction_task_classes(prefix: str, batch_cls: type, band: tuple[float, float], position_name: str,
                          module: str, *, steps: tuple[int, int] = (SLOW_SINE_STEPS, MICRO_STEPS),
                          ranges: FrictionReference | None = None,
                          defaults: Mapping[str, Any] | None = None) -> tuple[type, ...]:
    """The two friction-critical tasks on a plant's tracking batch ``batch_cls``: returns
    ``(SlowSineBatch, MicroPositionBatch, SlowSineEnv, SlowSineVectorEnv, MicroPositionEnv,
    MicroPositionVectorEnv)``, named ``<prefix><Task>...`` and owned by ``module`` (the plant's
    env module binds them to those names, so they pickle and register like hand-written ones).
    ``steps``: the episode lengths of the two tasks; ``ranges``: the plant's reference ranges;
    ``defaults``: keyword defaults of the tasks' batch (e.g. a finer position scale)."""
    from hydro_envs.envs.base import BatchedEnv, BatchedVectorEnv

    task_defaults = dict(defaults or {})

    def init(self, n: int, *, parallel: bool, reference: str | None = None, **kwargs: Any) -> None:
        batch_cls.__init__(self, n, parallel=parallel, **{**task_defaults, **kwargs})
        self._init_task(reference)

    def make(name: str, bases: tuple[type, ...], attrs: dict) -> type:
        cls = type(name, bases, {"__module__": module, "__qualname__": name, **attrs})
        return cls

    out = []
    for (task, kind), n_steps in zip((("SlowSine", "slow"), ("MicroPosition", "micro_steps")), steps):
        out.append(make(f"{prefix}{task}Batch", (FrictionTask, batch_cls),
                        {"band": band, "position_name": position_name, "friction_kind": kind,
                         "episode_steps_default": n_steps, "friction_ranges": ranges, "__init__": init}))
    envs = []
    for batch in out:
        name = batch.__name__[: -len("Batch")]
        envs.append(make(f"{name}Env", (BatchedEnv,), {"__doc__": __doc__, "batch_cls": batch}))
        envs.append(make(f"{name}VectorEnv", (BatchedVectorEnv,), {"__doc__": BatchedVectorEnv.__doc__,
                                                                    "batch_cls": batch}))
    return (*out, *envs)


@dataclasses.dataclass(frozen=True)
class SmallForceReference:
    """Ranges of the small-force task's reference [N, Hz, s] (:func:`generate_small_force_reference`):
    ``amplitude`` of the sines / triangles and the step levels, their ``frequency``, the steps'
    ``hold`` and ``rise`` time.

    The steps rise in 100 ms and hold 0.2-0.4 s: on the rig's 2e5 N/m spring a 120 N reversal in
    50 ms drives the free piston at up to 19 mm/s, past the valve's flow-limited damping knee near
    the null (eq (5)'s knee times its null floor, 8 mm/s), so the hydraulic damping and not the seals
    made most of the error; in 100 ms it peaks at 9.4 mm/s, the sines' 7.5 mm/s (60 N at 4 Hz)."""

    amplitude: tuple[float, float] = (10.0, 60.0)
    frequency: tuple[float, float] = (1.0, 4.0)
    hold: tuple[float, float] = (0.2, 0.4)
    rise: float = 0.1

    def __post_init__(self) -> None:
        if not (0.0 < self.rise < self.hold[0]):
            raise ValueError(f"SmallForceReference.rise = {self.rise!r}; need 0 < rise < hold[0]")
        for name in ("amplitude", "frequency", "hold"):
            r = getattr(self, name)
            if not (len(r) == 2 and 0.0 < r[0] <= r[1] and math.isfinite(r[1])):
                raise ValueError(f"SmallForceReference.{name} = {r!r}; need 0 < low <= high")


def generate_small_force_reference(kind: str, rng: np.random.Generator, n: int, dt: float,
                                   ranges: SmallForceReference | None = None) -> np.ndarray:
    """Force reference [N] of ``n`` samples where the seals' stiction decides the error:

    * ``small_sine``: ``A sin(2 pi f t)``, ``A`` and ``f`` uniform in ``ranges`` (10-60 N,
      1-4 Hz): the force changes sign twice a period, and so does the piston's motion;
    * ``small_triangle``: the same as a triangle (constant force rate between the reversals);
    * ``small_steps``: from 0, levels of ``+-A`` (A and the sign drawn per step) each held
      ``ranges.hold``, reached along a raised-cosine rise of ``ranges.rise`` (100 ms: the loop's
      own lag and the valve's flow-limited damping on a faster step would dominate the error): breakaway from a stuck seal on every
      step, hunting under integral action while a level holds;
    * ``small``: one of the three per episode.

    Every kind starts at 0 N, the plant's rest state (piston at rest, no force).
    """
    rg = ranges or SmallForceReference()
    if kind == "small":
        kind = SMALL_FORCE_KINDS[int(rng.integers(len(SMALL_FORCE_KINDS)))]
    if not (n > 0 and dt > 0):
        raise ValueError(f"reference needs n > 0, dt > 0; got {n}, {dt}")
    t = dt * np.arange(n)
    if kind in ("small_sine", "small_triangle"):
        amp = rng.uniform(*rg.amplitude)
        phase = 2.0 * math.pi * rng.uniform(*rg.frequency) * t
        if kind == "small_sine":
            return amp * np.sin(phase)
        return amp * (2.0 / math.pi) * np.arcsin(np.sin(phase))
    if kind == "small_steps":
        out = np.zeros(n)
        k = int(round(rng.uniform(*rg.hold) / dt))  # a first hold at 0 N
        rise = max(1, int(round(rg.rise / dt)))
        level = 0.0
        while k < n:
            new = rng.uniform(*rg.amplitude) * (1.0 if rng.random() < 0.5 else -1.0)
            hold = max(1, int(round(rng.uniform(*rg.hold) / dt)))
            j = np.arange(min(rise, n - k))
            out[k : k + j.size] = level + (new - level) * 0.5 * (1.0 - np.cos(math.pi * (j + 1) / rise))
            out[k + j.size : k + hold] = new
            level = new
            k += hold
        return out
    raise ValueError(f"unknown reference kind {kind!r}; allowed: {SMALL_FORCE_KINDS + ('small',)}")
