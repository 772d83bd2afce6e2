"""Reference generators for tracking tasks.

Each generator returns a whole episode's reference as an array sampled at the env step, drawn
from the env's ``np.random.Generator`` so the same seed gives the same reference. Values lie in
``[low, high]``; the kinds are chosen so their peak rate stays below what the plant can follow
(the caller passes ``max_rate``, e.g. 80 % of the servo cylinder's no-load speed).

Kinds: ``steps`` (random levels held 0.2-0.6 s), ``smooth`` (sum of four random sines,
0.1-1.5 Hz), ``sine`` (one sine, 0.2-2 Hz), ``chirp`` (linear chirp 0.1 -> 3 Hz over the
episode). ``mixed`` picks one of them per episode.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["REFERENCE_KINDS", "FRICTION_REFERENCE_KINDS", "FrictionReference", "generate_reference",
           "generate_friction_reference"]

REFERENCE_KINDS = ("steps", "smooth", "sine", "chirp")
#: references where friction decides the error (see :func:`generate_friction_reference`)
FRICTION_REFERENCE_KINDS = ("slow_sine", "slow_triangle", "micro_steps")


def _limit_amplitude(amp: float, freq: float, max_rate: float) -> float:
    """Largest amplitude <= amp whose sine at ``freq`` has peak rate <= max_rate."""
    return min(amp, max_rate / (2.0 * math.pi * freq))


def generate_reference(
    kind: str,
    rng: np.random.Generator,
    n: int,
    dt: float,
    low: float,
    high: float,
    max_rate: float,
) -> np.ndarray:
    """Reference of ``n`` samples at spacing ``dt`` within ``[low, high]``."""
    if kind == "mixed":
        kind = REFERENCE_KINDS[int(rng.integers(len(REFERENCE_KINDS)))]
    if not (high > low and n > 0 and dt > 0 and max_rate > 0):
        raise ValueError(f"reference needs high > low, n > 0, dt > 0, max_rate > 0; got {low}, {high}, {n}, {dt}, {max_rate}")
    t = dt * np.arange(n)
    mid = 0.5 * (low + high)
    half = 0.5 * (high - low)
    if kind == "steps":
        out = np.empty(n)
        k = 0
        while k < n:
            hold = int(round(rng.uniform(0.2, 0.6) / dt))
            out[k : k + hold] = rng.uniform(low, high)
            k += hold
        return out
    if kind == "smooth":
        freqs = rng.uniform(0.1, 1.5, 4)
        phases = rng.uniform(0.0, 2.0 * math.pi, 4)
        weights = rng.uniform(0.5, 1.0, 4)
        y = np.zeros(n)
        for f, ph, w in zip(freqs, phases, weights):
            y += w * np.sin(2.0 * math.pi * f * t + ph)
        # scale so that both the excursion and the rate respect the limits
        peak = float(np.max(np.abs(y))) or 1.0
        rate = float(np.sum(weights * 2.0 * math.pi * freqs))
        amp = min(rng.uniform(0.3, 1.0) * half / peak, max_rate / rate)
        return mid + amp * y
    if kind == "sine":
        f = rng.uniform(0.2, 2.0)
        amp = _limit_amplitude(rng.uniform(0.2, 1.0) * half, f, max_rate)
        return mid + amp * np.sin(2.0 * math.pi * f * t + rng.uniform(0.0, 2.0 * math.pi))
    if kind == "chirp":
        f0, f1 = 0.1, 3.0
        duration = max(t[-1], dt)
        amp = _limit_amplitude(rng.uniform(0.3, 0.8) * half, f1, max_rate)
        phase = 2.0 * math.pi * (f0 * t + 0.5 * (f1 - f0) / duration * t**2)
        return mid + amp * np.sin(phase)
    raise ValueError(f"unknown reference kind {kind!r}; allowed: {REFERENCE_KINDS + ('mixed',)}")


@dataclasses.dataclass(frozen=True)
class FrictionReference:
    """Ranges of a friction task's reference (:func:`generate_friction_reference`), per plant.

    ``frequency`` [Hz] and ``amplitude`` [m] of the slow sine / triangle (``amplitude = None``:
    ``amplitude_fraction`` of the half band); ``step`` [m] of the micro steps (``None``:
    ``step_resolutions`` position-sensor resolutions) and their ``hold`` [s]. The defaults are
    the band-relative ranges of the rodless cylinder's tasks."""

    frequency: tuple[float, float] = (0.2, 0.5)
    amplitude: tuple[float, float] | None = None
    amplitude_fraction: tuple[float, float] = (0.05, 0.2)
    step: tuple[float, float] | None = None
    step_resolutions: tuple[float, float] = (3.0, 30.0)
    hold: tuple[float, float] = (0.3, 0.8)

    def __post_init__(self) -> None:
        for name in ("frequency", "amplitude", "amplitude_fraction", "step", "step_resolutions", "hold"):
            r = getattr(self, name)
            if r is not None and not (len(r) == 2 and 0.0 < r[0] <= r[1] and math.isfinite(r[1])):
                raise ValueError(f"FrictionReference.{name} = {r!r}; need 0 < low <= high")


