"""Two effects at once: the pair round of the diagnosis loop.

A round in which no single catalogue effect wins can still hide two: on a heavy axis with
Coulomb friction *and* a constant force, Coulomb friction alone makes the free run drift under
the unmodelled force (held-out error up) and the force alone leaves the friction (its gain rests
on one window), so neither is named although both are in the catalogue. When such a round ends
with the residual still above the plant's noise-floor threshold, the plant effects whose single
refits scored best on the held-out data (at most :data:`PAIR_MEMBERS`) are refitted in pairs
from the current model; a pair is accepted under the rules of a single candidate (plausible and
identifiable parameters, held-out gain >= the acceptance gain, not resting on one held-out
window) and both members are named. A third effect can mimic part of the pair's signature: on
the same record a backlash alone won a round (held-out gain 53 %) and left 22645 noise floors,
the pair of Coulomb friction and the force 1.1. So pairs are also refitted when the single that
wins leaves the residual above the threshold: the pair of the two best other plant effects
(the winner's own pairs are the next round's single candidates), which takes the round if its
held-out error is below the single's by the ambiguity margin.

A member's single refit must be plausible: one that ends on a plausibility bound or breaks a
parameter relation (a static friction fitted below the Coulomb level) says the data push that
effect out of its physical range, which a partner's parameters do not widen (slider record with
an unmodelled spring: the pairs with such a Stribeck refit ended on the same bounds, 31 s of a
103 s run). A pair's refit starts from its members' single refits when they fit better than
their catalogue starts.

:func:`explained_in_final_model` orders the effects a run named by the held-out residual each
explains in the final model (the score with the effect, and every effect that needs it, set to
its null value, minus the final score): the greedy rounds find effects in an order that local
minima of the round's refits can decide (on the EMPS record the constant force's refit found its
minimum in round 1 while Coulomb's stopped at half its level, or the other way round with the
record rounded to 9 digits), while the final model's leave-one-out is the same either way
(NRMSE lost without Coulomb friction 0.758, without the force 0.11).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence

from hydro_envs.params import ParameterError
from identification import greybox as gb
from identification.diagnosis.candidates import Candidate, _best_start, _judge
from identification.diagnosis.catalogue import CATALOGUE, effect
from identification.diagnosis.fitting import _check_windows, _mean, fit_model, heldout_nrmse
from identification.diagnosis.models import Model, null_base, prerequisites, present_effects, with_effect
from identification.diagnosis.plants import DiagnosisPlant
from identification.diagnosis.records import Record

__all__ = ["PAIR_MEMBERS", "pair_candidates", "explained_in_final_model"]

#: plant effects (best single held-out scores first) combined into pairs
PAIR_MEMBERS = 3


def pair_candidates(spec: DiagnosisPlant, current: Model, singles: Sequence[Candidate], records: Sequence[Record],
                    holdout: Sequence[Record], sigma: dict[str, float], h_cur: float,
                    accept_gain: float, ceiling: float | None = None, cost_tol: float | None = None,
                    members: int = PAIR_MEMBERS, rival_cost: float | None = None) -> list[Candidate]:
    """Refits of the current model with two plant effects added, scored and judged like single
    candidates (name ``"a+b"``, ``a`` the member with the better single score), among the
    ``members`` best single refits. A pair's refit starts from the better (:func:`_pair_start`)
    of the members' catalogue starts and their single refits' values; ``ceiling`` and
    ``cost_tol`` as for single refits (:func:`.fitting.fit_model`). ``rival_cost``: the fit
    cost of a winning single the pairs compete with; a pair refit that cannot fall below it
    at its current rate stops (``cost_target``)."""
    live = sorted((c for c in singles if c.model is not None and math.isfinite(c.heldout) and c.plausible
                   and c.name in CATALOGUE and effect(c.name).kind == "plant"),  # not the sensor-offset candidate
                  key=lambda c: c.heldout)[:members]
    out: list[Candidate] = []
    for a, b in itertools.combinations(live, 2):
        if b.name in prerequisites(spec, a.name) or a.name in prerequisites(spec, b.name):  # e.g. Stribeck on Coulomb
            continue
        t0 = time.perf_counter()
        try:
            fit = fit_model(spec, _pair_start(spec, current, a, b, records, sigma), records, sigma=sigma,
                            cost_ceiling=ceiling, cost_tol=cost_tol, cost_target=rival_cost)
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


def _pair_start(spec: DiagnosisPlant, current: Model, a: Candidate, b: Candidate, records: Sequence[Record],
                sigma: dict[str, float]) -> Model:
    """``current`` with effects ``a`` and ``b`` added at their catalogue starts, or at the values
    of their single refits when those give the lower weighted simulation residual
    (:func:`.candidates._best_start`). From the catalogue starts a pair refit repeats most of
    what the single refits already walked (slider record with an unmodelled spring: three pair
    refits, 60 s)."""
    at_start = with_effect(spec, with_effect(spec, current, a.name), b.name)
    try:
        at_singles = with_effect(spec, with_effect(spec, current, a.name, a.parameters), b.name, b.parameters)
    except ParameterError:  # e.g. the single refits' levels break a relation together
        return at_start
    return _best_start(spec, [at_start, at_singles], [at_start, at_singles], records, sigma)


def explained_in_final_model(spec: DiagnosisPlant, model: Model, names: Sequence[str],
                             holdout: Sequence[Record]) -> dict[str, float]:
    """Held-out score lost when each of ``names`` (and every named effect that needs it) is set
    back to its null value in ``model`` (no refit): how much of the residual it explains there."""
    def without(name: str) -> Model:
        drop = {n for n in names if n == name or name in prerequisites(spec, n)}
        keep = [n for n in present_effects(spec, model) if n not in drop]
        delay = 0.0 if any(effect(n).kind == "sensor" for n in drop) else model.delay
        return model.copy(params=null_base(spec, model.params, keep=keep), delay=delay)

    scores = heldout_nrmse(spec, [model] + [without(n) for n in names], holdout)
    base = _mean(scores[0])
    return {n: _mean(sc) - base for n, sc in zip(names, scores[1:])}

