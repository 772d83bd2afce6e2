r"""Frequency-response identification: H1 spectra, first-harmonic ratios, mass-spring-damper fits.

Three tools:

1. :func:`h1_estimate` -- the H1 frequency-response estimate of a broadband test
   (M-sequence, PRBS, noise, sweep): ``H1(f) = S_uy(f) / S_uu(f)`` from Welch-averaged
   cross and auto spectra (``scipy.signal.csd``, ``scipy.signal.welch``), with the ordinary
   coherence ``gamma^2 = |S_uy|^2 / (S_uu S_yy)`` and the random error of ``|H1|``
   (Bendat & Piersol, Random Data, 4th ed., eq. (9.90):
   ``sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))``). H1 is unbiased by noise on the output,
   biased low by noise on the input.

2. :func:`first_harmonic` / :func:`first_harmonic_ratio` -- the first-harmonic ratio of
   ``000_d7d5fd9bd6b165a2.txt`` eq (18), ``A(f) = |A_pI(f)| / |A_pP(f)|``, plus the phase
   that method 1 (sec. 3: servovalve sine steps 10-150 Hz, about 4 s each, 10 kHz sampling,
   "amplitude and phase shift of the ratio between the pressures p2 and p1") also reports.
   Each signal is projected onto ``[cos(2 pi f t), sin(2 pi f t), 1]`` by least squares over
   the largest whole number of periods in the record (for a whole number of periods and an
   integer number of samples per period this is the DFT bin; least squares stays exact for
   a pure tone when ``fs / f`` is not an integer). :func:`stepped_sine_frf` applies it stage
   by stage (method 1); :func:`estimate_fundamental` finds the ripple frequency when it is
   not known from the pump speed (method 2, sec. 4: gear-pump ripple 20-500 Hz).

3. :func:`fit_mass_spring_damper` (and :func:`fit_transfer_function` for any rational
   model ``num(s; p) / den(s; p)``, with the same three methods) -- fit ``m, c, k`` of ``G(s) = s^p / (m s^2 + c s + k)``
   (force to position ``p = 0``, velocity 1, acceleration 2) to frequency-response data
   ``(frequencies, complex response)``, three ways:

   * ``"continuous"``: the complex ``G(j omega)``. **Biased on sampled data**: the measured
     response of a sampled loop (input held by a DAC, output sampled) is the zero-order-hold
     equivalent ``G_zoh(e^{j omega T})``, which lags ``G(j omega)`` by about half a sample
     (``omega T / 2``) near resonance; the continuous fit explains that lag with the wrong
     damping. docs/references.md (numerics notes): 1186 vs 1500 N s/m true.
   * ``"zoh"``: the sampled model ``G_zoh(e^{j omega T}) = C (e^{j omega T} I - A_d)^-1 B_d + D_d``
     with ``(A_d, B_d, C, D_d)`` the exact ZOH discretisation (``scipy.signal.cont2discrete``)
     at the sample rate ``fs``. Unbiased when the data come from a ZOH-driven loop (docs/references.md:
     1521).
   * ``"magnitude"``: ``log |G(j omega)|`` against ``log |H|`` only. The half-sample lag is a
     phase effect; the ZOH changes the magnitude only at second order in ``omega T``, so the
     magnitude fit is nearly unbiased below about fs/10 (docs/references.md: 1531) -- the choice when
     the sampling/hold mechanism is unknown (e.g. two sampled pressures as in 000).

   Residuals: relative complex error ``(G - H) / |H|`` (continuous, zoh) or log-magnitude
   error (magnitude), so every decade weighs the same; optional extra weights (for example
   ``gamma^2 / (1 - gamma^2)``, the inverse variance of H1, via ``weights="coherence"``).
   Parameters are fitted as logarithms (always positive); the start comes from the linear
   least-squares fit of ``1/H`` (Levy's method). Standard errors from the Jacobian at the
   optimum, ``s^2 (J'J)^-1`` -- approximate, because FRF points of one record are not
   independent.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import optimize, signal

from hydro_envs.jsonutil import to_jsonable as _jsonable

__all__ = [
    "FrfError",
    "FrfEstimate",
    "HarmonicAmplitude",
    "HarmonicRatio",
    "MsdFit",
    "h1_estimate",
    "first_harmonic",
    "first_harmonic_ratio",
    "stepped_sine_frf",
    "estimate_fundamental",
    "msd_response",
    "zoh_frequency_response",
    "fit_mass_spring_damper",
    "identify_msd_from_time_series",
    "TransferFunctionFit",
    "fit_transfer_function",
]




class FrfError(ValueError):
    """Bad data or options for a frequency-response estimate or fit."""

    exit_code = 1  # the command line's code for data that cannot give a result (hydro_envs.cli_errors)


def _series(name: str, x: Any) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1:
        raise FrfError(f"{name} must be a 1-D time series, got shape {a.shape}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise FrfError(f"{name} has {bad.size} NaN/inf value(s), first at sample {int(bad[0])}")
    return a


def _rate(fs: float) -> float:
    if not (isinstance(fs, (int, float, np.floating)) and math.isfinite(fs) and fs > 0):
        raise FrfError(f"sample rate fs = {fs!r} must be a finite frequency > 0 Hz")
    return float(fs)


# ============================================================================ H1 estimate
@dataclasses.dataclass
class FrfEstimate:
    """Frequency response ``response`` (complex, output/input) at ``frequencies`` [Hz]."""

    frequencies: np.ndarray
    response: np.ndarray
    coherence: np.ndarray
    fs: float | None = None
    n_averages: float = math.nan
    magnitude_rel_error: np.ndarray | None = None  # random error of |H| (relative)
    method: str = "H1"

    @property
    def magnitude(self) -> np.ndarray:
        return np.abs(self.response)

    @property
    def phase(self) -> np.ndarray:
        """Unwrapped phase [rad]."""
        return np.unwrap(np.angle(self.response))

    def select(
        self, f_min: float = 0.0, f_max: float = math.inf, min_coherence: float = 0.0
    ) -> "FrfEstimate":
        """The points with ``f_min <= f <= f_max`` and coherence >= ``min_coherence``."""
        keep = (self.frequencies >= f_min) & (self.frequencies <= f_max)
        keep &= ~(self.coherence < min_coherence)  # NaN coherence (stepped sine) passes
        return dataclasses.replace(
            self,
            frequencies=self.frequencies[keep],
            response=self.response[keep],
            coherence=self.coherence[keep],
            magnitude_rel_error=None if self.magnitude_rel_error is None else self.magnitude_rel_error[keep],
        )

    def to_json_dict(self) -> dict[str, Any]:
        return _jsonable({
            "method": self.method,
            "fs": self.fs,
            "n_averages": None if not math.isfinite(self.n_averages) else self.n_averages,
            "frequencies_hz": [float(f) for f in self.frequencies],
            "magnitude": [float(v) for v in self.magnitude],
            "phase_rad": [float(v) for v in self.phase],
            "coherence": list(self.coherence),
        })


def h1_estimate(
    u: Any,
    y: Any,
    fs: float,
    *,
    nperseg: int | None = None,
    noverlap: int | None = None,
    window: str = "hann",
    detrend: str | bool = "constant",
) -> FrfEstimate:
    """H1 estimate ``S_uy / S_uu`` with coherence from input ``u`` and output ``y``.

    Welch averaging with ``nperseg`` samples per segment (default: ``len / 8`` rounded down
    to a power of two, at least 64) and 50 % overlap. The zero-frequency bin is dropped.
    """
    u = _series("u", u)
    y = _series("y", y)
    fs = _rate(fs)
    if u.size != y.size:
        raise FrfError(f"u and y must have the same length, got {u.size} and {y.size}")
    if nperseg is None:
        nperseg = max(64, 2 ** int(math.floor(math.log2(max(u.size // 8, 2)))))
    nperseg = int(nperseg)
    if nperseg > u.size:
        raise FrfError(f"nperseg = {nperseg} exceeds the record length {u.size}")
    if np.ptp(u) == 0.0:
        raise FrfError("input u is constant: nothing excites the system")
    if noverlap is None:
        noverlap = nperseg // 2
    kw = dict(fs=fs, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)
    f, Suy = signal.csd(u, y, **kw)  # conj(U) Y
    _, Suu = signal.welch(u, **kw)
    _, Syy = signal.welch(y, **kw)
    keep = (f > 0) & (Suu > 0)
    f, Suy, Suu, Syy = f[keep], Suy[keep], Suu[keep], Syy[keep]
    H = Suy / Suu
    with np.errstate(invalid="ignore", divide="ignore"):
        coh = np.abs(Suy) ** 2 / (Suu * Syy)
    coh = np.clip(np.nan_to_num(coh, nan=0.0), 0.0, 1.0)
    step = nperseg - noverlap
    n_avg = 1 + (u.size - nperseg) // step
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.sqrt(1.0 - coh) / (np.sqrt(coh) * math.sqrt(2.0 * n_avg))
    return FrfEstimate(
        frequencies=f, response=H, coherence=coh, fs=fs, n_averages=float(n_avg),
        magnitude_rel_error=rel, method="H1",
    )


# ====================================================================== first harmonic
@dataclasses.dataclass
class HarmonicAmplitude:
    """First harmonic ``x(t) ~ offset + amplitude cos(2 pi f t + phase)``."""

    frequency: float
    amplitude: float
    phase: float  # rad, relative to t = 0 of the record
    offset: float
    n_periods: int
    n_samples: int
    residual_rms: float  # what the tone and offset do not explain (noise, other harmonics)

    @property
    def phasor(self) -> complex:
        return complex(self.amplitude * np.exp(1j * self.phase))


@dataclasses.dataclass
class HarmonicRatio:
    """First-harmonic ratio ``x_out / x_in`` at one frequency (000 eq (18) plus phase)."""

    frequency: float
    ratio: complex
    amplitude_ratio: float  # 000 eq (18): |A_out| / |A_in|
    phase: float  # rad, phase of x_out minus phase of x_in, wrapped to (-pi, pi]
    amplitude_in: float
    amplitude_out: float
    n_periods: int

    @property
    def phase_deg(self) -> float:
        return math.degrees(self.phase)

    @property
    def gain_db(self) -> float:
        return 20.0 * math.log10(self.amplitude_ratio) if self.amplitude_ratio > 0 else -math.inf

    def to_json_dict(self) -> dict[str, Any]:
        return _jsonable({
            "method": "first-harmonic ratio (000 eq (18))",
            "frequency_hz": self.frequency,
            "amplitude_ratio": self.amplitude_ratio,
            "gain_db": self.gain_db,
            "phase_rad": self.phase,
            "phase_deg": self.phase_deg,
            "amplitude_in": self.amplitude_in,
            "amplitude_out": self.amplitude_out,
            "n_periods": self.n_periods,
        })


def _whole_periods(n: int, fs: float, frequency: float, n_periods: int | None) -> tuple[int, int]:
    samples_per_period = fs / frequency
    available = int(math.floor(n / samples_per_period + 1e-9))
    if n_periods is None:
        n_periods = available
    n_periods = int(n_periods)
    if n_periods < 1 or n_periods > available:
        raise FrfError(
            f"need {n_periods if n_periods >= 1 else 1} whole period(s) of {frequency:g} Hz "
            f"({samples_per_period:.4g} samples each) but the record has {n} samples "
            f"({available} whole periods)"
        )
    n_use = int(round(n_periods * samples_per_period))
    return n_periods, min(n_use, n)


def first_harmonic(
    x: Any, fs: float, frequency: float, *, n_periods: int | None = None, start: int = 0
) -> HarmonicAmplitude:
    """Amplitude and phase of the component of ``x`` at ``frequency`` [Hz].

    Uses the largest whole number of periods from sample ``start`` (or ``n_periods``).
    """
    x = _series("x", x)
    fs = _rate(fs)
    if not (0 < frequency < 0.5 * fs):
        raise FrfError(f"frequency {frequency!r} Hz must lie in (0, fs/2 = {0.5 * fs}) Hz")
    if not (0 <= start < x.size):
        raise FrfError(f"start = {start} outside the record of {x.size} samples")
    seg = x[start:]
    n_periods, n_use = _whole_periods(seg.size, fs, frequency, n_periods)
    seg = seg[:n_use]
    t = (start + np.arange(n_use)) / fs
    w = 2.0 * math.pi * frequency
    X = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones(n_use)])
    coef, *_ = np.linalg.lstsq(X, seg, rcond=None)
    c, s, off = coef
    # c cos + s sin = A cos(wt + phi) with A cos(phi) = c, -A sin(phi) = s
    amp = math.hypot(c, s)
    phase = math.atan2(-s, c)
    resid = seg - X @ coef
    return HarmonicAmplitude(
        frequency=float(frequency), amplitude=amp, phase=phase, offset=float(off),
        n_periods=n_periods, n_samples=n_use, residual_rms=float(np.sqrt(np.mean(resid**2))),
    )


def first_harmonic_ratio(
    x_in: Any, x_out: Any, fs: float, frequency: float, *, n_periods: int | None = None, start: int = 0
) -> HarmonicRatio:
    """First-harmonic ratio ``x_out / x_in`` at ``frequency`` (000 eq (18), with phase).

    Both signals are projected over the same whole number of periods.
    """
    x_in = _series("x_in", x_in)
    x_out = _series("x_out", x_out)
    if x_in.size != x_out.size:
        raise FrfError(f"x_in and x_out must have the same length, got {x_in.size} and {x_out.size}")
    h_in = first_harmonic(x_in, fs, frequency, n_periods=n_periods, start=start)
    h_out = first_harmonic(x_out, fs, frequency, n_periods=h_in.n_periods, start=start)
    if h_in.amplitude <= 0.0:
        raise FrfError(f"x_in has no component at {frequency:g} Hz: the ratio is undefined")
    ratio = h_out.phasor / h_in.phasor
    return HarmonicRatio(
        frequency=float(frequency),
        ratio=complex(ratio),
        amplitude_ratio=h_out.amplitude / h_in.amplitude,
        phase=float(np.angle(ratio)),
        amplitude_in=h_in.amplitude,
        amplitude_out=h_out.amplitude,
        n_periods=h_in.n_periods,
    )


def stepped_sine_frf(
    x_in: Any,
    x_out: Any,
    fs: float,
    stages: Sequence[tuple[float, float, float]],
    *,
    settle: float = 0.0,
) -> FrfEstimate:
    """Frequency response from a stepped-sine test (000 method 1).

    ``stages``: ``(t_start, t_end, frequency)`` per stage, times in s from the first
    sample; the first ``settle`` seconds of each stage are skipped (transient). Returns an
    :class:`FrfEstimate` with ``coherence`` NaN (not defined for one tone).
    """
    x_in = _series("x_in", x_in)
    x_out = _series("x_out", x_out)
    fs = _rate(fs)
    if x_in.size != x_out.size:
        raise FrfError(f"x_in and x_out must have the same length, got {x_in.size} and {x_out.size}")
    if len(stages) == 0:
        raise FrfError("no stages given")
    freqs, H = [], []
    for i, (t0, t1, f0) in enumerate(stages):
        i0 = int(round((t0 + settle) * fs))
        i1 = int(round(t1 * fs))
        if not (0 <= i0 < i1 <= x_in.size):
            raise FrfError(
                f"stage {i} ({t0:g}..{t1:g} s, settle {settle:g} s) lies outside the record "
                f"of {x_in.size / fs:g} s or is empty"
            )
        r = first_harmonic_ratio(x_in[i0:i1], x_out[i0:i1], fs, f0)
        freqs.append(f0)
        H.append(r.ratio)
    freqs = np.asarray(freqs, dtype=np.float64)
    return FrfEstimate(
        frequencies=freqs, response=np.asarray(H, dtype=complex), coherence=np.full(freqs.size, np.nan),
        fs=fs, method="stepped sine, first harmonic",
    )


def estimate_fundamental(x: Any, fs: float, f_min: float, f_max: float) -> float:
    """Frequency [Hz] of the strongest tone of ``x`` in ``[f_min, f_max]`` (000 method 2).

    Peak of the Hann-windowed periodogram, refined by maximising the least-squares tone
    amplitude over the whole record (resolution far below one FFT bin).
    """
    x = _series("x", x)
    fs = _rate(fs)
    if not (0 < f_min < f_max <= 0.5 * fs):
        raise FrfError(f"need 0 < f_min < f_max <= fs/2, got {f_min}, {f_max} (fs = {fs})")
    xd = x - x.mean()
    n = xd.size
    spec = np.abs(np.fft.rfft(xd * np.hanning(n)))
    f = np.fft.rfftfreq(n, 1.0 / fs)
    band = np.flatnonzero((f >= f_min) & (f <= f_max))
    if band.size == 0:
        raise FrfError(f"record of {n} samples has no FFT bin in [{f_min}, {f_max}] Hz")
    k = int(band[np.argmax(spec[band])])
    df = fs / n
    t = np.arange(n) / fs

    def neg_amp(fr: float) -> float:
        X = np.column_stack([np.cos(2 * np.pi * fr * t), np.sin(2 * np.pi * fr * t)])
        coef, *_ = np.linalg.lstsq(X, xd, rcond=None)
        return -float(np.hypot(*coef))

    res = optimize.minimize_scalar(
        neg_amp, bounds=(max(f[k] - df, f_min), min(f[k] + df, f_max)), method="bounded",
        options={"xatol": 1e-6 * df},
    )
    return float(res.x)


# ================================================================ mass-spring-damper
def zoh_frequency_response(num: Any, den: Any, frequencies: Any, fs: float) -> np.ndarray:
    """Frequency response of the ZOH discretisation of ``num(s)/den(s)`` at ``frequencies``.

    The sampled system seen by a loop that holds its input for ``1/fs`` and samples its
    output: ``H(e^{j 2 pi f / fs})`` of ``cont2discrete(..., method="zoh")``.
    """
    fs = _rate(fs)
    A, B, C, D = signal.tf2ss(num, den)
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, D), 1.0 / fs, method="zoh")
    return _ss_response(Ad, Bd, Cd, Dd, np.exp(2j * np.pi * np.asarray(frequencies, float) / fs))


def _ss_response(A, B, C, D, z: np.ndarray) -> np.ndarray:
    n = A.shape[0]
    eye = np.eye(n)
    out = np.empty(z.size, dtype=complex)
    for i, zi in enumerate(z):
        out[i] = (C @ np.linalg.solve(zi * eye - A, B))[0, 0] + D[0, 0]
    return out


def msd_response(
    frequencies: Any, m: float, c: float, k: float, *, model: str = "continuous", fs: float | None = None,
    derivative: int = 0,
) -> np.ndarray:
    """``G = s^p / (m s^2 + c s + k)`` at ``frequencies`` [Hz]: continuous or its ZOH equivalent.

    ``derivative`` p = 0 (force to position [m/N]), 1 (velocity), 2 (acceleration).
    """
    w = 2.0 * np.pi * np.asarray(frequencies, dtype=np.float64)
    if derivative not in (0, 1, 2):
        raise FrfError(f"derivative = {derivative!r}; allowed 0 (position), 1 (velocity), 2 (acceleration)")
    if model == "continuous":
        s = 1j * w
        return s**derivative / (m * s * s + c * s + k)
    if model == "zoh":
        if fs is None:
            raise FrfError("model='zoh' needs the sample rate fs [Hz]")
        fs = _rate(fs)
        # state (x, v); x' = v, v' = (f - c v - k x) / m
        A = np.array([[0.0, 1.0], [-k / m, -c / m]])
        B = np.array([[0.0], [1.0 / m]])
        if derivative == 0:
            C, D = np.array([[1.0, 0.0]]), np.zeros((1, 1))
        elif derivative == 1:
            C, D = np.array([[0.0, 1.0]]), np.zeros((1, 1))
        else:
            C, D = np.array([[-k / m, -c / m]]), np.array([[1.0 / m]])
        Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, D), 1.0 / fs, method="zoh")
        return _zoh2(Ad, Bd, Cd, Dd, np.exp(1j * w / fs))
    raise FrfError(f"model = {model!r}; allowed 'continuous', 'zoh'")


def _zoh2(Ad, Bd, Cd, Dd, z: np.ndarray) -> np.ndarray:
    """Vectorised ``C (zI - A)^-1 B + D`` for a 2x2 ``A``."""
    a, b, c, d = Ad[0, 0], Ad[0, 1], Ad[1, 0], Ad[1, 1]
    det = (z - a) * (z - d) - b * c
    # inverse of [[z-a, -b], [-c, z-d]] = [[z-d, b], [c, z-a]] / det
    x0 = ((z - d) * Bd[0, 0] + b * Bd[1, 0]) / det
    x1 = (c * Bd[0, 0] + (z - a) * Bd[1, 0]) / det
    return Cd[0, 0] * x0 + Cd[0, 1] * x1 + Dd[0, 0]


@dataclasses.dataclass
class MsdFit:
    """Mass-spring-damper parameters fitted to frequency-response data."""

    mass: float
    damping: float  # c [N s/m]
    stiffness: float  # k [N/m]
    std_errors: dict[str, float]
    method: str  # continuous | zoh | magnitude
    fs: float | None
    derivative: int
    n_points: int
    fit_percent: float  # complex: 100 (1 - ||H - G|| / ||H - mean H||) with the fitted model
    rms_log_magnitude_error: float  # rms of ln|G| - ln|H| (dimensionless)
    f_range: tuple[float, float]

    @property
    def natural_frequency(self) -> float:
        """Undamped natural frequency [Hz] ``sqrt(k/m) / 2 pi`` (000 eq (19))."""
        return math.sqrt(self.stiffness / self.mass) / (2.0 * math.pi)

    @property
    def damping_ratio(self) -> float:
        return self.damping / (2.0 * math.sqrt(self.stiffness * self.mass))

    def response(self, frequencies: Any) -> np.ndarray:
        """The fitted model's response (the sampled one for ``method='zoh'``)."""
        model = "zoh" if self.method == "zoh" else "continuous"
        return msd_response(frequencies, self.mass, self.damping, self.stiffness, model=model,
                            fs=self.fs, derivative=self.derivative)

    def to_json_dict(self) -> dict[str, Any]:
        return _jsonable({
            "method": f"mass-spring-damper FRF fit ({self.method})",
            "parameters": {"mass": self.mass, "damping": self.damping, "stiffness": self.stiffness},
            "units": {"mass": "kg", "damping": "N s/m", "stiffness": "N/m"},
            "std_errors": dict(self.std_errors),
            "derived": {"natural_frequency_hz": self.natural_frequency, "damping_ratio": self.damping_ratio},
            "metrics": {"fit_percent": self.fit_percent, "rms_log_magnitude_error": self.rms_log_magnitude_error,
                        "n_points": self.n_points},
            "fs": self.fs,
            "derivative": self.derivative,
            "f_range_hz": list(self.f_range),
        })


