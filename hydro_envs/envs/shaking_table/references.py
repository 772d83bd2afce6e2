r"""Acceleration references for the shaking table, feasible for the drawn plant.

Every kind is built as a table *displacement* ``d(t)`` that starts at rest (``d = d' = 0`` at
``t <= 0``); the acceleration reference is its second central difference on the env grid,
``a_k = (d_{k+1} - 2 d_k + d_{k-1}) / dt^2``. So the reference is always the acceleration of a
motion that exists, starts from rest and stays inside the stroke -- a pure
``a = A sin(w t)`` from rest would integrate to a velocity offset ``A / w`` and drift the table
into its end stops. One scale factor then bounds the motion by the plant's limits
(:func:`reference_limits`): peak displacement (stroke), peak velocity (valve flow) and peak
acceleration (force), since for a sine ``a = D w^2 = V w``: at 0.5 Hz the displacement limits
the acceleration to ``0.052 m (pi)^2 = 0.51 m/s^2``, at 15 Hz the force does.

Kinds (drawn from the env's ``np.random.Generator``; ``mixed`` picks one per episode):

``sine``
    One sine, frequency log-uniform in 0.5-15 Hz (003 sec. 2: operating range 0-15 Hz), faded
    in over ``max(0.25 s, one period)`` by a raised cosine; amplitude 20-100 % of the feasible.
``pulse``
    Smooth displacement moves between random levels (003 Fig. 11, pulse input): each move has
    a raised-cosine velocity of duration 0.1-0.5 s, so its acceleration is one full sine period
    (a positive and a negative pulse); moves are separated by 0.2-0.8 s holds.
``transition``
    003 eq (23): a sine whose amplitude doubles (or halves) part-way (0.1 -> 0.2 at 4.35 s of
    6 s in the paper), here at 50-80 % of the episode, frequency 1-4 Hz (paper: 2 Hz), the
    amplitude change smoothed over half a period.
``earthquake``
    Synthetic ground motion: white noise through the Kanai-Tajimi soil filter
    ``H(s) = (2 zeta_g w_g s + w_g^2) / (s^2 + 2 zeta_g w_g s + w_g^2)`` and the Clough-Penzien
    high-pass ``s^2 / (s^2 + 2 zeta_f w_f s + w_f^2)`` (which keeps the displacement spectrum
    finite), times a Jennings-Housner-Tsai envelope (quadratic rise to ``t1``, strong phase to
    ``t2``, exponential decay ``exp(-c (t - t2))``), then baseline-corrected (a ``c2 t^2 + c3
    t^3`` trend fitted to the double-integrated displacement and removed, which keeps
    ``d(0) = d'(0) = 0``) and scaled to the limits.
    Assumed parameters: ``w_g = 5 pi rad/s, zeta_g = 0.6`` (firm soil, the values commonly used
    since Tajimi 1960; e.g. Clough & Penzien, Dynamics of Structures), ``w_f = 0.1 w_g``,
    ``zeta_f = 0.6`` (Clough-Penzien); envelope ``t1`` 0.5-1 s, strong phase 1.5-3 s,
    ``c`` 0.5-1.5 1/s (Jennings et al. 1968 shape, time-compressed as for scaled specimens so a
    record fits a 6 s episode).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hydro_envs.laws.filters import lfilter_from_rest

__all__ = [
    "TABLE_REFERENCE_KINDS",
    "ReferenceLimits",
    "reference_limits",
    "generate_table_reference",
    "KANAI_TAJIMI",
    "LOW_FREQUENCY",
    "low_frequency_reference",
]

TABLE_REFERENCE_KINDS = ("sine", "pulse", "transition", "earthquake")

#: Assumed earthquake filter parameters (see the module docstring).
KANAI_TAJIMI = {"omega_g": 5.0 * math.pi, "zeta_g": 0.6, "omega_f": 0.5 * math.pi, "zeta_f": 0.6}

SINE_BAND_HZ = (0.5, 15.0)


@dataclasses.dataclass(frozen=True)
class ReferenceLimits:
    """Peak displacement [m], velocity [m/s] and acceleration [m/s^2] a reference may ask for."""

    displacement: float
    velocity: float
    acceleration: float

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"reference limit {f.name} must be finite and > 0, got {v}")


def reference_limits(
    params,
    displacement_fraction: float = 0.4,
    velocity_fraction: float = 0.5,
    force_fraction: float = 0.4,
) -> ReferenceLimits:
    """Limits for a shaking-table parameter set (:class:`ShakingTableParams`).

    * displacement: ``displacement_fraction`` of the half stroke (0.4: 52 mm of 130 mm),
      leaving the agent room for drift;
    * velocity: ``velocity_fraction`` of the orifice-law no-load speed (0.5: 0.22 m/s), so the
      valve keeps flow in reserve for the load pressure;
    * acceleration: ``force_fraction`` of what the full hydraulic force minus static friction
      gives the drawn mass, ``(A (P_s - P_T) - F_s) / M`` (0.4: 8.5 m/s^2 with 200 kg,
      6.3 m/s^2 with 500 kg).
    """
    from hydro_envs.plants.shaking_table.model import max_drive_force, no_load_velocity
    from hydro_envs.params import ParameterError

    if not params.flow_coefficient > 0.0:
        raise ParameterError(
            f"ShakingTableParams.flow_coefficient = {params.flow_coefficient} m^3/(s Pa^0.5): a sealed valve "
            "(the plant's physics tests use it) moves no table; an env's references need flow_coefficient > 0")
    f_avail = max(max_drive_force(params) - params.static_friction, 1e-6)
    return ReferenceLimits(
        displacement=displacement_fraction * 0.5 * params.stroke,
        velocity=velocity_fraction * no_load_velocity(params),
        acceleration=force_fraction * f_avail / params.mass,
    )


def _raised_cosine_ramp(t: np.ndarray, t_start: float, duration: float) -> np.ndarray:
    """0 before ``t_start``, 1 after ``t_start + duration``, raised cosine in between."""
    s = np.clip((t - t_start) / duration, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(math.pi * s))


def _sine_shape(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    f = math.exp(rng.uniform(math.log(SINE_BAND_HZ[0]), math.log(SINE_BAND_HZ[1])))
    ramp = max(0.25, 1.0 / f)
    phase = rng.uniform(0.0, 2.0 * math.pi)
    return _raised_cosine_ramp(t, 0.0, ramp) * np.sin(2.0 * math.pi * f * t + phase)


def _transition_shape(rng: np.random.Generator, t: np.ndarray, duration: float) -> np.ndarray:
    f = rng.uniform(1.0, 4.0)
    ratio = 2.0 if rng.uniform() < 0.5 else 0.5
    t_switch = rng.uniform(0.5, 0.8) * duration
    ramp_in = max(0.25, 1.0 / f)
    amp = 1.0 + (ratio - 1.0) * _raised_cosine_ramp(t, t_switch, 0.5 / f)
    return _raised_cosine_ramp(t, 0.0, ramp_in) * amp * np.sin(2.0 * math.pi * f * t)


def _pulse_shape(rng: np.random.Generator, t: np.ndarray) -> np.ndarray:
    d = np.zeros_like(t)
    level = 0.0
    start = rng.uniform(0.05, 0.4)
    t_end = t[-1]
    while start < t_end:
        dur = rng.uniform(0.1, 0.5)
        new = rng.uniform(-1.0, 1.0)
        # raised-cosine velocity: displacement tau - sin(2 pi tau) / (2 pi), tau = (t - start) / dur
        # clipped to [0, 1]: exactly 0 before the move and exactly 1 after it (sin(2 pi) / (2 pi)
        # rounds away against 1), so only the move's samples, one more on either side, need it
        lo = max(int(np.searchsorted(t, start)) - 1, 0)
        hi = int(np.searchsorted(t, start + dur)) + 1
        tau = np.clip((t[lo:hi] - start) / dur, 0.0, 1.0)
        d[lo:hi] += (new - level) * (tau - np.sin(2.0 * math.pi * tau) / (2.0 * math.pi))
        d[hi:] += new - level
        level = new
        start += dur + rng.uniform(0.2, 0.8)
    return d


#: ``scipy.signal.bilinear`` of the Kanai-Tajimi filter (:func:`kanai_tajimi_digital`) at the
#: envs' 1 kHz, tabulated so that a reset does not import scipy.signal (0.7 s of every process's
#: first reset); a test checks it equals scipy's design bit for bit
_KANAI_TAJIMI_TABULATED = {
    1000.0: (
        (0.009388461492920967, -0.018654827425852262, -0.0001220955599896726, 0.018654827425852262,
         -0.009266365932931293),
        (1.0, -3.9791975132390784, 5.937875096651007, -3.938157146061383, 0.9794795632519728),
    ),
}


def kanai_tajimi_digital(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Digital ground-acceleration filter ``(b, a)`` at sample time ``dt`` [s]: the Kanai-Tajimi
    filter with the Clough-Penzien high-pass (:data:`KANAI_TAJIMI`), bilinear transform."""
    key = 1.0 / dt
    if key in _KANAI_TAJIMI_TABULATED:
        b, a = _KANAI_TAJIMI_TABULATED[key]
        return np.array(b), np.array(a)
    from scipy import signal

    kt = KANAI_TAJIMI
    wg, zg, wf, zf = kt["omega_g"], kt["zeta_g"], kt["omega_f"], kt["zeta_f"]
    num = np.polymul([2.0 * zg * wg, wg * wg], [1.0, 0.0, 0.0])
    den = np.polymul([1.0, 2.0 * zg * wg, wg * wg], [1.0, 2.0 * zf * wf, wf * wf])
    bz, az = signal.bilinear(num, den, fs=key)
    return np.asarray(bz, dtype=np.float64), np.asarray(az, dtype=np.float64)


