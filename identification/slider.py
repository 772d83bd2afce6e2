r"""Inverse-dynamics least-squares identification of the generic slider.

Identifies the physical parameters of :mod:`hydro_envs.plants.slider` from a record of the
applied force ``f`` [N] and the position ``x`` [m] at a constant sample rate::

    f = m a + F_f(v) + F_0
    F_f(v) = (F_C + (F_S - F_C) exp(-|v| / v_S)) s(v) + b v      (002 eq (1))

with ``s(v) = sign(v)`` (or ``tanh(v / v_eps)`` when ``sign_velocity = v_eps`` is given).

Procedure (the standard one for robots and positioning stages: Gautier's inverse-dynamic
identification model with parallel filtering)

1. Check the data (finite, same length, long enough, excitation, motion in both directions);
   every problem raises :class:`SliderIdentificationError` saying what is wrong.
2. Zero-phase low-pass of the position (Butterworth, ``scipy.signal.butter`` as second-order
   sections, forward-backward ``sosfiltfilt``; cut-off ``cutoff``), then central differences
   for velocity and acceleration (``(x[k+1] - x[k-1]) / 2 dt`` and
   ``(x[k+1] - 2 x[k] + x[k-1]) / dt^2``).
3. Build the regressor ``Phi = [a, s(v) (1 - e), s(v) e, v, 1]`` with
   ``e = exp(-|v| / v_S)`` at full rate; the linear parameters are
   ``(m, F_C, F_S, b, F_0)``. Samples with ``|v| < min_speed`` (sticking or creeping, where
   ``sign(v)`` is undefined and the static friction is not given by the model) are excluded.
   The default ``min_speed`` only clears the velocity noise; a stage that creeps (compliant
   guides, or the tanh-regularised simulation of :mod:`hydro_envs.plants.slider`, which
   creeps below a few ``friction_sign_velocity``) needs ``min_speed`` above its creep speed.
4. Decimation by ``decimation`` with *parallel filtering*: the force and every regressor
   column are low-passed by the same zero-phase filter (cut-off 0.8 of the new Nyquist
   frequency) before keeping every ``decimation``-th sample. Because the filter is linear,
   the filtered equation holds exactly, so this only removes noise and aliasing. A sample is
   used only if no excluded sample lies within one filter period of it, and one position-filter
   period is dropped at both ends (forward-backward edge transients).
5. Linear least squares for ``(m, F_C, F_S, b, F_0)`` at fixed ``v_S``.

The Stribeck part (``stribeck=``):

* ``"auto"`` (default): both ``"none"`` and ``"fit"``; the dip model is reported only if the
  data identify it (rules below) *and* it lowers the Bayesian information criterion
  ``n ln(RSS/n) + k ln n`` on the used samples. Otherwise the result is the ``"none"`` fit,
  so an unsupported dip never biases the viscous and Coulomb levels; ``notes`` say which
  model was chosen and why.
* ``"fit"``: second stage, separable nonlinear least squares. For each trial
  ``v_S`` the other five parameters follow from step 5, so the residual sum of squares is
  profiled over ``log v_S`` (coarse grid over the speed range of the data, then a bounded
  scalar search); the covariance of all six parameters comes from the full Jacobian at the
  optimum (the ``v_S`` column is ``(F_S - F_C) s(v) e |v| / v_S^2``, filtered like the
  others). The fit is declared *identified* only if the optimum is interior, the dip
  ``F_S - F_C`` exceeds three standard errors, the relative standard error of ``v_S`` is
  below 25 %, at least 20 used samples lie below ``3 v_S``, and the dip is seen at
  near-constant speed (``|m a| < 0.1 (F_S - F_C)``, in runs of at least two position-filter
  periods) for at least 20 filter periods in total; otherwise ``stribeck_identified`` is
  False and ``notes`` says why -- the values are then not to be trusted. Why the last rule:
  with fast reversals only, the dip is crossed in a few milliseconds per reversal, faster
  than the differentiation filter can render, and the dip estimates then depend on the
  cut-off and miss by 5-30 % while their standard errors look small (tests/test_slider.py
  measures this). The Stribeck curve is pinned by slow constant-velocity segments, which
  need feedback because the dip is open-loop unstable -- the constant-velocity tests of
  002 eqs (9)-(10) and 004 eq (1).
* ``"fixed"``: ``stribeck_velocity`` (and optionally ``static_friction``) are given; the rest
  is linear.
* ``"none"``: no dip, ``F_S = F_C`` (four linear parameters).

Direction-dependent friction (``asymmetric=True``, with ``stribeck`` ``"none"`` or
``"auto"``): ``f = m a + (F_C+ + b+ v) [v > 0] + (-F_C- + b- v) [v < 0]``, five linear
parameters (``DIRECTION_PARAMETER_NAMES``) and no separate offset (a constant force is the
half-difference of the two Coulomb levels, not separable from them). The fitted values are in
``direction_params`` / ``direction_std_errors``; ``params`` then holds the symmetric
equivalents ``F_C = (F_C+ + F_C-)/2``, ``b = (b+ + b-)/2``, ``F_0 = (F_C+ - F_C-)/2``.

Standard errors: the residuals of a filtered, differentiated record are autocorrelated, and
docs/references.md (numerics notes) measured naive standard errors 1.6-2.2x too small. We
report the naive ones (``std_errors_naive``) and heteroscedasticity-and-autocorrelation
consistent ones (Newey-West, Bartlett weights, ``std_errors``), the latter being the default.
Neither covers bias: the mass is shrunk by errors in variables when acceleration noise is a
noticeable share of the acceleration excitation (``acceleration_noise_ratio``, with a note
above 1 %), and the dip by filter distortion (above).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import optimize, signal

__all__ = [
    "SliderIdentificationError",
    "SliderIdentification",
    "identify_slider",
    "identify_slider_measured",
    "PARAMETER_NAMES",
    "DIRECTION_PARAMETER_NAMES",
]

#: Reported parameters, named as the fields of :class:`hydro_envs.plants.slider.SliderParams`.
PARAMETER_NAMES = (
    "mass",
    "coulomb_friction",
    "static_friction",
    "stribeck_velocity",
    "viscous_friction",
    "force_offset",
)
_UNITS = {
    "mass": "kg",
    "coulomb_friction": "N",
    "static_friction": "N",
    "stribeck_velocity": "m/s",
    "viscous_friction": "N s/m",
    "force_offset": "N",
}
#: Parameters of the direction-dependent model (``asymmetric=True``).
DIRECTION_PARAMETER_NAMES = (
    "mass",
    "coulomb_friction_pos",
    "viscous_friction_pos",
    "coulomb_friction_neg",
    "viscous_friction_neg",
)
_DIRECTION_UNITS = {"mass": "kg", "coulomb_friction_pos": "N", "viscous_friction_pos": "N s/m",
                    "coulomb_friction_neg": "N", "viscous_friction_neg": "N s/m"}
_MIN_USED = 50
#: relative sample-time jitter accepted on measured records (the median step is used)
JITTER_TOLERANCE = 1e-3


class SliderIdentificationError(ValueError):
    """The data cannot identify the slider parameters (message says why and what to do)."""

    exit_code = 1  # the command line's code for data that cannot give a result (hydro_envs.cli_errors)


@dataclasses.dataclass
class SliderIdentification:
    """Result of :func:`identify_slider`. Parameters in SI units (see ``units``)."""

    params: dict[str, float]
    std_errors: dict[str, float]
    std_errors_naive: dict[str, float]
    fitted: tuple[str, ...]
    stribeck: str
    stribeck_identified: bool
    covariance: np.ndarray  # HAC covariance of the fitted parameters, order of ``fitted``
    rms_residual: float  # [N] on the used (filtered, decimated) samples
    fit_percent: float  # 100 (1 - ||f - f_hat|| / ||f - mean f||) on the used samples
    nrmse: float  # ||f - f_hat|| / ||f - mean f||
    n_samples: int
    n_used: int
    sample_time: float
    cutoff: float
    decimation: int
    min_speed: float
    position_noise: float  # robust estimate of the position-sensor noise std [m]
    hac_lag: int
    acceleration_noise_ratio: float  # sigma_a^2 / mean(a^2) on the used samples (EIV bias)
    notes: list[str] = dataclasses.field(default_factory=list)
    units: dict[str, str] = dataclasses.field(default_factory=lambda: dict(_UNITS))
    #: direction-dependent fit (``asymmetric=True``), else None
    direction_params: dict[str, float] | None = None
    direction_std_errors: dict[str, float] | None = None
    #: Bayesian information criterion on the used samples (model selection of ``"auto"``)
    bic: float = math.nan

    def to_params(self, base: Any = None):
        """A :class:`~hydro_envs.plants.slider.SliderParams` with the identified values.

        Fields not identified (stroke, stops, ``friction_sign_velocity``) come from ``base``
        (default: the nominal set). Raises ``ParameterError`` if a value is unphysical.
        """
        from hydro_envs.plants.slider.params import SliderParams

        base = base if base is not None else SliderParams()
        vals = {k: v for k, v in self.params.items() if math.isfinite(v)}
        return SliderParams.from_mapping(vals, base)

    def relative_std_errors(self) -> dict[str, float]:
        return {
            k: (self.std_errors[k] / abs(self.params[k]) if self.params[k] != 0 else math.inf)
            for k in self.std_errors
        }

    def to_json_dict(self) -> dict[str, Any]:
        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "method": "slider inverse-dynamics least squares",
            "parameters": {k: num(v) for k, v in self.params.items()},
            "std_errors": {k: num(v) for k, v in self.std_errors.items()},
            "std_errors_naive": {k: num(v) for k, v in self.std_errors_naive.items()},
            "units": dict(self.units),
            "fitted": list(self.fitted),
            "stribeck": self.stribeck,
            "stribeck_identified": bool(self.stribeck_identified),
            "metrics": {
                "rms_residual_N": num(self.rms_residual),
                "fit_percent": num(self.fit_percent),
                "nrmse": num(self.nrmse),
            },
            "data": {
                "n_samples": self.n_samples,
                "n_used": self.n_used,
                "sample_time_s": self.sample_time,
                "cutoff_hz": self.cutoff,
                "decimation": self.decimation,
                "min_speed_m_per_s": self.min_speed,
                "position_noise_m": self.position_noise,
                "hac_lag": self.hac_lag,
                "acceleration_noise_ratio": num(self.acceleration_noise_ratio),
            },
            "notes": list(self.notes),
        }


# ------------------------------------------------------------------------ helpers
def _check_series(name: str, arr: Any) -> np.ndarray:
    a = np.asarray(arr, dtype=np.float64)
    if a.ndim != 1:
        raise SliderIdentificationError(f"{name} must be a 1-D array, got shape {a.shape}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise SliderIdentificationError(
            f"{name} has {bad.size} NaN/inf value(s), first at sample {int(bad[0])}; "
            "remove or repair them before identification (nothing is interpolated here)"
        )
    return a


def _position_noise(x: np.ndarray) -> float:
    """Robust std of white position noise from the MAD of second differences (var 6 s^2)."""
    d2 = np.diff(x, 2)
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(1.4826 * mad / math.sqrt(6.0))


def _diff_velocity_acceleration(xf: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.empty_like(xf)
    a = np.empty_like(xf)
    v[1:-1] = (xf[2:] - xf[:-2]) / (2.0 * dt)
    a[1:-1] = (xf[2:] - 2.0 * xf[1:-1] + xf[:-2]) / (dt * dt)
    v[0], v[-1] = v[1], v[-2]
    a[0], a[-1] = a[1], a[-2]
    return v, a


def _newey_west_lag(n: int, resid: np.ndarray) -> int:
    """Bandwidth: NW (1994) rule, widened to the first lag where the residual ACF is small."""
    rule = int(math.floor(4.0 * (n / 100.0) ** (2.0 / 9.0)))
    r = resid - resid.mean()
    den = float(r @ r)
    lag = rule
    if den > 0:
        max_lag = max(1, min(n // 4, 200))
        for k in range(1, max_lag + 1):
            if abs(float(r[k:] @ r[:-k]) / den) < 2.0 / math.sqrt(n):
                lag = max(rule, k)
                break
        else:
            lag = max_lag
    return max(1, min(lag, n // 4))


def _hac_covariance(J: np.ndarray, resid: np.ndarray, lag: int, n: int, dof: int) -> np.ndarray:
    """Newey-West sandwich ``(J'J)^-1 S (J'J)^-1`` with small-sample factor ``n / dof``.

    Rows of ``J`` and ``resid`` are on the (decimated) time axis; rows set to zero (unused
    samples) contribute nothing, so gaps keep their true time lags.
    """
    g = J * resid[:, None]
    S = g.T @ g
    for k in range(1, lag + 1):
        w = 1.0 - k / (lag + 1.0)
        G = g[k:].T @ g[:-k]
        S += w * (G + G.T)
    S *= n / max(dof, 1)
    JtJ_inv = np.linalg.pinv(J.T @ J)
    return JtJ_inv @ S @ JtJ_inv


def _quasi_steady_dip_time(
    absv: np.ndarray, a: np.ndarray, min_speed: float, vs: float, mass: float, dip: float,
    min_run: int, core: slice,
) -> int:
    """Samples in the Stribeck dip (min_speed <= |v| < 3 v_S) at near-constant speed.

    Near-constant: the inertial force ``|m a|`` is below 10 % of the dip ``F_S - F_C``. Only
    runs of at least ``min_run`` consecutive samples count (two position-filter periods):
    there the dip is read off the force as in a constant-velocity test, independent of how
    the filter renders fast transients.
    """
    ok = np.zeros(absv.size, dtype=bool)
    ok[core] = True
    ok &= (absv >= min_speed) & (absv < 3.0 * vs) & (np.abs(mass * a) < 0.1 * abs(dip))
    if not ok.any():
        return 0
    edges = np.diff(np.concatenate([[0], ok.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)
    runs = ends - starts
    return int(runs[runs >= min_run].sum())


# ------------------------------------------------------------------ main routine
def identify_slider(
    force: Any,
    position: Any,
    dt: float,
    *,
    stribeck: str = "auto",
    asymmetric: bool = False,
    **options: Any,
) -> SliderIdentification:
    """Identify ``m, F_C, F_S, v_S, b, F_0`` of a slider from force [N] and position [m].

    ``stribeck``: ``"auto"`` (default; the dip only when the data identify it and it lowers
    the BIC), ``"fit"``, ``"fixed"`` or ``"none"`` (module docstring). ``asymmetric``: fit
    Coulomb and viscous friction per direction of motion. Other options: see
    :func:`_identify_slider` (cutoff, decimation, min_speed, stribeck_velocity,
    static_friction, stribeck_bounds, sign_velocity, filter_order).
    """
    if stribeck not in ("auto", "fit", "fixed", "none"):
        raise SliderIdentificationError(f"stribeck = {stribeck!r}; allowed: 'auto', 'fit', 'fixed', 'none'")
    if asymmetric:
        if stribeck not in ("auto", "none"):
            raise SliderIdentificationError(
                f"asymmetric=True fits Coulomb and viscous friction per direction without a dip; "
                f"stribeck = {stribeck!r} is not allowed with it (use 'none' or 'auto')"
            )
        return _identify_slider(force, position, dt, stribeck="none", asymmetric=True, **options)
    if stribeck != "auto":
        return _identify_slider(force, position, dt, stribeck=stribeck, **options)
    plain = _identify_slider(force, position, dt, stribeck="none", **options)
    dip = _identify_slider(force, position, dt, stribeck="fit", **options)
    if dip.stribeck_identified and dip.bic < plain.bic:
        dip.notes.append(f"stribeck='auto': dip model chosen (identified; BIC {dip.bic:.6g} < {plain.bic:.6g} "
                         "without the dip)")
        return dip
    why = ("the data do not identify the dip: " + "; ".join(n for n in dip.notes if "NOT identified" in n)
           if not dip.stribeck_identified else f"BIC {dip.bic:.6g} with the dip is not below {plain.bic:.6g}")
    plain.notes[:] = [n for n in plain.notes if not n.startswith("stribeck='none'")]
    plain.notes.append(f"stribeck='auto': no Stribeck dip reported ({why})")
    return plain


@dataclasses.dataclass
class _Regression:
    """The filtered, differentiated and decimated record that every model variant regresses on.

    ``v``, ``a``, ``s`` (sign or tanh of ``v``) and ``absv`` are at the full rate; ``used_idx``
    are the full-rate indices of the used (fast enough, away from filter edges, decimated)
    samples; ``ff``, ``a_c``, ``v_c`` are the parallel-filtered force, acceleration and velocity
    there; ``pfilt`` is the parallel (anti-alias) filter applied to any full-rate column.
    """

    n: int
    dt: float
    cutoff: float
    decimation: int
    v: np.ndarray
    a: np.ndarray
    s: np.ndarray
    absv: np.ndarray
    core: slice
    idx: np.ndarray
    used_full: np.ndarray
    used_mask_dec: np.ndarray
    used_idx: np.ndarray
    ff: np.ndarray
    a_c: np.ndarray
    v_c: np.ndarray
    pfilt: Callable[[np.ndarray], np.ndarray]
    position_noise: float
    min_speed: float
    accel_noise_ratio: float

    @property
    def n_used(self) -> int:
        return int(self.used_idx.size)

    def used(self, col: np.ndarray) -> np.ndarray:
        """A full-rate regressor column, parallel-filtered, at the used samples."""
        return self.pfilt(col)[self.used_idx]

    def design(self, vs: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        """Used rows of ``[a, s(1-e), s e, v, 1]`` (``[a, s, v, 1]`` without a dip, ``vs=None``);
        ``e = exp(-|v|/v_S)`` at the full rate."""
        one = np.ones(self.n_used)
        if vs is None:
            return np.column_stack([self.a_c, self.used(self.s), self.v_c, one]), None
        e = np.exp(-self.absv / vs)
        return np.column_stack([self.a_c, self.used(self.s * (1.0 - e)), self.used(self.s * e), self.v_c, one]), e


@dataclasses.dataclass
class _Fit:
    """One model variant fitted: parameters, fitted names (Jacobian column order), residuals."""

    params: dict[str, float]
    fitted: tuple[str, ...]
    jacobian: np.ndarray
    resid: np.ndarray
    identified: bool
    notes: list[str]
    direction: dict[str, float] | None = None
    at_bound: bool = False
    profile_span: float = math.nan


def _checked_options(f, x, dt, stribeck, stribeck_velocity, cutoff, decimation):
    """Validate the record and the options; returns ``(cutoff, decimation, trim)``."""
    if f.shape != x.shape:
        raise SliderIdentificationError(
            f"force and position must have the same length, got {f.size} and {x.size} samples"
        )
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise SliderIdentificationError(f"dt = {dt!r} must be a finite sample time > 0 s")
    if stribeck not in ("fit", "fixed", "none"):
        raise SliderIdentificationError(f"stribeck = {stribeck!r}; allowed: 'fit', 'fixed', 'none'")
    if stribeck == "fixed":
        if stribeck_velocity is None or not (stribeck_velocity > 0):
            raise SliderIdentificationError(
                "stribeck='fixed' needs stribeck_velocity > 0 [m/s] (and optionally static_friction [N])"
            )
    fs = 1.0 / dt
    n = f.size
    if cutoff is None:
        cutoff = fs / 20.0
    if not (0.0 < cutoff < 0.5 * fs):
        raise SliderIdentificationError(f"cutoff = {cutoff} Hz must lie in (0, fs/2 = {0.5 * fs}) Hz")
    if decimation is None:
        decimation = max(1, int(math.floor(fs / (5.0 * cutoff) + 1e-9)))  # robust to dt rounding
    decimation = int(decimation)
    if decimation < 1:
        raise SliderIdentificationError(f"decimation = {decimation} must be >= 1")
    trim = int(math.ceil(fs / cutoff - 1e-9))
    min_len = 4 * trim + 10 * _MIN_USED * decimation
    if n < min_len:
        raise SliderIdentificationError(
            f"record too short: {n} samples ({n * dt:.3g} s); with cutoff {cutoff:g} Hz and "
            f"decimation {decimation} at least {min_len} samples ({min_len * dt:.3g} s) are needed"
        )
    if np.ptp(f) == 0.0:
        raise SliderIdentificationError("force is constant: no excitation, nothing to identify")
    return cutoff, decimation, trim


def _regression(f, x, dt, cutoff, decimation, trim, min_speed, sign_velocity, filter_order) -> _Regression:
    """Steps 2-4 of the procedure: zero-phase low-pass and central differences, the used
    samples (fast enough, both directions), the parallel filter and decimation."""
    fs = 1.0 / dt
    n = f.size
    sos = signal.butter(int(filter_order), cutoff, btype="low", fs=fs, output="sos")
    xf = signal.sosfiltfilt(sos, x)
    v, a = _diff_velocity_acceleration(xf, dt)
    sigma_x = _position_noise(x)
    # velocity noise gain of (filter + central difference) for unit white position noise
    probe = np.random.default_rng(12345).standard_normal(min(max(8 * trim, 4096), 65536))
    vp, ap = _diff_velocity_acceleration(signal.sosfiltfilt(sos, probe), dt)
    sigma_v = sigma_x * float(np.std(vp[trim:-trim]))
    core = slice(trim, n - trim)
    vmax = float(np.max(np.abs(v[core])))
    if np.ptp(xf[core]) <= 20.0 * max(sigma_x, 1e-300) or vmax == 0.0:
        raise SliderIdentificationError(
            f"no motion: position range {np.ptp(xf[core]):.3g} m is not above 20x the position "
            f"noise ({sigma_x:.3g} m); excite the slider with a larger force"
        )
    if min_speed is None:
        min_speed = max(4.0 * sigma_v, 1e-3 * vmax)
    if not (min_speed >= 0):
        raise SliderIdentificationError(f"min_speed = {min_speed} must be >= 0 m/s")
    if vmax <= 2.0 * min_speed:
        raise SliderIdentificationError(
            f"no excitation: peak speed {vmax:.3g} m/s is not above 2x min_speed "
            f"({min_speed:.3g} m/s); the slider barely moves (sticking?)"
        )
    s = np.tanh(v / sign_velocity) if sign_velocity > 0 else np.sign(v)
    absv = np.abs(v)
    valid = absv >= min_speed
    valid[:trim] = False
    valid[n - trim :] = False

    if decimation > 1:
        sos_p = signal.butter(8, 0.8 * 0.5 * fs / decimation, btype="low", fs=fs, output="sos")
        width = int(math.ceil(decimation / 0.4 - 1e-9))  # one period of the parallel filter

        def pfilt(col: np.ndarray) -> np.ndarray:
            return signal.sosfiltfilt(sos_p, col)

        bad = (~valid).astype(np.float64)
        near_bad = np.convolve(bad, np.ones(2 * width + 1), mode="same") > 0.5
        used_full = valid & ~near_bad
        idx = np.arange(0, n, decimation)
    else:

        def pfilt(col: np.ndarray) -> np.ndarray:
            return col

        used_full = valid
        idx = np.arange(n)
    used_mask_dec = used_full[idx]
    n_used = int(used_mask_dec.sum())
    if n_used < _MIN_USED:
        raise SliderIdentificationError(
            f"only {n_used} usable samples (need >= {_MIN_USED}): the slider moves faster than "
            f"min_speed = {min_speed:.3g} m/s too rarely or too briefly; record longer or "
            "excite more, or lower min_speed"
        )
    used_idx = idx[used_mask_dec]
    n_pos = int(np.sum(v[used_idx] > 0))
    n_neg = int(np.sum(v[used_idx] < 0))
    if min(n_pos, n_neg) < max(10, 0.05 * n_used):
        raise SliderIdentificationError(
            f"no direction changes: {n_pos} usable samples move in +x and {n_neg} in -x; the "
            "slider must move in both directions, otherwise Coulomb friction and the force "
            "offset are not separable (sign(v) is constant)"
        )
    a_c = pfilt(a)[used_idx]
    # errors-in-variables check: acceleration noise (position noise through the whole chain)
    # relative to the acceleration excitation; LS shrinks the mass by about this fraction
    sigma_a = sigma_x * float(np.std(pfilt(ap)[trim:-trim]))
    accel_noise_ratio = sigma_a**2 / max(float(np.mean(a_c**2)), 1e-300)
    return _Regression(
        n=n, dt=dt, cutoff=cutoff, decimation=decimation, v=v, a=a, s=s, absv=absv, core=core,
        idx=idx, used_full=used_full, used_mask_dec=used_mask_dec, used_idx=used_idx,
        ff=pfilt(f)[used_idx], a_c=a_c, v_c=pfilt(v)[used_idx], pfilt=pfilt,
        position_noise=sigma_x, min_speed=float(min_speed), accel_noise_ratio=float(accel_noise_ratio),
    )


def _lstsq(Phi: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column-scaled least squares: ``(theta, residual)``."""
    scale = np.sqrt(np.sum(Phi * Phi, axis=0))
    scale[scale == 0] = 1.0
    theta_s, *_ = np.linalg.lstsq(Phi / scale, rhs, rcond=None)
    theta = theta_s / scale
    return theta, rhs - Phi @ theta