def _levy_start(f: np.ndarray, H: np.ndarray, derivative: int) -> np.ndarray:
    """Linear LS of ``(j w)^p / H = k - m w^2 + j c w`` with relative weights."""
    w = 2 * np.pi * f
    s = 1j * w
    Z = s**derivative / H  # = m s^2 + c s + k
    wt = 1.0 / np.abs(Z)
    A = np.concatenate([np.column_stack([-(w**2), np.zeros_like(w), np.ones_like(w)]) * wt[:, None],
                        np.column_stack([np.zeros_like(w), w, np.zeros_like(w)]) * wt[:, None]])
    rhs = np.concatenate([Z.real * wt, Z.imag * wt])
    theta, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    return theta  # m, c, k


def fit_mass_spring_damper(
    frequencies: Any,
    response: Any = None,
    *,
    method: str = "zoh",
    fs: float | None = None,
    derivative: int = 0,
    weights: Any = None,
    f_range: tuple[float, float] | None = None,
    min_coherence: float | None = None,
    initial: tuple[float, float, float] | None = None,
    progress: Any = None,
) -> MsdFit:
    """Fit ``m, c, k`` of ``s^p / (m s^2 + c s + k)`` to FRF data.

    ``frequencies`` [Hz] and complex ``response`` (output/input), or an :class:`FrfEstimate`
    as the only positional argument. ``method``: ``"zoh"`` (sampled model, needs ``fs``;
    taken from the estimate if given), ``"magnitude"`` or ``"continuous"`` (biased on sampled
    data; module docstring). ``weights``: per-point weights or ``"coherence"``.
    ``f_range`` = (f_min, f_max) [Hz] and ``min_coherence`` select points. ``progress``: an
    optional callable ``progress(evaluations, max_evaluations)`` called at every model
    evaluation (e.g. :class:`identification.quality.Progress`).
    """
    coh = None
    if isinstance(frequencies, FrfEstimate):
        est = frequencies
        if response is not None:
            raise FrfError("pass either an FrfEstimate or (frequencies, response), not both")
        f = est.frequencies
        H = est.response
        coh = est.coherence
        if fs is None:
            fs = est.fs
    else:
        if response is None:
            raise FrfError("response (complex FRF values) is required with an array of frequencies")
        f = np.asarray(frequencies, dtype=np.float64)
        H = np.asarray(response, dtype=complex)
    if f.ndim != 1 or H.shape != f.shape:
        raise FrfError(f"frequencies and response must be 1-D of equal length, got {f.shape} and {H.shape}")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(H))):
        raise FrfError("frequencies/response contain NaN or inf")
    if method not in ("zoh", "continuous", "magnitude"):
        raise FrfError(f"method = {method!r}; allowed 'zoh', 'continuous', 'magnitude'")
    if method == "zoh":
        if fs is None:
            raise FrfError("method='zoh' needs the sample rate fs [Hz] of the data")
        fs = _rate(fs)
    if isinstance(weights, str):
        if weights != "coherence" or coh is None:
            raise FrfError("weights='coherence' needs an FrfEstimate with coherence")
        with np.errstate(divide="ignore"):
            wts = np.sqrt(np.clip(coh, 0.0, 0.999) / (1.0 - np.clip(coh, 0.0, 0.999)))
    elif weights is None:
        wts = np.ones_like(f)
    else:
        wts = np.sqrt(np.asarray(weights, dtype=np.float64))
        if wts.shape != f.shape or not np.all(np.isfinite(wts)):
            raise FrfError("weights must be finite and one per frequency")
    keep = (f > 0) & (np.abs(H) > 0)
    if f_range is not None:
        keep &= (f >= f_range[0]) & (f <= f_range[1])
    if min_coherence is not None:
        if coh is None:
            raise FrfError("min_coherence needs an FrfEstimate with coherence")
        keep &= coh >= min_coherence
    if fs is not None:
        keep &= f < 0.5 * fs
    f, H, wts = f[keep], H[keep], wts[keep]
    if f.size < 4:
        raise FrfError(f"only {f.size} usable frequency points; at least 4 are needed for m, c, k")

    if initial is None:
        m0, c0, k0 = _levy_start(f, H, derivative)
        # a broken start (negative values) falls back to a resonance-based guess
        if not (m0 > 0 and c0 > 0 and k0 > 0):
            w_all = 2 * np.pi * f
            g = np.abs(H) / w_all**derivative  # |1 / (m s^2 + c s + k)|
            wn = w_all[int(np.argmax(g))]
            k0 = 1.0 / g[0]
            m0 = k0 / wn**2
            c0 = 0.2 * math.sqrt(k0 * m0)
    else:
        m0, c0, k0 = initial
    x0 = np.log([m0, c0, k0])
    absH = np.abs(H)
    max_nfev = 2000
    count = [0]

    def model(p: np.ndarray) -> np.ndarray:
        if progress is not None:
            count[0] += 1
            progress(count[0], max_nfev)
        m, c, k = np.exp(p)
        return msd_response(f, m, c, k, model="zoh" if method == "zoh" else "continuous", fs=fs,
                            derivative=derivative)

    if method == "magnitude":
        logH = np.log(absH)

        def resid(p: np.ndarray) -> np.ndarray:
            return wts * (np.log(np.abs(model(p))) - logH)
    else:

        def resid(p: np.ndarray) -> np.ndarray:
            r = (model(p) - H) / absH
            return np.concatenate([wts * r.real, wts * r.imag])

    sol = optimize.least_squares(resid, x0, method="trf", x_scale=1.0, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                 max_nfev=max_nfev)
    p = sol.x
    m, c, k = np.exp(p)
    r = sol.fun
    dof = max(r.size - 3, 1)
    s2 = float(r @ r) / dof
    J = sol.jac
    try:
        cov_log = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        cov_log = s2 * np.linalg.pinv(J.T @ J)
    vals = np.array([m, c, k])
    se = vals * np.sqrt(np.maximum(np.diag(cov_log), 0.0))
    G = model(p)
    den = float(np.linalg.norm(H - H.mean()))
    fitp = 100.0 * (1.0 - float(np.linalg.norm(H - G)) / den) if den > 0 else math.nan
    return MsdFit(
        mass=float(m), damping=float(c), stiffness=float(k),
        std_errors={"mass": float(se[0]), "damping": float(se[1]), "stiffness": float(se[2])},
        method=method, fs=fs, derivative=int(derivative), n_points=int(f.size), fit_percent=fitp,
        rms_log_magnitude_error=float(np.sqrt(np.mean((np.log(np.abs(G)) - np.log(absH)) ** 2))),
        f_range=(float(f.min()), float(f.max())),
    )


