"""Excitation signals for experiments and recorded runs: M-sequence / PRBS, logarithmic sine
sweep and a random-phase multisine. Pure functions of numpy arrays (no plant, no state).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from scipy import signal

__all__ = ["m_sequence", "prbs", "log_sweep_frequency", "log_sine_sweep", "multisine"]


def m_sequence(
    n_bits: int,
    *,
    amplitude: float = 1.0,
    offset: float = 0.0,
    samples_per_bit: int = 1,
    periods: int = 1,
    state: Sequence[int] | None = None,
) -> np.ndarray:
    """Maximum-length binary sequence (``scipy.signal.max_len_seq``) mapped to
    ``offset +- amplitude``; ``2**n_bits - 1`` bits per period, each held for
    ``samples_per_bit`` samples, repeated ``periods`` times. Its periodic autocorrelation is
    ``N`` at lag 0 and ``-1`` elsewhere (flat spectrum up to about ``0.44 / (bit time)``)."""
    if not (2 <= int(n_bits) <= 32):
        raise ValueError(f"n_bits must be in [2, 32], got {n_bits}")
    if samples_per_bit < 1 or periods < 1:
        raise ValueError("samples_per_bit and periods must be >= 1")
    st = None if state is None else np.asarray(state, dtype=np.int8)
    bits = signal.max_len_seq(int(n_bits), state=st)[0]
    seq = offset + amplitude * (2.0 * bits.astype(float) - 1.0)
    return np.tile(np.repeat(seq, int(samples_per_bit)), int(periods))


def prbs(
    duration: float,
    dt: float,
    *,
    clock_period: float | None = None,
    amplitude: float = 1.0,
    offset: float = 0.0,
    n_bits: int | None = None,
    seed: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """PRBS excitation ``(t, u)`` of ``duration`` s at sample time ``dt``.

    An M-sequence whose bits last ``clock_period`` (default ``dt``; a whole number of samples).
    ``n_bits`` defaults to the smallest register whose period covers ``duration`` (so the
    record holds at most one period, no repetition). ``seed`` draws a random nonzero initial
    register state (a shifted sequence); None uses scipy's all-ones state.
    """
    if not (duration > 0 and dt > 0):
        raise ValueError("duration and dt must be > 0")
    spb = 1 if clock_period is None else int(round(clock_period / dt))
    if spb < 1:
        raise ValueError(f"clock_period must be >= dt, got {clock_period}")
    n = int(round(duration / dt))
    n_bit_samples = math.ceil(n / spb)
    if n_bits is None:
        n_bits = max(2, math.ceil(math.log2(n_bit_samples + 1)))
    state: list[int] | None = None
    if seed is not None:
        rng = np.random.default_rng(seed)
        bits = rng.integers(0, 2, int(n_bits))
        if not bits.any():
            bits[0] = 1
        state = bits.tolist()
    periods = math.ceil(n / (spb * (2 ** int(n_bits) - 1)))
    u = m_sequence(int(n_bits), amplitude=amplitude, offset=offset, samples_per_bit=spb,
                   periods=periods, state=state)[:n]
    return np.arange(n) * dt, u


def log_sweep_frequency(t: Any, f0: float, f1: float, duration: float) -> np.ndarray:
    """Instantaneous frequency [Hz] of :func:`log_sine_sweep`: ``f0 (f1/f0)^(t/T)``."""
    return f0 * (f1 / f0) ** (np.asarray(t, dtype=float) / duration)


def log_sine_sweep(
    f0: float,
    f1: float,
    duration: float,
    dt: float,
    *,
    amplitude: float = 1.0,
    offset: float = 0.0,
    fade: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Exponential (logarithmic) sine sweep ``(t, u)`` from ``f0`` to ``f1`` Hz in ``duration`` s.

    ``u = offset + amplitude sin(2 pi f0 T / ln(f1/f0) (exp(t ln(f1/f0) / T) - 1))`` (Farina's
    sweep: equal time per octave, phase 0 at t = 0). ``fade`` [s] applies half-cosine fade-in
    and fade-out ramps to the sine part. ``f1`` must stay below the Nyquist frequency.
    """
    if not (0 < f0 < f1):
        raise ValueError(f"need 0 < f0 < f1, got f0={f0}, f1={f1}")
    if not (duration > 0 and dt > 0):
        raise ValueError("duration and dt must be > 0")
    if f1 >= 0.5 / dt:
        raise ValueError(f"f1 = {f1} Hz must be below the Nyquist frequency {0.5 / dt} Hz")
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    r = math.log(f1 / f0)
    s = np.sin(2 * math.pi * f0 * duration / r * np.expm1(t * r / duration))
    if fade > 0:
        w = np.ones(n)
        m = min(int(round(fade / dt)), n // 2)
        if m > 0:
            ramp = 0.5 * (1 - np.cos(np.pi * np.arange(m) / m))
            w[:m] = ramp
            w[n - m:] = ramp[::-1]
        s = s * w
    return t, offset + amplitude * s


def multisine(
    n: int,
    dt: float,
    f0: float,
    f1: float,
    *,
    n_tones: int = 12,
    amplitude: float = 1.0,
    offset: float = 0.0,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """``n`` samples of a multisine: ``n_tones`` log-spaced tones in ``[f0, f1]`` Hz with
    random phases (Schroeder-like crest factor on average), scaled so its peak is
    ``amplitude`` about ``offset``. ``f1`` must stay below the Nyquist frequency."""
    if not (0 < f0 <= f1 < 0.5 / dt):
        raise ValueError(f"need 0 < f0 <= f1 < Nyquist {0.5 / dt} Hz, got f0={f0}, f1={f1}")
    if n < 1 or n_tones < 1:
        raise ValueError(f"n and n_tones must be >= 1, got {n}, {n_tones}")
    rng = rng if rng is not None else np.random.default_rng(0)
    t = np.arange(n) * dt
    freqs = np.geomspace(f0, f1, n_tones)
    phases = rng.uniform(0.0, 2 * math.pi, n_tones)
    s = np.sin(2 * math.pi * freqs[None, :] * t[:, None] + phases[None, :]).sum(axis=1)
    peak = np.max(np.abs(s))
    return offset + amplitude * s / (peak if peak > 0 else 1.0)
