r"""Measured records for the diagnosis workflow: checks, segmentation, state estimates.

A :class:`Record` is one uniformly sampled experiment (input channels and whatever output
channels were measured). :func:`record_from_measured` converts a
:class:`hydro_envs.data.measured.MeasuredData` file (resampling a non-uniform time base onto
its median step, with a note), :func:`check_records` says clearly when records cannot support a
conclusion (missing channels, too short, too little excitation), and :func:`segments` cuts
records into the short free-run windows the workflow fits and scores: each window starts from
the state estimated from the measurements (position and pressures as measured, velocity from a
Savitzky-Golay derivative of the position, unmeasured states quasi-static), so closed-loop data
of an integrating plant can be replayed open-loop without drifting away.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import signal

from identification.diagnosis.plants import DiagnosisPlant
from identification.greybox import Experiment

__all__ = ["DiagnosisError", "DiagnosisDataError", "DiagnosisFitError", "Record", "record_from_measured", "check_records", "segments",
           "velocity_estimate", "shifted"]


class DiagnosisError(ValueError):
    """The diagnosis cannot reach a verdict (the message says why and what is needed)."""

    exit_code = 1  # the command line's code for data that cannot give a result (hydro_envs.cli_errors)


class DiagnosisDataError(DiagnosisError):
    """The data cannot support a diagnosis (the message says why and what is needed)."""


class DiagnosisFitError(DiagnosisError):
    """The base model cannot be fitted to the data: its fit or its free run on the windows is not
    finite (the message names the channel, the windows and the base model's parameters)."""


@dataclasses.dataclass
class Record:
    """One uniformly sampled record: ``inputs (n, n_inputs)``, measured ``channels``."""

    dt: float
    inputs: np.ndarray
    channels: dict[str, np.ndarray]
    name: str = ""
    notes: list[str] = dataclasses.field(default_factory=list)

    def __post_init__(self) -> None:
        self.inputs = np.asarray(self.inputs, dtype=float)
        if self.inputs.ndim == 1:
            self.inputs = self.inputs[:, None]
        n = self.inputs.shape[0]
        for k, v in self.channels.items():
            v = np.asarray(v, dtype=float)
            if v.shape != (n,):
                raise DiagnosisDataError(f"record {self.name!r}: channel {k!r} has {v.shape} samples, inputs {n}")
            if not np.all(np.isfinite(v)):
                raise DiagnosisDataError(f"record {self.name!r}: channel {k!r} has NaN/inf values")
            self.channels[k] = v
        if not np.all(np.isfinite(self.inputs)):
            raise DiagnosisDataError(f"record {self.name!r}: the input has NaN/inf values")
        if not (self.dt > 0 and math.isfinite(self.dt)):
            raise DiagnosisDataError(f"record {self.name!r}: sample time {self.dt} must be > 0")

    @property
    def n(self) -> int:
        return int(self.inputs.shape[0])

    @property
    def duration(self) -> float:
        return (self.n - 1) * self.dt

    def split(self, fraction: float) -> tuple[Record, Record]:
        """(first ``fraction``, rest) of the record (for a held-out tail)."""
        k = int(round(fraction * self.n))
        a = Record(self.dt, self.inputs[:k], {c: v[:k] for c, v in self.channels.items()}, self.name + "[fit]")
        b = Record(self.dt, self.inputs[k:], {c: v[k:] for c, v in self.channels.items()}, self.name + "[held-out]")
        return a, b


def record_from_measured(data, spec: DiagnosisPlant) -> Record:
    """A :class:`Record` from a measured-data file of the plant; resamples a non-uniform time
    base onto the median step (noted). Missing input or position channels raise."""
    missing = [c for c in spec.required if c not in data]
    if missing:
        raise DiagnosisDataError(
            f"{data.metadata.get('name', 'record')}: missing channel(s) {missing}; the diagnosis of "
            f"{spec.name} needs {list(spec.required)} and uses {sorted(spec.outputs) + sorted(spec.derivative_outputs)} "
            "when present")
    t = np.asarray(data.t, dtype=float)
    if t.size < 3:
        raise DiagnosisDataError(f"record has {t.size} samples; need many more")
    dt = float(np.median(np.diff(t)))
    notes = []
    chans = {c: np.asarray(data[c], dtype=float) for c in list(spec.outputs) + list(spec.derivative_outputs) if c in data}
    u = np.column_stack([np.asarray(data[c], dtype=float) for c in spec.inputs])
    if np.max(np.abs(np.diff(t) - dt)) > 1e-6 * dt:
        tu = t[0] + dt * np.arange(int(math.floor((t[-1] - t[0]) / dt)) + 1)
        chans = {c: np.interp(tu, t, v) for c, v in chans.items()}
        u = np.column_stack([np.interp(tu, t, u[:, j]) for j in range(u.shape[1])])
        notes.append(f"non-uniform time base resampled onto its median step {dt:.3g} s")
    return Record(dt, u, chans, str(data.metadata.get("name", "")), notes)


#: Savitzky-Golay velocity estimate: polynomial order and window [s]. Quartic over 40 ms has the
#: white-noise gain of the quadratic over 20 ms it replaced (0.033 against 0.036 at 1 kHz) and no
#: bias from jerk: a window start in a stick-slip transient (independent axis record, 16 N /
#: 2 mm/s Stribeck friction) got -45.0 mm/s for about -47.4 from the quadratic, and the true
#: model's free run stuck where the axis slid (that window's weighted cost 4700 against ~0.01)
VELOCITY_ORDER, VELOCITY_WINDOW = 4, 0.04


def velocity_estimate(x: np.ndarray, dt: float) -> np.ndarray:
    """Velocity [m/s] from a sampled position: Savitzky-Golay first derivative
    (:data:`VELOCITY_ORDER` over :data:`VELOCITY_WINDOW`)."""
    w = max(VELOCITY_ORDER + 3, int(round(VELOCITY_WINDOW / dt)) | 1)
    if x.size < w + 2:
        return np.gradient(x, dt)
    return signal.savgol_filter(x, w, VELOCITY_ORDER, deriv=1, delta=dt)


def shifted(x: np.ndarray, dt: float, delay: float) -> np.ndarray:
    """``x(t + delay)``: a measurement delayed by ``delay`` moved back onto the model's time
    (linear interpolation; the last samples are held)."""
    n = x.size
    t = dt * np.arange(n)
    return np.interp(t + delay, t, x)


# white-noise gain of the 5-point cubic Savitzky-Golay residual (1 - the smoother's centre weight 17/35)
_SG_RESIDUAL_GAIN = math.sqrt(1 - 17 / 35)
# median absolute deviation of a normal variable over its standard deviation (Phi^-1(3/4))
_MAD_PER_SIGMA = 0.6744897501960817
# a channel counts as quantised when this share of its non-zero sample-to-sample changes are whole
# multiples of the smallest one (to QUANTUM_TOL of it)
QUANTISED_SHARE, QUANTUM_TOL = 0.99, 1e-3


def quantum(x: np.ndarray) -> float:
    """The resolution of a quantised channel (an encoder count, an ADC step): the smallest
    non-zero change between samples when nearly every change is a whole multiple of it
    (``QUANTISED_SHARE``); 0 for a channel that is not quantised (or hardly moves)."""
    d = np.abs(np.diff(np.asarray(x, dtype=float)))
    d = d[d > 0]
    if d.size < 20:
        return 0.0
    q = float(d.min())
    k = d / q
    return q if float(np.mean(np.abs(k - np.round(k)) <= QUANTUM_TOL)) >= QUANTISED_SHARE else 0.0


def noise_estimate(x: np.ndarray) -> float:
    """White measurement-noise level (standard deviation) of a sampled signal, robust to its
    deterministic content. The residual of a 5-point cubic Savitzky-Golay smoother passes the
    signal below ~1/6 of the sample rate and white noise with the gain sqrt(1 - 17/35) = 0.717;
    its spread is taken as the median absolute deviation (1.4826 MAD = sigma for normal noise),
    so the few samples at a step of the reference, the controller's reaction to it or an end
    stop -- large residuals, but deterministic -- do not count as noise (a standard deviation
    counted a controller's force steps as 1.0-1.5 N of noise on a record with none, issue 56).
    A quantised channel's level is at least its quantisation noise q / sqrt(12): a MAD of a
    staircase that mostly rests is 0, but the sensor cannot resolve below its count."""
    x = np.asarray(x, dtype=float)
    if x.size < 7:
        return float(np.std(x))
    r = x - signal.savgol_filter(x, 5, 3)
    mad = float(np.median(np.abs(r - np.median(r))))
    return max(mad / _MAD_PER_SIGMA / _SG_RESIDUAL_GAIN, quantum(x) / math.sqrt(12.0))


def check_records(records: Sequence[Record], spec: DiagnosisPlant, *, role: str = "data",
                  min_segments: int = 2) -> list[str]:
    """Raise :class:`DiagnosisDataError` when the records cannot support a conclusion; return
    notes on what is usable."""
    notes = []
    if not records:
        raise DiagnosisDataError(f"{role}: no records given")
    total = 0
    pos = spec.position_channel
    for r in records:
        if pos not in r.channels:
            raise DiagnosisDataError(f"{role} {r.name!r}: no position channel {pos!r}")
        nseg = int(r.duration // spec.segment_seconds)
        total += nseg
        x = r.channels[pos]
        span = float(np.ptp(x))
        noise = noise_estimate(x)
        if span < 50 * max(noise, 1e-12) or span == 0.0:
            raise DiagnosisDataError(
                f"{role} {r.name!r}: too little excitation: position spans {span:.3g} m, only "
                f"{span / max(noise, 1e-300):.0f} x its noise ({noise:.2g} m); need >= 50 x (move the actuator)")
        v = velocity_estimate(x, r.dt)
        vmax = float(np.max(np.abs(v)))
        rev = int(np.sum(np.diff(np.sign(v[np.abs(v) > 0.05 * vmax])) != 0))
        if rev < 2:
            raise DiagnosisDataError(
                f"{role} {r.name!r}: too little excitation: {rev} velocity reversal(s); need motion in "
                "both directions (friction and leakage effects are direction-dependent)")
        if float(np.std(r.inputs)) == 0.0:
            raise DiagnosisDataError(f"{role} {r.name!r}: the input is constant")
        have = [c for c in list(spec.outputs) + list(spec.derivative_outputs) if c in r.channels]
        absent = [c for c in list(spec.outputs) + list(spec.derivative_outputs) if c not in r.channels]
        if absent:
            notes.append(f"{role} {r.name!r}: channels {absent} not measured; effects seen mainly in them "
                         f"are harder to separate (measured: {have})")
    if total < min_segments:
        need = min_segments * spec.segment_seconds
        have_s = sum(r.duration for r in records)
        raise DiagnosisDataError(
            f"{role}: too short: {have_s:.2f} s gives {total} window(s) of {spec.segment_seconds} s; "
            f"need >= {need:.1f} s")
    return notes


def smoothed(x: np.ndarray, dt: float) -> np.ndarray:
    """Savitzky-Golay smoothing over ~20 ms (start values of windows: noise-reduced)."""
    w = max(5, int(round(0.02 / dt)) | 1)
    if x.size < w + 2:
        return x
    return signal.savgol_filter(x, w, 2)


def segments(records: Sequence[Record], spec: DiagnosisPlant, *, delay: float = 0.0,
             delayed_channels: Sequence[str] = (), seconds: float | None = None,
             warmup: float | None = None) -> list[Experiment]:
    """Free-run windows (greybox experiments) tiling each record in steps of ``seconds``
    (default ``spec.segment_seconds``). Each window starts ``warmup`` (default
    ``spec.warmup_seconds``) earlier from the state estimated from the (delay-corrected,
    smoothed) measurements and the unmeasured states the record implies for the parameters
    simulated (``spec.hidden_states``); the warm-up samples have weight 0, so the transient of
    an imperfect start state (unmeasured valve state, velocity estimate) is not scored."""
    seconds = spec.segment_seconds if seconds is None else seconds
    warmup = spec.warmup_seconds if warmup is None else warmup
    exps = []
    for i_rec, r in enumerate(records):
        chans = dict(r.channels)
        if delay > 0:
            for c in delayed_channels:
                if c in chans:
                    chans[c] = shifted(chans[c], r.dt, delay)
        v = velocity_estimate(chans[spec.position_channel], r.dt)
        smooth = {c: smoothed(a, r.dt) for c, a in chans.items()}
        m = max(3, int(round(seconds / r.dt)))
        kw = int(round(warmup / r.dt))
        trim = int(math.ceil(delay / r.dt)) if delay > 0 else 0
        n_use = r.n - trim
        hidden = _HiddenTrack(spec, smooth, r.inputs, r.dt) if spec.hidden_states is not None else None
        for k1 in range(kw, n_use - m + 1, m):
            k0 = k1 - kw
            sl = slice(k0, k1 + m)
            start = {c: float(smooth[c][k0]) for c in smooth}
            start["v"] = float(v[k0])
            start["u"] = float(r.inputs[k0, 0])
            w = np.ones(kw + m)
            w[:kw] = 0.0
            outs = {c: chans[c][sl] for c in chans}
            for c in spec.offset_free:  # compared without the window mean (see plants.py)
                if c in outs:
                    outs[c] = outs[c] - outs[c][kw:].mean()
            u = r.inputs[sl]
            if u.shape[1] < spec.kernel_inputs:  # kernel inputs beyond the measured ones are 0
                u = np.hstack([u, np.zeros((u.shape[0], spec.kernel_inputs - u.shape[1]))])
            exps.append(Experiment(
                dt=r.dt, u=u, y0=_initial(spec, start, hidden, k0),
                outputs=outs, name=f"{r.name}@{k1 * r.dt:.2f}s", weights=w, group=f"record {i_rec}"))
    return exps


class _HiddenTrack:
    """``spec.hidden_states`` of one record, evaluated per parameter set (the last few kept: a
    fit asks for the same set once per window)."""

    def __init__(self, spec: DiagnosisPlant, channels: Mapping[str, np.ndarray], inputs: np.ndarray,
                 dt: float, keep: int = 16) -> None:
        self.spec, self.channels, self.inputs, self.dt, self.keep = spec, channels, inputs, dt, keep
        self.cache: dict[bytes, Mapping[str, np.ndarray]] = {}

    def __call__(self, params) -> Mapping[str, np.ndarray]:
        key = np.asarray(params.to_array(), dtype=np.float64).tobytes()
        got = self.cache.get(key)
        if got is None:
            got = self.spec.hidden_states(params, self.channels, self.inputs, self.dt)
            if len(self.cache) >= self.keep:
                self.cache.pop(next(iter(self.cache)))
            self.cache[key] = got
        return got


def _initial(spec: DiagnosisPlant, start: Mapping[str, float], hidden: _HiddenTrack | None = None, k0: int = 0):
    def y0(params):
        if hidden is None:
            return spec.initial_state(params, start)
        return spec.initial_state(params, {**start, **{k: float(v[k0]) for k, v in hidden(params).items()}})
    return y0
