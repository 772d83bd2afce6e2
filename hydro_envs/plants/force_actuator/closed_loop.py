"""Closed-loop and impulse experiments on the force actuator (seed 001, ``001_3253c61f41166c3e.txt``).

* :func:`proportional_loop`: proportional force control ``i = K_f (r - F_s) / F_max * i_rated``
  of a batch of copies in one parallel compiled call (Kf between normalised signals);
* :func:`closed_loop_frequency_response`, :func:`bandwidth`, :func:`limit_cycle_sweep`: the
  figures of sec. 4.7 (bandwidth about 100 Hz at Kf = 2.44, limit cycle from Kf = 3.66);
* :func:`sensor_ring_down`: the impulse test of sec. 4.1 (sensor natural frequency, damping);
* :func:`closed_loop_summary`: the numbers of the validation rows.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numba as nb
import numpy as np

from hydro_envs.plants.force_actuator import model as plant
from hydro_envs.plants.force_actuator.model import SEED_T
from hydro_envs.plants.force_actuator.model import force_actuator_guard as guard
from hydro_envs.plants.force_actuator.model import force_actuator_rhs as rhs
from hydro_envs.plants.force_actuator.params import ForceActuatorParams
from hydro_envs.plants.force_actuator.spec import SPEC
from hydro_envs.sim.rk4 import rk4_advance
from hydro_envs.sim.simulate import simulate
from hydro_envs.sim.stiffness import substeps_from_stiffness

__all__ = [
    "proportional_loop",
    "closed_loop_frequency_response",
    "bandwidth",
    "limit_cycle_sweep",
    "sensor_ring_down",
    "closed_loop_summary",
    "LIMIT_CYCLE_GAINS",
    "RESPONSE_FREQUENCIES",
    "AMPLITUDES",
]


@nb.njit(cache=True, error_model="numpy", parallel=True)
def _proportional_loop(Y, P, NSUB, REF, KF, dt, OUT, VMAX):
    n, n_steps = REF.shape
    for i in nb.prange(n):
        y = Y[i]
        work = np.zeros((5, y.shape[0]))
        u = np.zeros(1)
        fmax = P[i, plant.I_A1] * P[i, plant.I_PS]
        i_rated = P[i, plant.I_IR]
        i_max = P[i, plant.I_IMAX]
        h = dt / NSUB[i]
        n_delay = int(round(P[i, plant.I_TDEL] / dt))
        pending = np.zeros(n_delay + 1)  # commands computed but not yet applied
        for k in range(n_steps):
            fs = plant.measured_force(y, P[i])
            OUT[i, k] = fs
            c = KF[i] * (REF[i, k] - fs) / fmax * i_rated
            for j in range(n_delay, 0, -1):
                pending[j] = pending[j - 1]
            pending[0] = min(max(c, -i_max), i_max)
            u[0] = pending[n_delay]
            rk4_advance(rhs, guard, y, u, P[i], h, NSUB[i], work)
            v = abs(y[plant.VS] + y[plant.VP])
            if v > VMAX[i]:
                VMAX[i] = v


def proportional_loop(
    params: ForceActuatorParams | Sequence[ForceActuatorParams],
    reference: np.ndarray,
    kf: float | np.ndarray,
    dt: float = SEED_T,
) -> tuple[np.ndarray, np.ndarray]:
    """Proportional force control of a batch: returns measured forces ``(n, steps)`` [N] and each
    copy's peak relative piston speed [m/s].

    ``i = K_f (r - F_m) / F_max * i_rated`` on the measured force ``F_m``
    (:func:`~hydro_envs.plants.force_actuator.model.measured_force`), clipped to the driver
    range, applied ``control_delay`` after the sample it was computed from and held over each
    ``dt`` (the env's 5 kHz loop). 001 does not print the unit of ``K_f`` (its on-board analog card);
    we read it as the gain between normalised signals: force error as a fraction of the
    maximum thrust, current as a fraction of the rated current. Row ``j`` of ``reference``
    runs with ``kf[j]`` and ``params[j]`` (or one set for all) from the rest state.
    """
    reference = np.atleast_2d(np.asarray(reference, dtype=np.float64))
    n = reference.shape[0]
    plist = [params] * n if isinstance(params, ForceActuatorParams) else list(params)
    if len(plist) != n:
        raise ValueError(f"need {n} parameter sets, got {len(plist)}")
    P = np.stack([q.to_array() for q in plist])
    Y = np.stack([plant.rest_state(q) for q in plist])
    NSUB = np.array([substeps_from_stiffness(plant.stiffness_modes(q), dt)[0] for q in plist], dtype=np.int64)
    KF = np.broadcast_to(np.asarray(kf, dtype=np.float64), (n,)).copy()
    out = np.zeros(reference.shape)
    vmax = np.zeros(n)
    _proportional_loop(Y, P, NSUB, np.ascontiguousarray(reference), KF, dt, out, vmax)
    return out, vmax


def _first_harmonic(x: np.ndarray, f: float, dt: float, t_start: float) -> complex:
    t = dt * np.arange(x.size)
    m = t >= t_start
    tt = t[m]
    n_per = math.floor((tt[-1] - tt[0]) * f)
    keep = tt < tt[0] + n_per / f
    return complex(2.0 * np.mean(x[m][keep] * np.exp(-2j * math.pi * f * tt[keep])))


def closed_loop_frequency_response(
    params: ForceActuatorParams,
    kf: float,
    amplitudes: Sequence[float],
    frequencies: Sequence[float],
    bias: float = 0.0,
    duration: float = 0.5,
    settle: float = 0.2,
) -> np.ndarray:
    """First-harmonic closed-loop response ``F_s / r`` ``(len(amplitudes), len(frequencies))``
    to sines ``bias + A sin(2 pi f t)`` (one batch copy per amplitude and frequency)."""
    n = int(round(duration / SEED_T))
    t = SEED_T * np.arange(n)
    cases = [(a, f) for a in amplitudes for f in frequencies]
    ref = np.stack([bias + a * np.sin(2 * math.pi * f * t) for a, f in cases])
    out, _ = proportional_loop(params, ref, kf)
    h = [
        _first_harmonic(out[j] - bias, f, SEED_T, settle) / _first_harmonic(ref[j] - bias, f, SEED_T, settle)
        for j, (_, f) in enumerate(cases)
    ]
    return np.array(h).reshape(len(amplitudes), len(frequencies))


def bandwidth(frequencies: np.ndarray, response: np.ndarray, drop_db: float = 3.0) -> float:
    """First frequency where ``|H| / |H(f_0)|`` falls below ``-drop_db`` (linear interpolation
    in log frequency); nan if it never does."""
    mag = 20 * np.log10(np.abs(response) / abs(response[0]))
    below = np.flatnonzero(mag < -drop_db)
    if below.size == 0:
        return float("nan")
    j = below[0]
    if j == 0:
        return float(frequencies[0])
    f0, f1, m0, m1 = math.log(frequencies[j - 1]), math.log(frequencies[j]), mag[j - 1], mag[j]
    return float(math.exp(f0 + (f1 - f0) * (-drop_db - m0) / (m1 - m0)))


def limit_cycle_sweep(
    params: ForceActuatorParams,
    gains: Sequence[float],
    level: float = 100.0,
    duration: float = 0.4,
    window: float = 0.1,
    threshold: float = 20.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Peak-to-peak sensed-force oscillation [N] and its frequency [Hz] (from the upward zero
    crossings) over the last ``window`` seconds after a reference step 0 -> ``level`` N, one
    copy per gain.

    A copy is in a limit cycle when the peak-to-peak amplitude exceeds ``threshold``.
    """
    n = int(round(duration / SEED_T))
    ref = np.full((len(gains), n), float(level))
    out, _ = proportional_loop(params, ref, np.asarray(gains, dtype=float))
    w = int(round(window / SEED_T))
    seg = out[:, -w:]
    pp = seg.max(axis=1) - seg.min(axis=1)
    fr = np.array([_crossing_frequency(s - s.mean(), SEED_T) for s in seg])
    return pp, np.where(pp > threshold, fr, np.nan)


def _crossing_frequency(x: np.ndarray, dt: float) -> float:
    """Mean frequency [Hz] of a zero-mean oscillation from its upward zero crossings (linearly
    interpolated between samples); nan with fewer than two crossings."""
    up = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
    if up.size < 2:
        return float("nan")
    t = up + x[up] / (x[up] - x[up + 1])
    return float((up.size - 1) / ((t[-1] - t[0]) * dt))


def sensor_ring_down(params: ForceActuatorParams, duration: float = 0.03, dt: float = 2e-5) -> tuple[float, float]:
    """Impulse test of 001 sec. 4.1 on the model: (omega_n [rad/s], zeta) of the sensor ring-down.

    Valve at null, friction and hydraulic damping off (the paper knocked the actuator "gently"),
    initial sensor velocity 0.01 m/s; the damped frequency and the logarithmic decrement of
    the simulated ``F_s = k_s x_s`` give omega_n and zeta.
    """
    p = dataclasses.replace(params, damping_gain=0.0, coulomb_friction=0.0, stiction_retract=0.0,
                            stiction_extend=0.0)
    y0 = plant.rest_state(p)
    y0[plant.VS] = 0.01
    n = int(round(duration / dt))
    xs = simulate(SPEC, p, np.zeros((n, 1)), y0, dt, n_sub=4)[1:, plant.XS]
    # peaks of the ring-down (parabolic interpolation)
    idx = np.flatnonzero((xs[1:-1] > xs[:-2]) & (xs[1:-1] >= xs[2:])) + 1
    tp, ap = [], []
    for j in idx:
        a, b, c = xs[j - 1], xs[j], xs[j + 1]
        d = 0.5 * (a - c) / (a - 2 * b + c)
        tp.append((j + d + 1) * dt)
        ap.append(b - 0.25 * (a - c) * d)
    tp, ap = np.array(tp), np.array(ap)
    wd = 2 * math.pi / np.mean(np.diff(tp))
    delta = np.mean(np.log(ap[:-1] / ap[1:]))
    zeta = delta / math.sqrt(4 * math.pi**2 + delta**2)
    return wd / math.sqrt(1 - zeta**2), zeta


#: gain sweep of the limit-cycle row (001 sec. 4.7: limit cycle at K_f >= 3.66, ~95 Hz)
LIMIT_CYCLE_GAINS = np.round(np.arange(2.0, 12.01, 0.1), 2)
#: sine amplitudes of the closed-loop frequency-response rows [N] (001 figs. 11-13 use 50, 200
#: and 800 N square waves; fig. 9's amplitudes are not printed)
AMPLITUDES = (10.0, 50.0, 200.0, 400.0, 800.0)
#: frequencies of the closed-loop frequency-response rows [Hz]
RESPONSE_FREQUENCIES = np.geomspace(5.0, 500.0, 36)


def closed_loop_summary(params: ForceActuatorParams | None = None) -> dict[str, object]:
    """Numbers of the closed-loop validation rows (proportional force control, 001 sec. 4.7)."""
    p = params or ForceActuatorParams()
    amps = AMPLITUDES
    h = closed_loop_frequency_response(p, 2.44, amps, RESPONSE_FREQUENCIES)
    bw3 = {a: bandwidth(RESPONSE_FREQUENCIES, h[j], 3.0) for j, a in enumerate(amps)}
    bw6 = {a: bandwidth(RESPONSE_FREQUENCIES, h[j], 6.0) for j, a in enumerate(amps)}
    pp, fr = limit_cycle_sweep(p, LIMIT_CYCLE_GAINS)
    osc = np.flatnonzero(pp > 20.0)
    k_lc = float(LIMIT_CYCLE_GAINS[osc[0]]) if osc.size else float("nan")
    f_lc = float(fr[osc[0]]) if osc.size else float("nan")
    return {"bw3": bw3, "bw6": bw6, "kf_limit_cycle": k_lc, "f_limit_cycle": f_lc,
            "limit_cycle_pp": float(pp[osc[0]]) if osc.size else 0.0}