def _check_conditioning(Phi: np.ndarray, names: list[str]) -> None:
    """An error naming the parameter the data cannot separate (zero or collinear regressor)."""
    scale = np.sqrt(np.sum(Phi * Phi, axis=0))
    if np.any(scale == 0):
        j = int(np.flatnonzero(scale == 0)[0])
        raise SliderIdentificationError(f"parameter {names[j]!r} has no excitation (zero regressor)")
    _, sv, vt = np.linalg.svd(Phi / scale, full_matrices=False)
    cond = sv[0] / sv[-1]
    if cond > 1e6:
        j = int(np.argmax(np.abs(vt[-1])))
        raise SliderIdentificationError(
            f"regressor is ill-conditioned (condition number {cond:.3g}): {names[j]!r} is "
            "not separable from the others with these data; add excitation (accelerations "
            "for mass, a range of speeds for viscous friction, both directions for offset)"
        )


def _linear_fit(Phi: np.ndarray, rhs: np.ndarray, names: list[str]) -> tuple[dict[str, float], np.ndarray]:
    _check_conditioning(Phi, names)
    theta, resid = _lstsq(Phi, rhs)
    return dict(zip(names, (float(t) for t in theta))), resid


def _fit_asymmetric(R: _Regression) -> _Fit:
    """``m a + F_C+ [v>0] + b+ v [v>0] - F_C- [v<0] + b- v [v<0]``: friction per direction."""
    pos = (R.v > 0).astype(np.float64)
    neg = (R.v < 0).astype(np.float64)
    names = list(DIRECTION_PARAMETER_NAMES)
    Phi = np.column_stack([R.a_c, R.used(pos), R.used(R.v * pos), -R.used(neg), R.used(R.v * neg)])
    d, resid = _linear_fit(Phi, R.ff, names)
    fc = 0.5 * (d["coulomb_friction_pos"] + d["coulomb_friction_neg"])
    params = {
        "mass": d["mass"],
        "coulomb_friction": fc,
        "static_friction": fc,
        "stribeck_velocity": math.nan,
        "viscous_friction": 0.5 * (d["viscous_friction_pos"] + d["viscous_friction_neg"]),
        "force_offset": 0.5 * (d["coulomb_friction_pos"] - d["coulomb_friction_neg"]),
    }
    note = ("asymmetric: Coulomb and viscous friction per direction (params hold the symmetric "
            "equivalents; no separate offset)")
    return _Fit(params, tuple(names), Phi, resid, False, [note], direction=d)


