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

__all__ = ["PAIR_MEMBERS", "pair_candidates", "pair_order"]

#: plant effects (best single held-out scores first) combined into pairs
PAIR_MEMBERS = 3


def _requires(spec: DiagnosisPlant, a: str, b: str) -> bool:
    """True if effect ``a`` needs ``b`` (directly or through another), or the other way round."""
    def needs(x: str, y: str) -> bool:
        todo, seen = list(effect(x).on(spec.name).requires), set()
        while todo:
            n = todo.pop()
            if n == y:
                return True
            if n not in seen:
                seen.add(n)
                todo += list(effect(n).on(spec.name).requires)
        return False
    return needs(a, b) or needs(b, a)


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