def identify_msd_from_time_series(
    u: Any,
    y: Any,
    fs: float,
    *,
    method: str = "zoh",
    derivative: int = 0,
    nperseg: int | None = None,
    f_range: tuple[float, float] | None = None,
    min_coherence: float | None = 0.9,
    weights: Any = None,
    progress: Any = None,
) -> tuple[MsdFit, FrfEstimate]:
    """H1 estimate of ``u -> y`` sampled at ``fs``, then :func:`fit_mass_spring_damper`."""
    est = h1_estimate(u, y, fs, nperseg=nperseg)
    fit = fit_mass_spring_damper(est, method=method, derivative=derivative, f_range=f_range,
                                 min_coherence=min_coherence, weights=weights, progress=progress)
    return fit, est


# ======================================================== generic rational model fit
@dataclasses.dataclass
class TransferFunctionFit:
    """Parameters of a user model ``num(s; p) / den(s; p)`` fitted to FRF data."""

    params: np.ndarray
    std_errors: np.ndarray
    names: tuple[str, ...]
    method: str
    fs: float | None
    n_points: int
    fit_percent: float
    rms_log_magnitude_error: float

    def to_json_dict(self) -> dict[str, Any]:
        return _jsonable({
            "method": f"transfer-function FRF fit ({self.method})",
            "parameters": dict(zip(self.names, self.params.tolist())),
            "std_errors": dict(zip(self.names, self.std_errors.tolist())),
            "metrics": {"fit_percent": self.fit_percent,
                        "rms_log_magnitude_error": self.rms_log_magnitude_error,
                        "n_points": self.n_points},
            "fs": self.fs,
        })