def _earthquake_shape(rng: np.random.Generator, t: np.ndarray, dt: float) -> np.ndarray:
    bz, az = kanai_tajimi_digital(dt)
    noise = rng.standard_normal(t.size)
    acc = lfilter_from_rest(bz, az, noise)
    t1 = rng.uniform(0.5, 1.0)
    t2 = t1 + rng.uniform(1.5, 3.0)
    c = rng.uniform(0.5, 1.5)
    tp = np.maximum(t, 0.0)
    env = np.where(tp < t1, (tp / t1) ** 2, np.where(tp <= t2, 1.0, np.exp(-c * (tp - t2))))
    acc = acc * env
    acc[t <= 0.0] = 0.0
    # displacement from rest (d = d' = 0 at t = 0), then baseline correction: remove the
    # least-squares trend c2 t^2 + c3 t^3 (keeps d(0) = d'(0) = 0)
    d = np.cumsum(np.cumsum(acc)) * dt * dt
    basis = np.stack([tp**2, tp**3], axis=1)
    coef, *_ = np.linalg.lstsq(basis, d, rcond=None)
    return d - basis @ coef


def generate_table_reference(
    kind: str,
    rng: np.random.Generator,
    n: int,
    dt: float,
    limits: ReferenceLimits,
) -> tuple[np.ndarray, np.ndarray]:
    """``n`` samples of acceleration reference [m/s^2] and its displacement [m] at spacing dt.

    Sample ``k`` is at ``t = k dt``. The displacement starts at 0 at rest, and ``|d|``, the
    backward-difference velocity and ``|a|`` stay within ``limits``.
    """
    if kind == "mixed":
        kind = TABLE_REFERENCE_KINDS[int(rng.integers(len(TABLE_REFERENCE_KINDS)))]
    if kind not in TABLE_REFERENCE_KINDS:
        raise ValueError(f"unknown reference kind {kind!r}; allowed: {TABLE_REFERENCE_KINDS + ('mixed',)}")
    if not (n > 0 and dt > 0):
        raise ValueError(f"reference needs n > 0 and dt > 0, got n = {n}, dt = {dt}")
    t = dt * np.arange(-1, n + 1)  # one sample before and after for the central difference
    duration = n * dt
    if kind == "sine":
        d, frac = _sine_shape(rng, t), (0.2, 1.0)
    elif kind == "transition":
        d, frac = _transition_shape(rng, t, duration), (0.5, 1.0)
    elif kind == "pulse":
        d, frac = _pulse_shape(rng, t), (0.3, 1.0)
    else:
        d, frac = _earthquake_shape(rng, t, dt), (0.3, 1.0)
    d[t <= 0.0] = 0.0
    a = (d[2:] - 2.0 * d[1:-1] + d[:-2]) / (dt * dt)
    v = np.diff(d) / dt
    peaks = (np.max(np.abs(d)), np.max(np.abs(v)), np.max(np.abs(a)))
    lims = (limits.displacement, limits.velocity, limits.acceleration)
    scale = min(lim / pk for lim, pk in zip(lims, peaks) if pk > 0.0) if max(peaks) > 0 else 0.0
    scale *= rng.uniform(*frac)
    return a * scale, d[1:-1] * scale


