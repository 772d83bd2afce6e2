"""Two effects at once: the pair round of the diagnosis loop.

A round in which no single catalogue effect wins can still hide two: on a heavy axis with
Coulomb friction *and* a constant force, Coulomb friction alone makes the free run drift under
the unmodelled force (held-out error up) and the force alone leaves the friction (its gain rests
on one window), so neither is named although both are in the catalogue. When such a round ends
with the residual still above the plant's noise-floor threshold, the plant effects whose single
refits scored best on the held-out data (at most :data:`PAIR_MEMBERS`) are refitted in pairs
from the current model; a pair is accepted under the rules of a single candidate (plausible and
identifiable parameters, held-out gain >= the acceptance gain, not resting on one held-out
window) and its members are named in order of the residual each explains: the member whose
removal from the pair costs more held-out error (the other member's single refit is worse)
comes first.

:func:`explained_in_final_model` orders the effects a run named by the held-out residual each
explains in the final model (the score with the effect, and every effect that needs it, set to
its null value, minus the final score): the greedy rounds find effects in an order that local
minima of the round's refits can decide (on the EMPS record the constant force's refit found its
minimum in round 1 while Coulomb's stopped at half its level, or the other way round with the
record rounded to 9 digits), while the final model's leave-one-out is the same either way
(without Coulomb friction 0.72, without the force 0.15).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence

from hydro_envs.params import ParameterError
from identification import greybox as gb
from identification.diagnosis.candidates import Candidate, _judge
from identification.diagnosis.catalogue import effect
from identification.diagnosis.fitting import _check_windows, _mean, fit_model, heldout_nrmse
from identification.diagnosis.models import Model, with_effect
from identification.diagnosis.plants import DiagnosisPlant
from identification.diagnosis.records import Record

__all__ = ["PAIR_MEMBERS", "pair_candidates", "pair_order", "explained_in_final_model"]

#: plant effects (best single held-out scores first) combined into pairs
PAIR_MEMBERS = 3


def _requires(spec: DiagnosisPlant, a: str, b: str) -> bool:
    """True if effect ``a`` needs ``b`` (directly or through another), or the other way round."""
    return _requires_one(spec, a, b) or _requires_one(spec, b, a)


def pair_candidates(spec: DiagnosisPlant, current: Model, singles: Sequence[Candidate], records: Sequence[Record],
                    holdout: Sequence[Record], sigma: dict[str, float], h_cur: float,
                    accept_gain: float) -> list[Candidate]:
    """Refits of the current model with two plant effects added, scored and judged like single
    candidates (name ``"a+b"``, ``a`` the member with the better single score)."""
    live = sorted((c for c in singles if c.model is not None and math.isfinite(c.heldout)
                   and effect(c.name).kind == "plant"), key=lambda c: c.heldout)[:PAIR_MEMBERS]
    out: list[Candidate] = []
    for a, b in itertools.combinations(live, 2):
        if _requires(spec, a.name, b.name):  # e.g. Stribeck on Coulomb: one effect, not two
            continue
        t0 = time.perf_counter()
        try:
            fit = fit_model(spec, with_effect(spec, with_effect(spec, current, a.name), b.name), records, sigma=sigma)
        except (ParameterError, gb.GreyboxError):
            continue
        (nr,) = heldout_nrmse(spec, [fit.model], holdout)
        h = _mean(nr)
        vals: dict[str, float] = {}
        ses: dict[str, float] = {}
        plausible = identifiable = True
        reasons: list[str] = []
        for name in (a.name, b.name):
            v, s, p, i, r = _judge(spec, effect(name), fit)
            vals.update(v)
            ses.update(s)
            plausible, identifiable = plausible and p, identifiable and i
            reasons += r
        if not math.isfinite(h):
            reasons.append("its free run is not finite on the held-out windows")
        out.append(Candidate(f"{a.name}+{b.name}", 0.0, vals, ses, dict(fit.result.nrmse) if fit.result else {}, nr, h,
                             (h_cur - h) / h_cur, plausible, identifiable, reasons, time.perf_counter() - t0,
                             fit.model, fit))
    _check_windows(spec, current, out, holdout, accept_gain)
    return out


def pair_order(pair: Candidate, singles: Sequence[Candidate]) -> list[str]:
    """Members of ``pair`` in order of the held-out residual each explains: the one whose single
    refit scored better first (removing it from the pair leaves the worse single)."""
    names = pair.name.split("+")
    score = {c.name: c.heldout for c in singles}
    return sorted(names, key=lambda n: score.get(n, math.inf))


def explained_in_final_model(spec: DiagnosisPlant, model: Model, names: Sequence[str],
                             holdout: Sequence[Record]) -> dict[str, float]:
    """Held-out score lost when each of ``names`` (and every named effect that needs it) is set
    back to its null value in ``model`` (no refit): how much of the residual it explains there."""
    import dataclasses

    def without(name: str) -> Model:
        drop = [n for n in names if n == name or _requires_one(spec, n, name)]
        params, delay = model.params, model.delay
        for n in drop:
            e = effect(n)
            if e.kind == "sensor":
                delay = 0.0
                continue
            r = e.on(spec.name)
            null = {q.field: r.null[q.field] for q in r.parameters if q.field in r.null}
            params = dataclasses.replace(params, **{k: (float(getattr(params, v)) if isinstance(v, str) else float(v))
                                                    for k, v in null.items()})
        return model.copy(params=params, delay=delay)

    scores = heldout_nrmse(spec, [model] + [without(n) for n in names], holdout)
    base = _mean(scores[0])
    return {n: _mean(sc) - base for n, sc in zip(names, scores[1:])}


def _requires_one(spec: DiagnosisPlant, a: str, b: str) -> bool:
    """True if effect ``a`` needs ``b`` (directly or through another)."""
    todo, seen = list(effect(a).on(spec.name).requires), set()
    while todo:
        n = todo.pop()
        if n == b:
            return True
        if n not in seen:
            seen.add(n)
            todo += list(effect(n).on(spec.name).requires)
    return False