def _fit_without_dip(R: _Regression) -> _Fit:
    """``m a + F_C s + b v + F_0`` (``F_S = F_C``)."""
    names = ["mass", "coulomb_friction", "viscous_friction", "force_offset"]
    Phi, _ = R.design(None)
    lin, resid = _linear_fit(Phi, R.ff, names)
    params = dict(lin, static_friction=lin["coulomb_friction"], stribeck_velocity=math.nan)
    return _Fit(params, tuple(names), Phi, resid, False, ["stribeck='none': no Stribeck dip modelled (F_S = F_C)"])


def _fit_given_dip(R: _Regression, fs_given: float, vs: float) -> _Fit:
    """The dip fixed (``F_S``, ``v_S`` given): linear in ``m, F_C, b, F_0``."""
    names = ["mass", "coulomb_friction", "viscous_friction", "force_offset"]
    Phi5, _ = R.design(vs)
    Phi = Phi5[:, [0, 1, 3, 4]]
    lin, resid = _linear_fit(Phi, R.ff - fs_given * Phi5[:, 2], names)
    params = dict(lin, static_friction=fs_given, stribeck_velocity=vs)
    note = f"stribeck='fixed': F_S = {fs_given:g} N and v_S = {vs:g} m/s given"
    return _Fit(params, tuple(names), Phi, resid, False, [note])


