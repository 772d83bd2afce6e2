"""The static friction level read off a measured record.

Used by the plants' diagnosis settings (``hydro_envs/plants/*/diagnosis.py``) to place the start
points of a Stribeck refit: the plant computes the friction force sample by sample from its own
equation of motion, this module reduces it to one level.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SMOOTHING_WINDOW", "SPEED_BINS", "MIN_BIN_SAMPLES", "smoothing_samples", "smoothed", "binned_friction_peak"]

#: Savitzky-Golay window [s] of the velocity, acceleration and pressures the friction is computed from
SMOOTHING_WINDOW = 0.015
#: edges [m/s] of the 40 log-spaced speed bins, 10 um/s - 0.1 m/s
SPEED_BINS = np.geomspace(1e-5, 0.1, 41)
#: bins with fewer samples than this are left out
MIN_BIN_SAMPLES = 20


def smoothing_samples(dt: float) -> int:
    """Samples in :data:`SMOOTHING_WINDOW` at sample time ``dt`` [s]: odd, at least 7."""
    return max(7, int(round(SMOOTHING_WINDOW / dt)) | 1)


def smoothed(x: np.ndarray, dt: float, deriv: int = 0) -> np.ndarray:
    """``x`` (sampled every ``dt`` s) or its ``deriv``-th time derivative from a cubic
    Savitzky-Golay fit over :func:`smoothing_samples`."""
    from scipy.signal import savgol_filter

    return savgol_filter(np.asarray(x, float), smoothing_samples(dt), 3, deriv=deriv, delta=dt)


def binned_friction_peak(speed: np.ndarray, friction: np.ndarray) -> float:
    """Largest median [N] of ``friction`` over the :data:`SPEED_BINS` of ``|speed|`` that hold
    at least :data:`MIN_BIN_SAMPLES` samples; NaN when none does. ``friction`` is the friction
    force signed with the velocity (positive where it opposes the motion). The medians smooth a
    narrow Stribeck peak and read it low; callers scan above the value."""
    k = np.digitize(np.abs(np.asarray(speed, float)), SPEED_BINS) - 1
    fr = np.asarray(friction, float)
    medians = [float(np.median(fr[k == i])) for i in range(SPEED_BINS.size - 1)
               if np.count_nonzero(k == i) >= MIN_BIN_SAMPLES]
    return max(medians) if medians else float("nan")
