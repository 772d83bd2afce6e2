"""Digital sensor filters (pure numba kernels on float64, SI units).

Source: ``003_54985feb8193da53.txt`` sec. 4: "velocity ... has been calculated by an
approximate differentiation of the measured system position. The noise in the calculated
velocity signal has been filtered through a butter-worth low-pass filter with order 8 and a
bandwidth of 40 [Hz]". The filter is designed once with :func:`scipy.signal.butter` as
second-order sections (SOS) and run sample by sample in the observation kernel by
:func:`sos_filter_step`, the same transposed direct form II recursion that
:func:`scipy.signal.sosfilt` uses (so the two agree to rounding).

The seed does not say whether the filter ran causally or forward-backward (offline, for the
identification); a control loop can only use the causal form, which we implement. Its group
delay is about 20 ms below 10 Hz (20.3 samples at 1 kHz, 22.5 at 20 Hz, 36.8 at 40 Hz, from
:func:`scipy.signal.group_delay`): a velocity estimate that lags a 15 Hz motion by about
110 degrees, which is why the paper used it for identification, not for feedback.
"""

from __future__ import annotations

import numba
import numpy as np

from hydro_envs.jit import njit_noalloc

__all__ = ["butterworth_lowpass_sos", "sos_filter_step", "lfilter_from_rest", "backward_difference"]

#: ``scipy.signal.butter(8, 40.0, fs=1000.0, output="sos")`` (the 003 sec. 4 filter at the table's
#: 1 kHz), tabulated so that making an env does not import scipy.signal (about 1 s); a test
#: checks it equals scipy's design bit for bit
_TABULATED = {
    (8, 40.0, 1000.0): (
        (3.398854055800834e-08, 6.797708111601668e-08, 3.398854055800834e-08, 1.0, -1.5573185938226184,
         0.6078315794876814),
        (1.0, 2.0, 1.0, 1.0, -1.6052382354614283, 0.6573055364610528),
        (1.0, 2.0, 1.0, 1.0, -1.7020087907357317, 0.7572149290232181),
        (1.0, 2.0, 1.0, 1.0, -1.8475297400233444, 0.907455977110453),
    ),
}


def butterworth_lowpass_sos(order: int, cutoff_hz: float, sample_rate_hz: float) -> np.ndarray:
    """Digital Butterworth low-pass as SOS ``(order/2, 6)`` (bilinear, pre-warped cut-off).

    ``|H| = 1/sqrt(2)`` (-3.01 dB) exactly at ``cutoff_hz``; ``order`` poles give an
    asymptotic roll-off of ``-20 order`` dB/decade (8th order: -48 dB/octave).
    Source: 003 sec. 4 (order 8, 40 Hz).
    """
    if not (0.0 < cutoff_hz < 0.5 * sample_rate_hz):
        raise ValueError(
            f"cutoff {cutoff_hz} Hz must lie in (0, fs/2 = {0.5 * sample_rate_hz}) Hz"
        )
    if order < 1:
        raise ValueError(f"filter order must be >= 1, got {order}")
    key = (int(order), float(cutoff_hz), float(sample_rate_hz))
    if key in _TABULATED:
        return np.array(_TABULATED[key], dtype=np.float64)
    from scipy import signal

    return np.ascontiguousarray(
        signal.butter(int(order), float(cutoff_hz), btype="low", fs=float(sample_rate_hz), output="sos"),
        dtype=np.float64,
    )


@njit_noalloc
def sos_filter_step(sos, zi, x):
    """Filter one sample ``x`` through the cascade ``sos`` with state ``zi`` (updated in place).

    ``sos`` rows are ``[b0, b1, b2, a0, a1, a2]`` with ``a0 = 1`` (scipy's normalisation),
    ``zi`` is ``(n_sections, 2)``. Transposed direct form II per section::

        y      = b0 x + z0
        z0_new = b1 x - a1 y + z1
        z1_new = b2 x - a2 y

    Identical to :func:`scipy.signal.sosfilt` (up to floating-point rounding).
    Units: any; returns the filtered sample.
    """
    for s in range(sos.shape[0]):
        y = sos[s, 0] * x + zi[s, 0]
        zi[s, 0] = sos[s, 1] * x - sos[s, 4] * y + zi[s, 1]
        zi[s, 1] = sos[s, 2] * x - sos[s, 5] * y
        x = y
    return x


def lfilter_from_rest(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``scipy.signal.lfilter(b, a, x)`` from rest, for 1-D ``b`` and ``a`` of equal length.

    Transposed direct form II after dividing ``b`` and ``a`` by ``a[0]``::

        y_k      = z_0 + b_0 x_k
        z_n      = z_{n+1} + b_{n+1} x_k - a_{n+1} y_k      (n < N - 2)
        z_{N-2}  = b_{N-1} x_k - a_{N-1} y_k

    in scipy's order of operations, so the output equals scipy's bit for bit (test), without
    importing scipy.signal (0.7 s). Units: any; returns a float array like ``x``.
    """
    b = np.asarray(b, dtype=np.float64)
    a = np.asarray(a, dtype=np.float64)
    x = np.ascontiguousarray(x, dtype=np.float64)
    if b.ndim != 1 or b.shape != a.shape or b.size < 1 or a[0] == 0.0 or x.ndim != 1:
        raise ValueError(f"lfilter_from_rest needs 1-D b and a of equal length >= 1 with a[0] != 0 and a "
                         f"1-D x, got shapes {b.shape}, {a.shape}, {x.shape}")
    y = np.empty_like(x)
    _lfilter_loop(b / a[0], a / a[0], x, np.zeros(max(b.size - 1, 1)), y)
    return y


@numba.njit(cache=True, error_model="numpy")
def _lfilter_loop(b, a, x, z, y):
    n_b = b.shape[0]
    for k in range(x.shape[0]):
        xk = x[k]
        if n_b > 1:
            yk = z[0] + b[0] * xk
            for n in range(n_b - 2):
                z[n] = z[n + 1] + xk * b[n + 1] - yk * a[n + 1]
            z[n_b - 2] = xk * b[n_b - 1] - yk * a[n_b - 1]
        else:
            yk = xk * b[0]
        y[k] = yk


@numba.njit(cache=True, error_model="numpy")
def backward_difference(x, x_prev, dt):
    """Approximate derivative ``(x_k - x_{k-1}) / dt`` (003 sec. 4: differentiated position).

    Frequency response ``(1 - exp(-j w dt)) / dt``: gain ``2 sin(w dt / 2) / dt`` (0.26 %
    below ``w`` at 40 Hz and 1 kHz sampling) and half a sample of delay.
    Units: x [m], dt [s] -> [m/s].
    """
    return (x - x_prev) / dt