def _fit_dip(R: _Regression, stribeck: str, vs_given: float | None, bounds) -> _Fit:
    """The dip model, linear in ``m, F_C, F_S, b, F_0`` for each ``v_S``; ``v_S`` given
    (``"fixed"``) or found by a profile search on the residual sum of squares (``"fit"``)."""
    names5 = ["mass", "coulomb_friction", "static_friction", "viscous_friction", "force_offset"]
    notes: list[str] = []
    at_bound, profile_span = False, math.nan
    if stribeck == "fixed":
        vs = float(vs_given)
        notes.append(f"stribeck='fixed': v_S = {vs:g} m/s given, F_S fitted linearly")
    else:
        speeds = R.absv[R.used_full]
        lo, hi = (
            bounds
            if bounds is not None
            else (max(0.25 * R.min_speed, 1e-3 * np.max(speeds), 1e-9), float(np.percentile(speeds, 95)))
        )
        if not (0 < lo < hi):
            raise SliderIdentificationError(f"stribeck_bounds {lo!r}..{hi!r} m/s must satisfy 0 < low < high")

        def rss(log_vs: float) -> float:
            _, r = _lstsq(R.design(math.exp(log_vs))[0], R.ff)
            return float(r @ r)

        grid = np.linspace(math.log(lo), math.log(hi), 25)
        vals = np.array([rss(g) for g in grid])
        k = int(np.argmin(vals))
        res = optimize.minimize_scalar(rss, bounds=(grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]),
                                       method="bounded", options={"xatol": 1e-6})
        vs = math.exp(res.x)
        span = grid[-1] - grid[0]
        at_bound = (res.x - grid[0] < 0.02 * span) or (grid[-1] - res.x < 0.02 * span)
        profile_span = float(vals.max() / max(vals.min(), 1e-300))
    Phi, e = R.design(vs)
    lin, resid = _linear_fit(Phi, R.ff, names5)
    params = dict(lin, stribeck_velocity=vs)
    if stribeck != "fit":
        return _Fit(params, tuple(names5), Phi, resid, False, notes)
    d_fs = lin["static_friction"] - lin["coulomb_friction"]
    dcol = R.used(d_fs * R.s * e * R.absv / vs**2)  # d(model)/d(v_S)
    J = np.column_stack([Phi, dcol])[:, [0, 1, 2, 5, 3, 4]]
    fitted = tuple(names5[:3]) + ("stribeck_velocity",) + tuple(names5[3:])
    return _Fit(params, fitted, J, resid, True, notes, at_bound=at_bound, profile_span=profile_span)