def fit_transfer_function(
    frequencies: Any,
    response: Any,
    model: Any,
    x0: Sequence[float],
    *,
    method: str = "zoh",
    fs: float | None = None,
    names: Sequence[str] | None = None,
    positive: bool = True,
    weights: Any = None,
) -> TransferFunctionFit:
    """Fit parameters ``p`` of a continuous rational model to FRF data, three ways.

    ``model(p) -> (num, den)``: polynomial coefficients in ``s`` (descending powers), e.g.
    the transfer functions of 000 eqs (11)-(17) written as functions of the unknown damping.
    ``method`` as in :func:`fit_mass_spring_damper`: ``"zoh"`` fits the zero-order-hold
    equivalent at ``fs`` (:func:`zoh_frequency_response`), ``"magnitude"`` the
    log-magnitude of ``G(j w)``, ``"continuous"`` the complex ``G(j w)`` (biased on sampled
    data). ``positive`` fits ``log p`` (every parameter > 0). Standard errors from the
    Jacobian, as there.
    """
    f = np.asarray(frequencies, dtype=np.float64)
    H = np.asarray(response, dtype=complex)
    if f.ndim != 1 or H.shape != f.shape or f.size == 0:
        raise FrfError(f"frequencies and response must be 1-D of equal length, got {f.shape} and {H.shape}")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(H))) or np.any(np.abs(H) == 0):
        raise FrfError("frequencies/response must be finite and the response non-zero")
    if method not in ("zoh", "continuous", "magnitude"):
        raise FrfError(f"method = {method!r}; allowed 'zoh', 'continuous', 'magnitude'")
    if method == "zoh":
        if fs is None:
            raise FrfError("method='zoh' needs the sample rate fs [Hz] of the data")
        fs = _rate(fs)
        if np.any(f >= 0.5 * fs):
            raise FrfError(f"frequencies must lie below fs/2 = {0.5 * fs} Hz for the ZOH model")
    x0 = np.asarray(x0, dtype=np.float64)
    if f.size < x0.size + 1:
        raise FrfError(f"{f.size} frequency points for {x0.size} parameters: too few")
    if positive and np.any(x0 <= 0):
        raise FrfError("positive=True needs a positive start x0")
    names = tuple(names) if names is not None else tuple(f"p{i}" for i in range(x0.size))
    wts = np.ones_like(f) if weights is None else np.sqrt(np.asarray(weights, dtype=np.float64))
    absH = np.abs(H)
    s_j = 2j * np.pi * f

    def unpack(q: np.ndarray) -> np.ndarray:
        return np.exp(q) if positive else q

    def g(q: np.ndarray) -> np.ndarray:
        num, den = model(unpack(q))
        if method == "zoh":
            return zoh_frequency_response(num, den, f, fs)
        return np.polyval(num, s_j) / np.polyval(den, s_j)

    if method == "magnitude":
        logH = np.log(absH)

        def resid(q: np.ndarray) -> np.ndarray:
            return wts * (np.log(np.abs(g(q))) - logH)
    else:

        def resid(q: np.ndarray) -> np.ndarray:
            r = (g(q) - H) / absH
            return np.concatenate([wts * r.real, wts * r.imag])

    q0 = np.log(x0) if positive else x0
    sol = optimize.least_squares(resid, q0, method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=5000)
    r = sol.fun
    s2 = float(r @ r) / max(r.size - x0.size, 1)
    cov = s2 * np.linalg.pinv(sol.jac.T @ sol.jac)
    p = unpack(sol.x)
    se_q = np.sqrt(np.maximum(np.diag(cov), 0.0))
    se = p * se_q if positive else se_q
    G = g(sol.x)
    den = float(np.linalg.norm(H - H.mean()))
    return TransferFunctionFit(
        params=p, std_errors=se, names=names, method=method, fs=fs, n_points=int(f.size),
        fit_percent=100.0 * (1.0 - float(np.linalg.norm(H - G)) / den) if den > 0 else math.nan,
        rms_log_magnitude_error=float(np.sqrt(np.mean((np.log(np.abs(G)) - np.log(absH)) ** 2))),
    )
