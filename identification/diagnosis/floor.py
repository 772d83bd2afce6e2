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

The verdict's bar is per channel and adapts to the record (:func:`noise_floor` reports every part)::

    start_state = start_state_part         the prediction's change when the channels that set the
                                           windows' start states carry fresh noise and mains lines
    lines       = line_part(mains_lines)   mains pickup (50/60 Hz and harmonics) found in the base
                                           model's residual, its RMS inside the score band
    expected    = sqrt(1 + (start_state/floor)^2 + (lines/floor)^2)   floors a correct model leaves
    spread      = 1 + 3 / sqrt(2 N_eff)    pure-noise RMS spread over N_eff independent scored samples
    factor      = max(unexplained_factor, 2 * expected * spread)       [noise floors]
    threshold   = factor * floor           (in the channel's unit)

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

__all__ = ["UNEXPLAINED_FACTOR", "THRESHOLD_MARGIN", "BANDS", "noise_floor", "heldout_rms", "where_mismatch",
           "threshold_factor", "spread_factor", "over_threshold", "factors", "mains_lines", "start_state_part"]

# Minimum of the threshold of verdict ``unexplained`` [noise floors]: the plant's
# ``unexplained_factor``. Set between the ratios correct models reach and those off-catalogue
# effects leave (measured, docs/history/diagnosis_bench_2026-11.md "Noise floor"): the project's
# hidden-effect records, correct model 0.01-0.9 floors; the independent rigid-axis records, correct
# model 1.2 floors, 5.0 with 1 um of 50 Hz hum on the encoder (the hum biases the start-state
# velocity estimate of every window); mechanical backlash on those records, 328 floors. Plants whose
# correct models leave more (start-state errors of stiff or slow plants, parameter errors of
# integrating plants) set their own ``unexplained_factor`` in their diagnosis settings; this is the
# default. The record raises the threshold above it when a correct model is expected to leave more
# on it (:func:`threshold_factor`).
UNEXPLAINED_FACTOR = DiagnosisPlant.__dataclass_fields__["unexplained_factor"].default

# the threshold is THRESHOLD_MARGIN times what a correct model is expected to leave: the rule the
# plants' own factors follow ("twice the largest residual a correct model left":
# hydro_envs/plants/ls_compensator/diagnosis.py, rodless_cylinder/diagnosis.py)
THRESHOLD_MARGIN = 2.0
# one-sided normal quantile of the pure-noise RMS spread the threshold allows (assumed: 3 standard
# deviations, a 0.13 % chance that noise alone reads above the expected residual)
SPREAD_Z = 3.0
# realisations of the start-state Monte Carlo (assumed: 3 batched runs; the part pools their
# squares over every held-out window, so its own relative spread is ~1/sqrt(6 x windows))
START_REALISATIONS = 3
# mains pickup: the narrow-band disturbance of measuring cables (50 Hz and 60 Hz grids and their
# harmonics; IEC 60038 nominal frequencies). Lines at other frequencies are the excitation or the
# plant's response, i.e. evidence about the model, and are never counted as noise
MAINS_HZ = (50.0, 60.0)
# a mains line is present when its power in the residual is LINE_RATIO times the median power at
# nearby frequencies (assumed: 10 dB above the local background; a white-noise bin, chi-square with
# 2 degrees of freedom, exceeds 10 times its mean with probability e^-10)
LINE_RATIO = 10.0
# the local background: frequencies f +- k / T_window for these k (assumed: 2-6 bins either side,
# clear of the line's own leakage over a rectangular window, within a few Hz of it)
LINE_BACKGROUND_BINS = (2, 3, 4, 5, 6)

THRESHOLD_RULE = (f"factor = max(plant minimum, {THRESHOLD_MARGIN:g} x expected x spread); expected = "
                  "sqrt(1 + start_state^2 + lines^2) floors (a correct model: the noise floor, the start-state "
                  "error the noise and mains lines cause, the lines' in-band power); spread = 1 + "
                  f"{SPREAD_Z:g}/sqrt(2 N_eff) (pure-noise RMS over N_eff independent scored samples)")


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


def correlation_length(n: int, dt: float, band: float) -> float:
    """Samples per independent sample of white noise after the score's low-pass at ``band`` Hz:
    sum over lags of the squared autocorrelation coefficient (1 without a low-pass). The variance
    of a mean square over ``N`` samples is that of ``N / correlation_length`` independent ones."""
    w = np.random.default_rng(12345).standard_normal(max(n, 4096))
    y = _band_limited(w, dt, band)
    f = np.fft.rfft(y - y.mean(), 2 * y.size)
    acf = np.fft.irfft(np.abs(f) ** 2)[: y.size]
    rho = acf / acf[0]
    lags = min(y.size // 4, 1 + int(10 / max(band * dt, 1e-12)))  # 10 periods of the band edge
    return float(max(1.0, rho[0] ** 2 + 2 * np.sum(rho[1:lags] ** 2)))


def spread_factor(n_eff: float, z: float = SPREAD_Z) -> float:
    """Upper bound of a pure-noise RMS over its expected value: the chi distribution with
    ``n_eff`` degrees of freedom has relative standard deviation ~ 1/sqrt(2 n_eff)."""
    return 1.0 + z / math.sqrt(2.0 * max(n_eff, 1.0))


def threshold_factor(minimum: float, expected: float, spread: float, margin: float = THRESHOLD_MARGIN) -> float:
    """The verdict's threshold in noise floors: ``margin`` times the residual a correct model is
    expected to leave on the record (``expected`` floors, up to its noise ``spread``), at least
    the plant's ``minimum``."""
    return max(minimum, margin * expected * spread)


def _window_residuals(spec: DiagnosisPlant, model: Model, records: Sequence[Record]):
    """Experiments, predicted outputs and, per window, {channel: (scored residual, scored
    prediction)} of ``model`` on ``records`` (raw, not band-limited)."""
    ((exps, outs),) = _simulate(spec, [model], records)
    res = []
    for e, o in zip(exps, outs):
        sel = _scored(e)
        res.append({k: (e.outputs[k][sel] - v[sel], v[sel]) for k, v in o.items()})
    return exps, outs, res


def _line_power(x: np.ndarray, f: float, dt: float) -> float:
    """Squared amplitude of the sinusoid at ``f`` Hz in ``x``: projection of the linearly detrended
    series on cos and sin under a Hann window (its leakage of the slow motion falls off fast)."""
    t = dt * np.arange(x.size)
    w = np.hanning(x.size)
    d = signal.detrend(x) * w
    a = 2.0 / float(np.sum(w)) * float(np.dot(d, np.cos(2 * np.pi * f * t)))
    b = 2.0 / float(np.sum(w)) * float(np.dot(d, np.sin(2 * np.pi * f * t)))
    return a * a + b * b


def mains_lines(windows: Sequence[tuple[np.ndarray, np.ndarray]], dt: float) -> list[tuple[float, float]]:
    """Mains lines (:data:`MAINS_HZ` and harmonics below 0.45/dt) in a model's residual over the
    scored ``windows`` of one channel (pairs of residual and prediction): ``(Hz, amplitude)`` of
    each line whose window-averaged power exceeds ``LINE_RATIO`` times the median at nearby
    frequencies (the background's power removed), unless the prediction has a line there too that
    is stronger than the mismatch's (a frequency the model reproduces is excitation, not pickup).
    Windows shorter than 3 periods of a line are not used for it."""
    out = []
    nyq = 0.45 / dt
    for base in MAINS_HZ:
        for h in range(1, int(nyq // base) + 1):
            f = base * h
            line, pred, bg, bg_p, used = 0.0, 0.0, [], [], 0
            for r, p in windows:
                T = r.size * dt
                if T * f < 3 or f - LINE_BACKGROUND_BINS[-1] / T <= 0:
                    continue
                near = [f + s * k / T for k in LINE_BACKGROUND_BINS for s in (-1, 1)]
                line += _line_power(r, f, dt)
                pred += _line_power(p, f, dt)
                bg.append([_line_power(r, x, dt) for x in near])
                bg_p.append([_line_power(p, x, dt) for x in near])
                used += 1
            if not used:
                continue
            line, pred = line / used, pred / used
            back = float(np.median(np.mean(bg, axis=0)))
            excitation = pred > LINE_RATIO * float(np.median(np.mean(bg_p, axis=0))) and pred > line
            if line > LINE_RATIO * back and not excitation:
                out.append((f, math.sqrt(line - back)))
    return out


def _perturbed(records: Sequence[Record], levels: Sequence[dict[str, float]],
               lines: dict[str, list[tuple[float, float]]], rng: np.random.Generator) -> list[Record]:
    """Copies of ``records`` whose channels carry a fresh white noise of their level (``levels``
    per record) and the mains ``lines`` at random phases."""
    out = []
    for r, lv in zip(records, levels):
        t = r.dt * np.arange(r.n)
        ch = {}
        for k, v in r.channels.items():
            x = v + lv.get(k, 0.0) * rng.standard_normal(r.n)
            for f, a in lines.get(k, []):
                x = x + a * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
            ch[k] = x
        out.append(Record(r.dt, r.inputs, ch, r.name))
    return out


def start_state_part(spec: DiagnosisPlant, model: Model, records: Sequence[Record], levels: Sequence[dict[str, float]],
                     lines: dict[str, list[tuple[float, float]]], clean_outs: Sequence[dict[str, np.ndarray]],
                     tracked: dict[str, set[int]] | None = None, seed: int = 1) -> dict[str, float]:
    """Per output channel: the band-limited RMS change of ``model``'s free-run prediction over the
    scored samples when the measured channels that set every window's start state (and the hidden
    states the record implies) carry a fresh realisation of their white noise (``levels`` per
    record) and of the mains ``lines`` (random phases): what estimating the start states from
    these records costs a correct model (the estimate is linear in the noise, so the change has
    the distribution of the estimate's own error). ``clean_outs``: the predictions on the windows
    of ``records``; ``START_REALISATIONS`` realisations in one batched run. ``tracked``: per
    channel, the windows (indices) counted (None: all)."""
    rng = np.random.default_rng(seed)
    copies = [c for _ in range(START_REALISATIONS) for c in _perturbed(records, levels, lines, rng)]
    ((exps, outs),) = _simulate(spec, [model], copies)
    num: dict[str, float] = {}
    cnt: dict[str, int] = {}
    for i, (e, o) in enumerate(zip(exps, outs)):  # each realisation: the same windows, in order
        sel = _scored(e)
        clean = clean_outs[i % len(clean_outs)]
        for k, v in o.items():
            if tracked is not None and i % len(clean_outs) not in tracked.get(k, set()):
                continue
            d = _band_limited(v[sel] - clean[k][sel], e.dt, spec.score_bandwidth)
            num[k] = num.get(k, 0.0) + float(np.sum(d**2))
            cnt[k] = cnt.get(k, 0) + d.size
    return {k: math.sqrt(num[k] / cnt[k]) for k in num if cnt[k]}


def line_part(lines: Sequence[tuple[float, float]], dt: float, band: float) -> float:
    """RMS of the mains ``lines`` (Hz, amplitude) after the score's zero-phase low-pass at
    ``band`` Hz (the squared magnitude of its 2nd-order Butterworth; all-pass without a band)."""
    if not lines:
        return 0.0
    f = np.array([x for x, _ in lines])
    a = np.array([y for _, y in lines])
    if band <= 0 or band >= 0.45 / dt:
        g = np.ones_like(f)
    else:
        b_, a_ = signal.butter(2, band * 2 * dt)
        g = np.abs(signal.freqz(b_, a_, worN=2 * np.pi * f * dt)[1]) ** 2
    return float(np.sqrt(np.sum(0.5 * (a * g) ** 2)))


def _band_rms(x: np.ndarray, dt: float, band: float) -> float:
    """RMS of ``x`` after the score's low-pass (its mean removed)."""
    return float(np.sqrt(np.mean(_band_limited(x - x.mean(), dt, band) ** 2)))


def noise_floor(spec: DiagnosisPlant, model: Model, records: Sequence[Record]) -> dict[str, dict[str, Any]]:
    """Per measured output channel of ``records``, in the channel's ``unit``: ``sensor_noise``
    (white-noise level sigma_y), ``sensor`` (its part inside the score band), ``input`` (spread
    from the noise of measured inputs through ``model``), ``floor`` (their root sum of squares),
    the ``estimator`` of the noise levels, and the verdict's threshold with what it used:
    ``start_state`` (:func:`start_state_part` over the ``tracked_windows`` of ``windows``: those
    where ``model`` leaves at most the plant's minimum factor of floors), ``lines_hz`` / ``lines`` (mains lines found in
    ``model``'s residual, :func:`mains_lines`, and their in-band RMS), ``n_eff`` (independent
    scored samples), ``expected`` (floors a correct model leaves: sqrt(1 + start_state^2 +
    lines^2) in floors), ``spread`` (:func:`spread_factor`), ``minimum_factor`` (the plant's
    ``unexplained_factor``), ``factor`` (:func:`threshold_factor`, in floors) and ``threshold``
    (factor x floor)."""
    chans = [k for k in list(spec.outputs) + list(spec.derivative_outputs) if any(k in r.channels for r in records)]
    inp = input_noise_floor(spec, model, records)
    dt = records[0].dt
    n_win = max(16, int(round((spec.segment_seconds + spec.warmup_seconds) / dt)))
    g = _band_gain(n_win, dt, spec.score_bandwidth)
    levels = [{k: noise_estimate(v) for k, v in r.channels.items()} for r in records]
    exps, clean, res = _window_residuals(spec, model, records)
    lines = {k: mains_lines([w[k] for w in res if k in w], dt) for k in chans}
    floors = {}
    for k in chans:
        parts = [(lv[k], r.n) for r, lv in zip(records, levels) if k in r.channels]
        s = math.sqrt(sum(v * v * n for v, n in parts) / sum(n for _, n in parts))
        i = float(inp.get(k, 0.0))
        floors[k] = (s, i, math.sqrt((s * g) ** 2 + i * i))
    # the start-state cost is measured on the windows the model tracks (at most the plant's
    # minimum factor of floors of band-limited residual): a window the model misses is evidence
    # of a mismatch, and a mismatched model's sensitivity to its start state is no noise
    tracked = {k: {j for j, w in enumerate(res) if k in w and _band_rms(w[k][0], dt, spec.score_bandwidth)
                   <= spec.unexplained_factor * floors[k][2]} for k in chans}
    start = start_state_part(spec, model, records, levels, lines, clean, tracked)
    corr = correlation_length(n_win, dt, spec.score_bandwidth)
    out = {}
    for k in chans:
        s, i, fl = floors[k]
        st, ln = float(start.get(k, 0.0)), line_part(lines[k], dt, spec.score_bandwidth)
        n_sc = sum(int(np.count_nonzero(e.weights > 0)) if e.weights is not None else e.outputs[k].size
                   for e in exps if k in e.outputs)
        n_eff = n_sc / corr
        expected = math.sqrt(1 + (st / fl) ** 2 + (ln / fl) ** 2) if fl > 0 else 1.0
        spread = spread_factor(n_eff)
        factor = threshold_factor(spec.unexplained_factor, expected, spread)
        out[k] = {"unit": spec.units.get(k, ""), "sensor_noise": s, "sensor": s * g, "input": i,
                  "floor": fl, "estimator": ESTIMATOR, "start_state": st, "lines": ln,
                  "tracked_windows": len(tracked[k]), "windows": sum(1 for w in res if k in w),
                  "lines_hz": [f for f, _ in lines[k]], "n_eff": n_eff, "expected": expected, "spread": spread,
                  "minimum_factor": spec.unexplained_factor, "factor": factor, "threshold": factor * fl,
                  "rule": THRESHOLD_RULE}
    return out


def factors(floor: dict[str, dict[str, Any]], default: float = UNEXPLAINED_FACTOR) -> dict[str, float]:
    """The verdict's threshold per channel of ``floor`` [noise floors] (``default`` when a floor
    carries none)."""
    return {k: float(v.get("factor", default)) for k, v in floor.items()}


def over_threshold(left: dict[str, float], floor: dict[str, dict[str, Any]],
                   default: float = UNEXPLAINED_FACTOR) -> dict[str, float]:
    """Held-out residual per channel [noise floors] over that channel's threshold factor: above
    1 in some channel is verdict ``unexplained``."""
    fac = factors(floor, default)
    return {k: v / fac.get(k, default) for k, v in left.items()}


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
    residual/floor ratio relative to its threshold factor, that channel's RMS residual [unit and floors] per operating region
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
    over = over_threshold(rat, floor, spec.unexplained_factor)
    ch = max(over, key=over.get)
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
            "factor": rat[ch] / over[ch],
            "median_speed": vm, "speed_unit": f"{pos_unit}/s" if pos_unit else "", "regions": regions, "worst_region": worst, "bands": bands, "worst_band": band}