def _covariances(R: _Regression, fit: _Fit) -> tuple[np.ndarray, np.ndarray, int]:
    """HAC and naive covariance of the fitted parameters on the used samples, and the HAC lag;
    gaps are fine (filtered columns), the HAC runs over the decimated time axis with zero
    residuals at the unused samples."""
    J, resid = fit.jacobian, fit.resid
    dof = R.n_used - J.shape[1]
    sigma2 = float(resid @ resid) / max(dof, 1)
    try:
        cov_naive = sigma2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        cov_naive = sigma2 * np.linalg.pinv(J.T @ J)
    r_full = np.zeros(R.idx.size)
    r_full[R.used_mask_dec] = resid
    J_full = np.zeros((R.idx.size, J.shape[1]))
    J_full[R.used_mask_dec] = J
    lag = _newey_west_lag(R.n_used, resid)
    return _hac_covariance(J_full, r_full, lag, R.n_used, dof), cov_naive, lag


def _dip_not_identified(R: _Regression, fit: _Fit, cov: np.ndarray, se: dict[str, float]) -> list[str]:
    """Why the data do not identify a fitted Stribeck dip (empty: they do)."""
    p, fitted = fit.params, fit.fitted
    vs = p["stribeck_velocity"]
    rel_vs = se["stribeck_velocity"] / vs
    d_fs = p["static_friction"] - p["coulomb_friction"]
    i_fc, i_fs = fitted.index("coulomb_friction"), fitted.index("static_friction")
    se_d = math.sqrt(max(cov[i_fc, i_fc] + cov[i_fs, i_fs] - 2 * cov[i_fc, i_fs], 0.0))
    n_low = int(np.sum(R.absv[R.used_idx] < 3.0 * vs))
    fs = 1.0 / R.dt
    steady_time = _quasi_steady_dip_time(
        R.absv, R.a, R.min_speed, vs, p["mass"], d_fs, int(math.ceil(2.0 * fs / R.cutoff - 1e-9)), R.core
    ) * R.dt
    need_time = 20.0 / R.cutoff
    reasons = []
    if fit.at_bound:
        reasons.append(f"v_S optimum at the search bound ({vs:.3g} m/s)")
    if not (d_fs > 3.0 * se_d):
        reasons.append(f"dip F_S - F_C = {d_fs:.3g} N is within 3 std errors ({se_d:.3g} N)")
    if not (rel_vs < 0.25):
        reasons.append(f"relative std error of v_S is {rel_vs:.0%} (> 25 %)")
    if n_low < 20:
        reasons.append(f"only {n_low} used samples below 3 v_S")
    if steady_time < need_time:
        reasons.append(
            f"the dip is seen at near-constant speed for only {steady_time:.3g} s (need "
            f"{need_time:.3g} s = 20 filter periods); elsewhere it is crossed in transients "
            "faster than the differentiation filter, which distorts them"
        )
    return reasons


