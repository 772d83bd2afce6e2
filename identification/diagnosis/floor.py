r"""Noise floor of the held-out residual, the residual of a model in channel units, and where a
residual above the floor remains.

The held-out score compares a model's free run with the measurements after low-passing the
error at the plant's ``score_bandwidth`` (:func:`~identification.diagnosis.fitting._nrmse`).
What no model can remove from that error is the measurement noise inside the band, plus --
when a measured input drives the simulation -- the spread that the input's own noise causes.
Both are estimated from the data, per output channel, in the channel's unit::

    sensor   = sigma_y * g                 sigma_y: white-noise level of the measured channel
                                           (records.noise_estimate: the median absolute deviation
                                           of the residual of a 5-point cubic Savitzky-Golay
                                           smoother, which passes the signal below ~fs/6, over its
                                           white-noise gain; at least q/sqrt(12) on a channel
                                           quantised in steps q), pooled over the held-out records;
                                           g: RMS of unit white noise after the score's low-pass
                                           (computed, not assumed)
    input    = fitting.input_noise_floor   (0 when every input is commanded, i.e. exact; the
                                           input's level by the same robust estimate)
    floor    = sqrt(sensor^2 + input^2)
    threshold = unexplained_factor * floor (the verdict's bar, reported per channel)

The median, not the standard deviation, separates the noise from the deterministic excitation:
a step of the reference and the controller's reaction to it leave large smoother residuals at a
few samples only (a standard deviation made 1.0-1.5 N of "noise" of a slider's noise-free force
record, a position floor of 47-236 um instead of ~0.3 um, issue 56).

A model's held-out residual (:func:`heldout_rms`) is the RMS of the same band-limited error over
the scored samples of the held-out windows, in the same unit; ``residual / floor`` is how many
floors of mismatch remain (1: the model explains everything the sensors can resolve).

:func:`where_mismatch` says where the remaining residual of a model sits: the channel with the
largest ratio, the operating region (direction of motion x slow/fast, split at the median speed;
motion of the plant's position channel, a force for the force actuator) where its RMS is largest, and the frequency band that holds most of its power above the noise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import signal

from identification.diagnosis.fitting import _band_limited, _error_sums, _simulate, input_noise_floor, rms_of_sums
from identification.diagnosis.models import Model, _scored
from identification.diagnosis.plants import DiagnosisPlant
from identification.diagnosis.records import Record, noise_estimate, velocity_estimate

__all__ = ["UNEXPLAINED_FACTOR", "BANDS", "noise_floor", "heldout_rms", "where_mismatch"]

# Verdict ``unexplained``: after the best catalogue effect(s) the held-out residual of some
# channel stays above UNEXPLAINED_FACTOR times its noise floor. Set between the ratios correct
# models reach and those off-catalogue effects leave (measured, docs/history/diagnosis_bench_2026-11.md "Noise
# floor"): the project's hidden-effect records, correct model 0.01-0.9 floors; the independent
# rigid-axis records, correct model 1.2 floors, 5.0 with 1 um of 50 Hz hum on the encoder (the
# hum biases the start-state velocity estimate of every window, which the white-noise floor does
# not count); mechanical backlash on those records, 328 floors. Plants whose correct models leave
# more (start-state errors of stiff or slow plants) set their own ``unexplained_factor`` in their
# diagnosis settings; this is the default.
UNEXPLAINED_FACTOR = DiagnosisPlant.__dataclass_fields__["unexplained_factor"].default

# how the floor's white-noise levels are estimated (reported with the floor)
ESTIMATOR = ("robust: 1.4826 x median absolute deviation of the 5-point cubic Savitzky-Golay residual "
             "(steps and the controller's reaction are not noise), at least q/sqrt(12) when quantised")

# frequency bands [Hz] of the mismatch report (upper edge inf: up to the Nyquist frequency)
BANDS = ((0.0, 1.0), (1.0, 5.0), (5.0, 20.0), (20.0, 50.0), (50.0, math.inf))


def _band_gain(n: int, dt: float, band: float) -> float:
    """RMS of unit white noise after the score's zero-phase low-pass at ``band`` Hz (window of
    ``n`` samples; a fixed seed, so the floor is reproducible)."""
    w = np.random.default_rng(12345).standard_normal(max(n, 64))
    return float(np.sqrt(np.mean(_band_limited(w, dt, band) ** 2)))


def noise_floor(spec: DiagnosisPlant, model: Model, records: Sequence[Record]) -> dict[str, dict[str, Any]]:
    """Per measured output channel of ``records``: ``sensor_noise`` (white-noise level sigma_y),
    ``sensor`` (its part inside the score band), ``input`` (spread from the noise of measured
    inputs through ``model``), ``floor`` (their root sum of squares), ``threshold`` (the plant's
    ``unexplained_factor`` times the floor: the verdict's bar in the channel's unit), ``unit``
    and ``estimator`` (how the noise levels were estimated)."""
    chans = [k for k in list(spec.outputs) + list(spec.derivative_outputs) if any(k in r.channels for r in records)]
    inp = input_noise_floor(spec, model, records)
    n_win = max(16, int(round((spec.segment_seconds + spec.warmup_seconds) / records[0].dt)))
    g = _band_gain(n_win, records[0].dt, spec.score_bandwidth)
    out = {}
    for k in chans:
        parts = [(noise_estimate(r.channels[k]), r.n) for r in records if k in r.channels]
        s = math.sqrt(sum(v * v * n for v, n in parts) / sum(n for _, n in parts))
        i = float(inp.get(k, 0.0))
        fl = math.sqrt((s * g) ** 2 + i * i)
        out[k] = {"unit": spec.units.get(k, ""), "sensor_noise": s, "sensor": s * g, "input": i,
                  "floor": fl, "threshold": spec.unexplained_factor * fl, "estimator": ESTIMATOR}
    return out


def _errors(spec: DiagnosisPlant, models: Sequence[Model], records: Sequence[Record]):
    """Per model: (experiments, per window {channel: band-limited error over the scored samples})."""
    out = []
    for exps, outs in _simulate(spec, models, records):
        wins = []
        for e, o in zip(exps, outs):
            sel = _scored(e)
            wins.append({k: _band_limited(e.outputs[k][sel] - v[sel], e.dt, spec.score_bandwidth)
                         for k, v in o.items()})
        out.append((exps, wins))
    return out


def heldout_rms(spec: DiagnosisPlant, models: Sequence[Model], records: Sequence[Record]) -> list[dict[str, float]]:
    """Per model: the RMS per channel [channel unit] of the band-limited free-run error over the
    scored samples of the windows of ``records`` (``inf`` when the free run is not finite)."""
    return [rms_of_sums(*_error_sums(exps, outs, spec.score_bandwidth)[::2])
            for exps, outs in _simulate(spec, models, records)]


def ratios(rms: dict[str, float], floor: dict[str, dict[str, Any]]) -> dict[str, float]:
    """Residual over noise floor per channel (channels with a zero floor are left out)."""
    return {k: rms[k] / floor[k]["floor"] for k in rms if k in floor and floor[k]["floor"] > 0}


def where_mismatch(spec: DiagnosisPlant, model: Model, records: Sequence[Record],
                   floor: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Where ``model``'s held-out residual stays above the floor: the channel with the largest
    residual/floor ratio, that channel's RMS residual [unit and floors] per operating region
    (direction of motion x speed below/above the median speed, from the measured position), the
    region with the largest RMS, and the share of the residual power above the white-noise floor
    in each of :data:`BANDS` with the band holding most of it."""
    ((exps, wins),) = _errors(spec, [model], records)
    sums: dict[str, float] = {}
    counts: dict[str, int] = {}
    for w in wins:  # the pooled RMS of heldout_rms, from this one free run
        for k, err in w.items():
            sums[k] = sums.get(k, 0.0) + float(np.sum(err**2))
            counts[k] = counts.get(k, 0) + err.size
    rms = rms_of_sums(sums, counts)
    rat = ratios(rms, floor)
    if not rat:
        return {}
    ch = max(rat, key=rat.get)
    fl = floor[ch]["floor"]
    err, vel = [], []
    for e, w in zip(exps, wins):
        if ch not in w:
            continue
        sel = _scored(e)
        err.append(w[ch])
        vel.append(velocity_estimate(e.outputs[spec.position_channel], e.dt)[sel])
    r, v = np.concatenate(err), np.concatenate(vel)
    vm = float(np.median(np.abs(v)))
    regions = {}
    for name, m in (("moving +, slow", (v > 0) & (np.abs(v) <= vm)), ("moving +, fast", (v > 0) & (np.abs(v) > vm)),
                    ("moving -, slow", (v <= 0) & (np.abs(v) <= vm)), ("moving -, fast", (v <= 0) & (np.abs(v) > vm))):
        if m.sum() >= 20:
            x = float(np.sqrt(np.mean(r[m] ** 2)))
            regions[name] = {"rms": x, "floors": x / fl, "share_of_samples": float(m.mean())}
    worst = max(regions, key=lambda k: regions[k]["rms"]) if regions else ""
    # spectrum of the raw (not band-limited) residual; the white-noise floor's PSD removed
    dt = exps[0].dt
    raw = []
    ((_, outs),) = _simulate(spec, [model], records)
    for e, o in zip(exps, outs):
        if ch in o:
            d = (e.outputs[ch] - o[ch])[_scored(e)]
            raw.append(d - d.mean())
    bands = {}
    x = np.concatenate(raw) if raw else np.zeros(0)
    if x.size >= 64 and np.all(np.isfinite(x)):
        f, p = signal.welch(x, fs=1 / dt, nperseg=min(1024, x.size))
        noise_psd = 2 * dt * floor[ch]["sensor_noise"] ** 2  # one-sided PSD of white noise
        excess = np.maximum(p - noise_psd, 0.0)
        total = float(np.sum(excess)) or 1.0
        for lo, hi in BANDS:
            m = (f >= lo) & (f < hi)
            label = f"{lo:g}-{hi:g} Hz" if math.isfinite(hi) else f">= {lo:g} Hz"
            bands[label] = float(np.sum(excess[m]) / total)
    band = max(bands, key=bands.get) if bands else ""
    pos_unit = spec.units.get(spec.position_channel, "")
    return {"channel": ch, "unit": floor[ch]["unit"], "ratio": rat[ch], "rms": rms[ch], "floor": fl,
            "median_speed": vm, "speed_unit": f"{pos_unit}/s" if pos_unit else "", "regions": regions, "worst_region": worst, "bands": bands, "worst_band": band}
