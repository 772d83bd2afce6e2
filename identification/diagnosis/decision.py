"""Judgement of one round and of a run: the round's decision among the refitted candidates
(:func:`decide`, :func:`check_correlated`), the measuring-chain candidate
(:func:`offset_candidate`), the input-noise distinctness check (:func:`check_distinct`), notes
on better but implausible candidates (:func:`implausible_best_notes`), the report entry of a
named effect (:func:`named_entry`) and the one verdict of a run (:func:`verdict_reason`). The rules are
those of :mod:`.workflow`'s docstring, step 6."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from hydro_envs.params import ParameterError
from identification import greybox as gb
from identification.diagnosis.candidates import Candidate
from identification.diagnosis.catalogue import effect
from identification.diagnosis.fitting import DISTINCT_MIN, FitOutcome, _distinctness, _mean, fit_model, heldout_nrmse
from identification.diagnosis.floor import UNEXPLAINED_FACTOR, over_threshold
from identification.diagnosis.models import OFFSET_ESTIMATE_FLAG, SENSOR_OFFSETS, Model, prerequisites
from identification.diagnosis.plants import DiagnosisPlant
from identification.diagnosis.records import Record
from identification.diagnosis.residuals import effect_channels, mean_weighted_residual

__all__ = ["AMBIGUOUS_CORRELATION", "OFFSET_MAX_FRACTION", "named_entry", "verdict_reason", "check_distinct",
           "offset_candidate", "check_correlated", "describe", "implausible_best_notes", "decide"]


def named_entry(spec: DiagnosisPlant, name: str, best: Candidate, h_cur: float, h_nr: dict[str, float],
           pair: str | None) -> dict[str, Any]:
    """The report entry of effect ``name`` named from candidate ``best`` (a single effect, or
    one member of the pair ``pair``): its parameters, the held-out score before and after, and
    the shrink over the channels it acts on (every channel for a pair)."""
    e = effect(name)
    fields = ["delay"] if e.kind == "sensor" else [q.field for q in e.on(spec.name).parameters]
    chans = list(h_nr) if pair else list(effect_channels(spec, name, h_nr))
    shrink = 1 - _mean({k: best.nrmse_heldout[k] for k in chans}) / _mean({k: h_nr[k] for k in chans})
    out = {"name": name, "title": e.title,
           "parameters": {k: best.parameters[k] for k in fields},
           "std_errors": {k: best.std_errors.get(k, math.nan) for k in fields},
           "nrmse_before": h_cur, "nrmse_after": best.heldout,
           "nrmse_before_per_channel": h_nr, "nrmse_after_per_channel": best.nrmse_heldout,
           "shrink": shrink, "shrink_channels": chans}
    if pair:
        out["pair"] = pair
    return out

def verdict_reason(accepted: Sequence[dict[str, Any]], ambiguous: str, left: dict[str, float],
                   floor: dict[str, dict[str, Any]], mismatch: dict[str, Any], last: str,
                   factor: float = UNEXPLAINED_FACTOR) -> tuple[str, str]:
    """The one verdict of a run and its reason: ``unexplained`` when the last model's held-out
    residual (``left``, noise floors per channel) stays above its channel's threshold factor
    (``floor[channel]["factor"]``, :func:`~identification.diagnosis.floor.noise_floor`; ``factor``,
    the plant's ``unexplained_factor``, where the floor carries none) in some channel (whatever was
    named or left ambiguous before: the catalogue does not explain the data); else ``ambiguous``
    when any round was; else ``named`` or ``none``."""
    names = ", ".join(e["name"] for e in accepted)
    over = over_threshold(left, floor, factor)
    ch = max(over, key=over.get, default="")
    worst, fac = (left[ch], left[ch] / over[ch]) if ch else (0.0, factor)
    why = _threshold_words(floor.get(ch, {}), fac)
    if ch and over[ch] > 1:
        where = (f"channel {mismatch['channel']!r}: {mismatch['rms']:.3g} {mismatch['unit']} RMS = "
                 f"{mismatch['ratio']:.1f} noise floors of {mismatch['floor']:.3g} {mismatch['unit']}")
        if mismatch.get("worst_region"):
            reg = mismatch["regions"][mismatch["worst_region"]]
            where += f"; largest while {mismatch['worst_region']} ({reg['floors']:.1f} floors)"
        if mismatch.get("worst_band"):
            where += (f"; {mismatch['bands'][mismatch['worst_band']]:.0%} of the excess residual power in "
                      f"{mismatch['worst_band']}")
        after = f"after {last}" if accepted or ambiguous else "with no catalogue effect accepted"
        return "unexplained", (f"the held-out residual {after} stays above {fac:.3g} noise floors{why} "
                               f"({where}): an effect outside the catalogue, or a base model that does not match the "
                               "rig" + (f"; named so far: {names}" if names else "")
                               + (f"; {ambiguous}" if ambiguous else ""))
    if ambiguous:
        return "ambiguous", (f"{ambiguous}: both explain the held-out data (residual {worst:.1f} noise floors with the "
                             "better one) and the data cannot tell them apart" + (f"; named before: {names}" if names
                                                                                  else ""))
    if accepted:
        return "named", (f"{names} lowered the held-out error and the residual left is {worst:.1f} noise floors "
                         f"(<= {fac:.3g}{why})")
    return "none", (f"no catalogue effect clearly lowers the held-out error and the base model's residual is "
                    f"{worst:.1f} noise floors (<= {fac:.3g}{why})")


def _threshold_words(fl: dict[str, Any], factor: float) -> str:
    """What a channel's threshold ``factor`` used: the plant's minimum, or the record's expected
    residual of a correct model (empty without the parts)."""
    if "expected" not in fl:
        return ""
    if factor <= fl["minimum_factor"]:
        return (f", the plant's minimum; a correct model is expected to leave {fl['expected']:.2g} floors on this "
                "record")
    return (f", twice the {fl['expected']:.2g} floors a correct model is expected to leave on this record x its noise "
            f"spread {fl['spread']:.3g}")


def check_distinct(spec: DiagnosisPlant, current: Model, results: Sequence[Candidate], holdout: Sequence[Record],
                    floor: dict[str, float]) -> None:
    """Mark candidates whose prediction the input noise could produce (``DISTINCT_MIN``) as not
    identifiable; the ratio is kept in ``Candidate.distinct``. Plant effects only: a sensor
    delay is applied to the measured channels, not to the prediction (its standard error comes
    from the curvature of the delay cost), and white input noise has no phase to mimic it."""
    live = [c for c in results if c.model is not None and effect(c.name).kind != "sensor"]
    for c, ratio in zip(live, _distinctness(spec, current, [c.model for c in live], holdout, floor)):
        c.distinct = ratio
        if ratio < DISTINCT_MIN:
            c.identifiable = False
            c.reasons.append(f"its prediction differs from the current model's by {ratio:.2f} times the spread the "
                             f"noise of the measured input(s) causes (< {DISTINCT_MIN:g}): not distinguishable")


OFFSET_MAX_FRACTION = 0.05
_OFFSET_EXPERIMENT = ("zero the pressure transducers at rest (valve closed, both chambers vented to tank) "
                      "before and after the test: an offset reads non-zero, a physical effect does not")


def offset_candidate(spec: DiagnosisPlant, cur: FitOutcome, records: Sequence[Record], holdout: Sequence[Record],
                      sigma: dict[str, float], h_cur: float) -> Candidate:
    """The measuring-chain candidate: a constant sensor offset per ``sensor_offsets`` channel
    (profiled nuisance parameters in the refit; the fitted values are carried to the held-out
    records as fixed corrections, so it is scored out of sample like every physical effect)."""
    tc = time.perf_counter()
    try:
        fit = fit_model(spec, cur.model.copy(offsets={}), records, sigma=sigma)
    except (ParameterError, gb.GreyboxError) as err:
        return Candidate(SENSOR_OFFSETS, 0.0, {}, {}, {}, {}, math.inf, -math.inf, False, False,
                         [f"fit failed: {err}"], time.perf_counter() - tc)
    (nr,) = heldout_nrmse(spec, [fit.model], holdout)
    h = _mean(nr)
    # plausible: a zero error of at most OFFSET_MAX_FRACTION of the largest value the channel
    # recorded (a proxy of its full scale; zero errors are 0.1-0.5 % of full scale)
    reasons = []
    for k, b in (fit.model.offsets or {}).items():
        top = max(float(np.max(np.abs(r.channels[k]))) for r in records if k in r.channels)
        if abs(b) > OFFSET_MAX_FRACTION * top:
            reasons.append(f"offset of {k!r} {b:+.4g} beyond {OFFSET_MAX_FRACTION:.0%} of the largest recorded "
                           f"value {top:.4g}: not a transducer zero error")
    # identifiable (and worth a correction): at least one offset above OFFSET_ESTIMATE_FLAG
    # noise levels of its channel (the corrected model's RMS residual over the scored samples);
    # smaller ones are the constant part of model error or noise (effect-free rodless records:
    # ~0.8 levels), not a finding
    stats = mean_weighted_residual(spec, fit.model, records, sigma)
    levels = {k: abs(b) / max(stats[k][2] * sigma[k], 1e-300)
              for k, b in (fit.model.offsets or {}).items() if k in stats}
    ident = any(v > OFFSET_ESTIMATE_FLAG for v in levels.values())
    if not ident:
        reasons.append("offsets below {:g} noise levels ({}): negligible".format(
            OFFSET_ESTIMATE_FLAG, ", ".join(f"{k} {v:.2f}" for k, v in levels.items())))
    return Candidate(SENSOR_OFFSETS, 0.0, dict(fit.model.offsets or {}), {}, dict(fit.result.nrmse), nr, h,
                     (h_cur - h) / h_cur, not any("beyond" in r_ for r_ in reasons), ident, reasons,
                     time.perf_counter() - tc, fit.model, fit)


# a winner whose parameter correlates with a parameter of an effect named earlier in the run by
# more than this (the joint fit's parameter correlation, identification.greybox) cannot be told
# apart from it on these data: the decision is "ambiguous: winner vs earlier effect"; pairs above
# greybox's CORRELATION_LIMIT (0.95) are noted in the candidate's reasons
AMBIGUOUS_CORRELATION = 0.99


def check_correlated(spec: DiagnosisPlant, winner: Candidate, earlier: Sequence[str], decision: str,
                      sep: str) -> tuple[str, str]:
    """The decision after the identifiability check of the winner against the effects named
    earlier in the run (not its prerequisites): a parameter pair correlated above
    ``AMBIGUOUS_CORRELATION`` in the joint fit makes the round ``ambiguous: winner vs earlier``."""
    res = getattr(winner.fit, "result", None)
    if res is None or effect(winner.name).kind != "plant":
        return decision, sep
    own = {p.field for p in effect(winner.name).on(spec.name).parameters}
    skip = prerequisites(spec, winner.name)
    fields = {p.field: e for e in earlier if e not in skip and effect(e).kind == "plant"
              for p in effect(e).on(spec.name).parameters}
    worst = None
    for a, b, rho in res.correlated_pairs:
        for x, y in ((a, b), (b, a)):
            if x in own and y in fields:
                winner.reasons.append(f"{x} correlated with {y} of {fields[y]} (rho {rho:+.3f}) in the joint fit")
                if abs(rho) > AMBIGUOUS_CORRELATION and (worst is None or abs(rho) > abs(worst[1])):
                    worst = (fields[y], rho)
    if worst is None:
        return decision, sep
    return f"ambiguous: {winner.name} vs {worst[0]}", f"{describe(winner.name)} | {describe(worst[0])}"


def describe(name: str) -> str:
    if name == SENSOR_OFFSETS:
        return f"{SENSOR_OFFSETS}: {_OFFSET_EXPERIMENT}"
    e = effect(name)
    return f"{e.name}: {e.separating_experiment}"


def implausible_best_notes(results: Sequence[Candidate], decision: str, accept_gain: float,
                            round_no: int) -> list[str]:
    """Notes on candidates that explain the held-out data better than the round's decision but
    were not named because a fitted value lies beyond its plausible bound: the value and the
    bound are reported ("check the rig"), never dropped without a word."""
    names = set(decision.split(": ", 1)[1].split(" vs ")) if decision.startswith("ambiguous") else {decision}
    bar = min((c.heldout for c in results if c.name in names), default=math.inf)
    out = []
    for c in results:
        if c.plausible or not c.identifiable or c.gain < accept_gain or c.heldout >= bar:
            continue
        why = "; ".join(r for r in c.reasons if "plausib" in r) or "; ".join(c.reasons)
        out.append(f"round {round_no}: {c.name} explains the held-out data best (gain {c.gain:.1%}) but is not "
                   f"named: {why} -- check the rig (an effect that large is not expected on a working one), "
                   "or widen the bound if the rig is known to have it")
    return out


def decide(spec: DiagnosisPlant, results: Sequence[Candidate], accept_gain: float, margin: float) -> tuple[str, str]:
    ok = [c for c in results if c.plausible and c.identifiable and c.gain >= accept_gain]
    if not ok:
        return "none", ""
    best = min(ok, key=lambda c: c.heldout)
    rivals = [c for c in ok if c is not best]
    if rivals:
        runner = min(rivals, key=lambda c: c.heldout)
        if runner.heldout < (1 + margin) * best.heldout:
            sep = f"{describe(best.name)} | {describe(runner.name)}"
            return f"ambiguous: {best.name} vs {runner.name}", sep
    return best.name, ""