def _identify_slider(
    force: Any,
    position: Any,
    dt: float,
    *,
    cutoff: float | None = None,
    decimation: int | None = None,
    min_speed: float | None = None,
    asymmetric: bool = False,
    stribeck: str = "fit",
    stribeck_velocity: float | None = None,
    static_friction: float | None = None,
    stribeck_bounds: tuple[float, float] | None = None,
    sign_velocity: float = 0.0,
    filter_order: int = 4,
) -> SliderIdentification:
    """Identify ``m, F_C, F_S, v_S, b, F_0`` of a slider from force [N] and position [m].

    ``dt`` [s] is the (constant) sample time. ``cutoff`` [Hz] is the position low-pass
    (default ``fs / 20``); ``decimation`` the decimation factor (default
    ``max(1, floor(fs / (5 cutoff)))``); ``min_speed`` [m/s] excludes slow samples (default:
    four times the velocity noise implied by the estimated position noise and the filter,
    at least 0.1 % of the peak speed). ``stribeck`` is ``"fit" | "fixed" | "none"`` (module
    docstring); ``stribeck_bounds`` [m/s] limits the ``v_S`` search (default: from the
    speed range of the data). ``sign_velocity`` > 0 uses ``tanh(v / sign_velocity)`` instead
    of ``sign(v)`` in the regressor.
    """
    f = _check_series("force", force)
    x = _check_series("position", position)
    cutoff, decimation, trim = _checked_options(f, x, dt, stribeck, stribeck_velocity, cutoff, decimation)
    R = _regression(f, x, dt, cutoff, decimation, trim, min_speed, sign_velocity, filter_order)
    if asymmetric:
        fit = _fit_asymmetric(R)
    elif stribeck == "none":
        fit = _fit_without_dip(R)
    elif stribeck == "fixed" and static_friction is not None:
        fit = _fit_given_dip(R, float(static_friction), float(stribeck_velocity))
    else:
        fit = _fit_dip(R, stribeck, stribeck_velocity, stribeck_bounds)

    cov, cov_naive, lag = _covariances(R, fit)
    se = {nm: float(math.sqrt(max(cov[i, i], 0.0))) for i, nm in enumerate(fit.fitted)}
    se_naive = {nm: float(math.sqrt(max(cov_naive[i, i], 0.0))) for i, nm in enumerate(fit.fitted)}
    notes = list(fit.notes)
    identified = fit.identified
    if stribeck == "fit" and not asymmetric:
        reasons = _dip_not_identified(R, fit, cov, se)
        if reasons:
            identified = False
            notes.append(
                "Stribeck dip NOT identified by these data: " + "; ".join(reasons) + ". "
                "Add slow constant-velocity segments under feedback, or use stribeck='fixed'."
            )
        notes.append(f"v_S profile: RSS max/min over the search range = {fit.profile_span:.4g}")
    if R.accel_noise_ratio > 0.01:
        notes.append(
            f"acceleration noise is {R.accel_noise_ratio:.1%} of the acceleration power: the mass "
            "is biased low by about that fraction (errors in variables); lower the cutoff or "
            "excite larger accelerations"
        )
    resid, ff, n_used = fit.resid, R.ff, R.n_used
    den = float(np.linalg.norm(ff - ff.mean()))
    nrmse = float(np.linalg.norm(resid)) / den if den > 0 else math.inf
    rss = float(resid @ resid)
    bic = n_used * math.log(max(rss, 1e-300) / n_used) + fit.jacobian.shape[1] * math.log(n_used)
    direction = fit.direction
    return SliderIdentification(
        params={k: float(fit.params[k]) for k in PARAMETER_NAMES},
        std_errors=se,
        std_errors_naive=se_naive,
        fitted=fit.fitted,
        stribeck=stribeck,
        stribeck_identified=bool(identified),
        covariance=cov,
        rms_residual=float(np.sqrt(np.mean(resid**2))),
        fit_percent=100.0 * (1.0 - nrmse),
        nrmse=nrmse,
        n_samples=R.n,
        n_used=n_used,
        sample_time=float(dt),
        cutoff=float(cutoff),
        decimation=decimation,
        min_speed=R.min_speed,
        position_noise=R.position_noise,
        hac_lag=lag,
        acceleration_noise_ratio=R.accel_noise_ratio,
        notes=notes,
        units=dict(_UNITS, **(_DIRECTION_UNITS if direction is not None else {})),
        direction_params=direction,
        direction_std_errors=({k: se[k] for k in DIRECTION_PARAMETER_NAMES} if direction is not None else None),
        bic=float(bic),
    )