#: ranges of the friction-critical low-frequency task (``ShakingTableLowFrequency-v0``):
#: frequency [Hz] of the velocity sine and its peak [m/s]. 0.25-0.5 Hz puts 4-8 reversals into an
#: 8 s episode; 5-25 mm/s peaks are 0.35-1.8 Stribeck velocities of 003 Table 2 (v_s = 14 mm/s),
#: so every half period passes through stiction, the Stribeck dip and a reversal
LOW_FREQUENCY = {"frequency": (0.25, 0.5), "peak_velocity": (5e-3, 25e-3)}


def low_frequency_reference(rng: np.random.Generator, n: int, dt: float,
                            ranges: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``n`` samples of acceleration [m/s^2] and displacement [m] of a low-frequency, low-velocity
    motion with reversals: the velocity ``v = +-V sin(2 pi f t)`` from rest (displacement
    ``V / w (1 - cos w t)``, ``d = v = 0`` at ``t = 0``), f and V drawn from ``ranges``
    (:data:`LOW_FREQUENCY`), sign random. The acceleration is the displacement's second central
    difference on the env grid (as :func:`generate_table_reference`). Its peak ``V w`` (0.008-0.08
    m/s^2) is far below what friction's stick and breakaway give the table at each reversal
    (``F_s / M`` = 1.5 m/s^2 nominal): the friction decides the acceleration error."""
    r = {**LOW_FREQUENCY, **(ranges or {})}
    f = rng.uniform(*r["frequency"])
    v_peak = rng.uniform(*r["peak_velocity"]) * (1.0 if rng.uniform() < 0.5 else -1.0)
    w = 2.0 * math.pi * f
    t = dt * np.arange(-1, n + 1)
    d = v_peak / w * (1.0 - np.cos(w * np.maximum(t, 0.0)))
    a = (d[2:] - 2.0 * d[1:-1] + d[:-2]) / (dt * dt)
    return a, d[1:-1]