def generate_friction_reference(
    kind: str,
    rng: np.random.Generator,
    n: int,
    dt: float,
    low: float,
    high: float,
    resolution: float,
    ranges: FrictionReference | None = None,
) -> np.ndarray:
    """Reference of ``n`` samples within ``[low, high]`` where friction decides the error.

    * ``slow_sine``: ``c + A sin(2 pi f t)`` with ``f`` and ``A`` from ``ranges``
      (:class:`FrictionReference`; default f 0.2-0.5 Hz, A 5-20 % of the half band): every
      reversal crosses the Stribeck region and the axis has to break away twice per period;
    * ``slow_triangle``: the same band as a triangle: constant low speed between reversals;
    * ``slow``: one of the two, drawn per episode;
    * ``micro_steps``: steps of ``ranges.step`` (default 3-30 position-sensor resolutions,
      ``resolution`` [m]) about the centre, each held ``ranges.hold`` (default 0.3-0.8 s):
      steady-state error, stick and hunting under integral action.

    Every kind starts at its centre ``c`` (uniform in the middle half of the band, so the
    plant can be started on the reference).
    """
    rg = ranges or FrictionReference()
    if kind == "slow":
        kind = ("slow_sine", "slow_triangle")[int(rng.integers(2))]
    if not (high > low and n > 0 and dt > 0 and resolution > 0):
        raise ValueError(f"reference needs high > low, n > 0, dt > 0, resolution > 0; got {low}, {high}, {n}, "
                         f"{dt}, {resolution}")
    t = dt * np.arange(n)
    half = 0.5 * (high - low)
    c = rng.uniform(low + 0.5 * half, high - 0.5 * half)
    if kind in ("slow_sine", "slow_triangle"):
        f = rng.uniform(*rg.frequency)
        amp = rng.uniform(*rg.amplitude) if rg.amplitude is not None else rng.uniform(*rg.amplitude_fraction) * half
        amp = min(amp, 0.5 * half)
        phase = 2.0 * math.pi * f * t
        if kind == "slow_sine":
            return c + amp * np.sin(phase)
        return c + amp * (2.0 / math.pi) * np.arcsin(np.sin(phase))
    if kind == "micro_steps":
        out = np.empty(n)
        k, level = 0, c
        while k < n:
            hold = int(round(rng.uniform(*rg.hold) / dt))
            out[k : k + hold] = level
            k += hold
            size = rng.uniform(*rg.step) if rg.step is not None else rng.uniform(*rg.step_resolutions) * resolution
            step = size * (1.0 if rng.random() < 0.5 else -1.0)
            level = float(np.clip(c + (level - c) + step, c - 0.5 * half, c + 0.5 * half))
        return out
    raise ValueError(f"unknown reference kind {kind!r}; allowed: {FRICTION_REFERENCE_KINDS + ('slow',)}")