def identify_slider_measured(data: Any, **options: Any) -> SliderIdentification:
    """:func:`identify_slider` on a :class:`hydro_envs.data.MeasuredData` of plant ``slider``.

    Needs channels ``f`` [N] and ``x`` [m] and a uniform time axis: sample-time jitter up to
    1e-3 of the median step (a logger's clock) is accepted and the median step used.
    """
    if getattr(data, "plant", None) not in (None, "slider"):
        raise SliderIdentificationError(f"measured data are for plant {data.plant!r}, not 'slider'")
    for ch in ("f", "x"):
        if ch not in data:
            raise SliderIdentificationError(f"measured data lack channel {ch!r} (need f [N] and x [m])")
    t = np.asarray(data.t, dtype=np.float64)
    steps = np.diff(t)
    dt = float(np.median(steps))
    if not np.all(np.abs(steps - dt) <= JITTER_TOLERANCE * dt):
        j = int(np.argmax(np.abs(steps - dt)))
        raise SliderIdentificationError(
            f"time axis is not uniform: step {steps[j]!r} s at sample {j + 1} vs median {dt!r} s "
            f"(more than {JITTER_TOLERANCE:g} relative: a gap or a changed rate); split or resample the record"
        )
    return identify_slider(data["f"], data["x"], dt, **options)
