"""Where a fitted model and the data disagree: residual maps, sensor and bound notes, prediction
residuals, the applicable candidates and their signature (score-test) ranking."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import signal

from identification.diagnosis.catalogue import Effect, effect, effects_for
from identification.diagnosis.plants import DiagnosisPlant
from identification.diagnosis.records import Record, velocity_estimate
from identification.diagnosis.models import BASE_FIT_FACTOR, SENSOR_OFFSETS, DRIFT_FLAG, Model, OFFSET_ESTIMATE_FLAG, _scored, present_effects, with_effect
from identification.diagnosis.final_model import on_bound
from identification.diagnosis.fitting import FIT_MAX_SUBSTEP_RATIO, FitOutcome, _simulate

def effect_channels(spec: DiagnosisPlant, name: str, measured: Sequence[str]) -> tuple[str, ...]:
    """The measured channels an effect acts on: a measuring-chain effect (``kind == "sensor"``)
    only the channels it sits on, a physical effect every channel (it changes the dynamics).

    The gap shrink of a named effect is the relative fall of the held-out score over these
    channels. A position-sensor delay leaves the pressure channels untouched by construction;
    with them in the mean the shrink measures their noise floor, not the effect (rodless
    cylinder: the true delay model gives 0.53 over y, pa, pb and 0.9 over y alone)."""
    e = effect(name)
    if e.kind == "sensor":
        chans = tuple(k for k in e.on(spec.name).channels if k in measured)
        if chans:
            return chans
    return tuple(measured)


# ======================================================================================
# locate: residual maps
# ======================================================================================


def residual_maps(spec: DiagnosisPlant, model: Model, records: Sequence[Record], sigma: dict[str, float],
                  n_bins: int = 10) -> dict[str, Any]:
    """Where and when the model disagrees with the records (see the module docstring)."""
    ((exps, outs),) = _simulate(spec, [model], records)
    res = {k: [] for k in sigma}
    feats: dict[str, list] = {"velocity": [], "position": [], "command": []}
    has_dp = "p1" in spec.outputs and "p2" in spec.outputs
    if has_dp:
        feats["pressure_difference"] = []
    t_win, e_win = [], []
    for e, o in zip(exps, outs):
        sel = slice(None) if e.weights is None else e.weights > 0
        x = e.outputs[spec.position_channel]
        feats["velocity"].append(velocity_estimate(x, e.dt)[sel])
        feats["position"].append(x[sel])
        feats["command"].append(e.u[sel, 0])
        if has_dp:
            if "p1" in e.outputs and "p2" in e.outputs:
                feats["pressure_difference"].append((e.outputs["p1"] - e.outputs["p2"])[sel])
            else:
                feats["pressure_difference"].append(np.full(x[sel].size, np.nan))
        energy = 0.0
        for k in sigma:
            r = ((e.outputs[k] - o[k]) / sigma[k])[sel] if k in o else np.full(x[sel].size, np.nan)
            res[k].append(r)
            energy += float(np.nanmean(r**2))
        t_win.append(e.name)
        e_win.append(energy)
    R = {k: np.concatenate(v) for k, v in res.items()}
    F = {k: np.concatenate(v) for k, v in feats.items()}
    maps: dict[str, Any] = {}
    for fname, f in F.items():
        ok = np.isfinite(f)
        if ok.sum() < n_bins * 5:
            continue
        edges = np.unique(np.quantile(f[ok], np.linspace(0, 1, n_bins + 1)))
        centres, rms, mean = [], {k: [] for k in R}, {k: [] for k in R}
        for a, b in zip(edges[:-1], edges[1:]):
            sel = ok & (f >= a) & (f <= b)
            centres.append(float(0.5 * (a + b)))
            for k, r in R.items():
                rr = r[sel]
                rr = rr[np.isfinite(rr)]
                rms[k].append(float(np.sqrt(np.mean(rr**2))) if rr.size else math.nan)
                mean[k].append(float(np.mean(rr)) if rr.size else math.nan)
        maps[fname] = {"bin_centres": centres, "rms": rms, "mean": mean}
    # frequency: residual spectrum over measured spectrum per channel (Welch)
    spectra = {}
    dt = exps[0].dt
    for k in R:
        r = R[k][np.isfinite(R[k])]
        y = np.concatenate([e.outputs[k] - e.outputs[k].mean() for e in exps if k in e.outputs]) / sigma[k]
        if r.size < 64:
            continue
        nper = min(256, r.size)
        f, pr = signal.welch(r, fs=1 / dt, nperseg=nper)
        _, py = signal.welch(y, fs=1 / dt, nperseg=nper)
        spectra[k] = {"frequency": f.tolist(), "residual_over_measured": (pr / np.maximum(py, 1e-300)).tolist()}
    maps["frequency"] = spectra
    order = np.argsort(e_win)[::-1][:3]
    maps["worst_windows"] = [{"window": t_win[i], "mean_square_weighted_residual": float(e_win[i])} for i in order]
    maps["rms_weighted_residual"] = {k: float(np.sqrt(np.nanmean(v**2))) for k, v in R.items()}
    maps["mean_weighted_residual"] = {k: float(np.nanmean(v)) for k, v in R.items()}
    return maps


def mean_weighted_residual(spec: DiagnosisPlant, model: Model, records: Sequence[Record],
                           sigma: dict[str, float]) -> dict[str, tuple[float, float, float]]:
    """Per measured channel, in units of ``sigma``: (mean free-run residual over the scored
    samples of the windows of ``records``, mean of the second half of the windows minus the
    first half, standard deviation of the residual). A persistent mean residual is what a sensor offset leaves, a
    trend what a drift leaves (offset-free channels and estimated offsets are removed by
    construction)."""
    ((exps, outs),) = _simulate(spec, [model], records)
    acc: dict[str, list] = {}
    for e, o in zip(exps, outs):
        sel = _scored(e)
        for k, v in o.items():
            if k in sigma:
                acc.setdefault(k, []).append(((e.outputs[k] - v) / sigma[k])[sel])
    out = {}
    for k, parts in acc.items():
        h = len(parts) // 2
        allr = np.concatenate(parts)
        drift = float(np.mean(np.concatenate(parts[h:])) - np.mean(np.concatenate(parts[:h]))) if h else 0.0
        out[k] = (float(np.mean(allr)), drift, float(np.std(allr)))
    return out


def _sensor_notes(spec: DiagnosisPlant, fit: FitOutcome, records: Sequence[Record], sigma: dict[str, float]) -> list[str]:
    """Notes on sensor offsets and drift after the final model, in noise levels (see
    ``OFFSET_ESTIMATE_FLAG``): the estimated offsets of the ``sensor_offsets`` channels and any
    persistent mean residual above ``OFFSET_ESTIMATE_FLAG`` levels, a drift (mean residual of
    the last half of the windows minus the first half) above ``DRIFT_FLAG`` levels."""
    notes = []
    stats = mean_weighted_residual(spec, fit.model, records, sigma)
    for k, b in (fit.model.offsets or {}).items():
        if k not in stats:
            continue
        noise = stats[k][2] * sigma[k]
        if abs(b) > OFFSET_ESTIMATE_FLAG * noise:
            notes.append(f"channel {k!r}: estimated sensor offset {b:+.4g} ({b / noise:+.1f} noise levels), "
                         f"found as the measuring-chain candidate {SENSOR_OFFSETS!r} -- check the transducer's zero")
    for k, (mean, drift, sd) in stats.items():
        if sd <= 0:
            continue
        if abs(mean) > OFFSET_ESTIMATE_FLAG * sd:
            notes.append(f"channel {k!r}: mean residual {mean / sd:+.2f} noise levels after the final model -- a "
                         "sensor offset or drift the catalogue does not model")
        if abs(drift) > DRIFT_FLAG * sd:
            notes.append(f"channel {k!r}: the mean residual drifts by {drift / sd:+.2f} noise levels between the "
                         "first and the second half of the data -- sensor drift (or a slow effect the catalogue "
                         "does not model)")
    return notes


def _base_bound_notes(model: Model, stage: str) -> list[str]:
    """Base-fit parameters of ``model`` on their refinement bound (:data:`BASE_FIT_FACTOR`)."""
    notes = []
    for n, (lo, hi) in (model.base_bounds or {}).items():
        v = float(getattr(model.params, n))
        if on_bound(v, lo, hi):
            notes.append(f"{stage}: base-fit parameter {n} = {v:.4g} on its bound [{lo:.4g}, {hi:.4g}] "
                         f"({BASE_FIT_FACTOR:g} times the base model's value either way): the base model is far off "
                         "or absorbs an effect it lacks -- if the final model still has it there, give a better base "
                         "model (--base)")
    return notes


def _stiffness_cap_notes(fit: FitOutcome, stage: str) -> list[str]:
    """A note when the fit of ``stage`` was held back from stiffer parameter sets
    (:data:`identification.diagnosis.fitting.FIT_MAX_SUBSTEP_RATIO`): like a parameter on its
    bound, the base model is far off or absorbs an effect it lacks."""
    res = fit.result
    if res is None or not res.substep_rejections:
        return []
    return [f"{stage}: the fit was held back from stiffer parameter sets ({res.substep_rejections} trial point(s) "
            f"needed more than {FIT_MAX_SUBSTEP_RATIO:g} times its start's RK4 sub-steps; it stopped at "
            f"{res.n_substeps} per sample): the base model is far off or absorbs an effect it lacks -- if the "
            "final model is held back too, give a better base model (--base)"]


def prediction_residual(spec: DiagnosisPlant, model: Model, records: Sequence[Record], sigma: dict[str, float],
                        horizon_s: float = 0.02) -> dict[str, float]:
    """Equation-error view: RMS weighted residual of ``horizon_s``-ahead predictions started
    from the measured state at every window start shifted through the record (short windows,
    so drift cannot build up)."""
    short = dataclasses.replace(spec, segment_seconds=horizon_s, warmup_seconds=0.0)
    ((exps, outs),) = _simulate(short, [model], records)
    acc: dict[str, list] = {}
    for e, o in zip(exps, outs):
        for k, v in o.items():
            if k in sigma:
                acc.setdefault(k, []).append(((e.outputs[k] - v) / sigma[k])[1:])
    return {k: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for k, v in acc.items()}


# ======================================================================================
# propose: score test of each candidate's signature
# ======================================================================================


def _candidates(spec: DiagnosisPlant, model: Model, allowed: Sequence[str] | None) -> list[Effect]:
    present = set(present_effects(spec, model))
    out = []
    for e in effects_for(spec.name, diagnosable_only=True):
        if e.name in present or (allowed is not None and e.name not in allowed):
            continue
        if all(r in present for r in e.on(spec.name).requires):
            out.append(e)
    return out


def signature_scores(spec: DiagnosisPlant, model: Model, records: Sequence[Record], sigma: dict[str, float],
                     cands: Sequence[Effect]) -> dict[str, float]:
    """Fraction of the weighted simulation residual explained by each candidate's signature
    (least-squares projection onto the output changes its parameters cause at their start
    values; 0 = orthogonal, 1 = explains everything)."""
    variants: list[Model] = [model]
    cols: dict[str, list[tuple[int, int]]] = {}
    for e in cands:
        if e.kind == "sensor":
            continue
        r = e.on(spec.name)
        m0 = with_effect(spec, model, e.name)
        i0 = len(variants)
        variants.append(m0)
        pairs = [(i0, 0)]
        for p in r.parameters[1:]:
            v = float(getattr(m0.params, p.field))
            v2 = v * 1.5 if p.log else v + 0.5 * abs(p.start)
            variants.append(with_effect(spec, model, e.name, {p.field: v2} | {
                q.field: float(getattr(m0.params, q.field)) for q in r.parameters if q.field != p.field}))
            pairs.append((len(variants) - 1, i0))
        cols[e.name] = pairs
    sims = _simulate(spec, variants, records)
    exps, base_out = sims[0]
    keys = [k for k in sigma]

    def stack(outs):
        return np.concatenate([(o[k] / sigma[k])[_scored(e)] for e, o in zip(exps, outs) for k in keys if k in o])

    y = np.concatenate([(e.outputs[k] / sigma[k])[_scored(e)] for e, o in zip(exps, base_out) for k in keys if k in o])
    y0 = stack(base_out)
    r = y - y0
    rr = float(r @ r)
    scores = {}
    for name, pairs in cols.items():
        S = np.column_stack([stack(sims[a][1]) - stack(sims[b][1]) if b else stack(sims[a][1]) - y0
                             for a, b in pairs])
        S = np.where(np.isfinite(S), S, 0.0)
        beta, *_ = np.linalg.lstsq(S, r, rcond=None)
        e_ = r - S @ beta
        scores[name] = float(max(0.0, 1.0 - (e_ @ e_) / rr)) if rr > 0 else 0.0
    for e in cands:
        if e.kind == "sensor":
            ch = e.on(spec.name).channels
            parts = []
            for ex, o in zip(exps, base_out):
                sel = _scored(ex)
                for k in keys:
                    if k not in o:
                        continue
                    if k in ch:
                        parts.append((-np.gradient(o[k], ex.dt) / sigma[k])[sel])
                    else:
                        parts.append(np.zeros(o[k].size)[sel])
            s = np.concatenate(parts)
            scores[e.name] = float((s @ r) ** 2 / max(s @ s, 1e-300) / rr) if rr > 0 else 0.0
    return scores
