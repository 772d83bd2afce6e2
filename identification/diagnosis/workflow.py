r"""The diagnosis loop: fit, locate, propose, refit, score on held-out data, accept or not.

The run is a chain of phases, each a function whose result the next one takes
(:func:`diagnose`): :func:`prepare` (checked data, held-out split) -> :func:`fit_base`
(:class:`BaseFit`) -> per round :func:`locate` (:class:`Located`), :func:`rank`
(:class:`Ranked`), :func:`refit` (candidates), :func:`score` (:class:`Scored`), :func:`advance`
(the :class:`Run` so far) -> :func:`verdict` (:class:`DiagnosisResult`). The judgement rules
live in :mod:`.decision`.

One round::

    1. fit the current model (base-fit parameters + the effects already present) to the fit
       windows by grey-box output error (identification.greybox, batched kernel);
    2. residuals: free-run simulation residual of every window and the k-step (equation-error)
       prediction residual; LOCATE them: RMS/mean residual binned by velocity, position,
       pressure difference and command, residual spectrum vs the measured one, and the
       windows (times) where the residual is largest;
    3. PROPOSE: every catalogue effect that applies to the plant, is absent and whose
       prerequisites are present, ranked by how much of the weighted residual its *signature*
       explains -- the output change the effect causes at a typical size, i.e. the score test
       (Lagrange multiplier test) of the effect's parameters at their null value;
    4. REFIT each augmented model (base parameters + effect parameters, bounded NLS);
    5. SCORE every model by free-run NRMSE on held-out windows (a separate record or the
       record's tail): per channel, the band-limited error over the window spread
       (:func:`.fitting._nrmse`), combined over channels by the geometric mean (:func:`.fitting._mean`);
    6. ACCEPT the best only if it (a) lowers the held-out NRMSE by >= ``accept_gain`` of the
       current model's, (b) its held-out NRMSE is below the runner-up's (among candidates that
       pass (a), (c), (d)) by the factor ``1 + margin``, (c) has
       physically plausible parameters (not on a bound, parameter relations hold) and (d)
       identifiable ones (standard error < ``max_rel_se`` of the effect size and, when a
       measured input drives the simulation, a prediction that differs from the current
       model's by more than the input's own noise moves it, :func:`input_noise_floor`, and a
       held-out gain that survives leaving out any one held-out window, ``LOO_GAIN_FRACTION``);
       candidates that fail (c) or (d) are set aside with the reason. No winner -> ``none``; a
       winner that does not beat the runner-up, or whose parameters correlate with those of an
       effect named earlier in the run by more than ``AMBIGUOUS_CORRELATION`` in the joint fit,
       -> ``ambiguous: A vs B`` with the experiment that separates them.
    7. PAIRS (:mod:`.pairs`): when room for two is left and either no single effect wins while
       the residual stays above the plant's noise-floor threshold, or the single that wins leaves
       the held-out residual above it (unexplained), the best single refits are refitted in pairs
       and judged by the same rules; a winning pair names both members, in order of the residual
       each explains (two effects that only together explain the data: Coulomb friction and a
       constant force on a heavy axis). Beside a winning single only the two best other effects
       are paired (the winner's pairs are the next round); the pair replaces the single only if
       its held-out error is below the single's by the ambiguity margin, and its refit stops
       once it cannot reach the single's fit cost at its current rate (``cost_target``).
    Repeat with the accepted effect added until nothing more is accepted (``max_effects``), or
    until the held-out residual left is at the noise floor (``AT_NOISE_FLOOR`` floors in every
    channel: what is left is noise, and a further gain would fit it).
    Several named effects are listed in order of the held-out residual each explains in the final
    model (:func:`.pairs.explained_in_final_model`), not in the order the rounds found them.
    One verdict for the run: ``unexplained`` when the last model leaves more held-out residual in
    some channel than that channel's threshold (:func:`.floor.noise_floor`: twice what a correct
    model is expected to leave on the record, at least the plant's ``unexplained_factor`` noise
    floors), else
    ``ambiguous`` when any round was, else ``named`` or ``none``.
    The gap shrink reported for a named effect is the fall of the held-out score over the
    channels it acts on (:func:`effect_channels`); the base-fit parameters are refined within
    ``BASE_FIT_FACTOR`` of the start model's values.

Cost (target: the whole catalogue on one 20 s record plus 10 s held out in <= 60 s on 2
cores; the kernel rollouts are ~95 % of the time, so the levers cut rollouts): every candidate
of a round is fitted under the round's fixed channel weights (the noise levels of the current
fit: one solve, not a solve, a reweighting and a second solve), with forward-difference
Jacobians in the iterations (p instead of 2p perturbed copies); a fit stops when an iteration
gains less than a chi-square change of 1, or creeps (< 1 % per iteration) above the cost of the
model it extends; the warm refit starts from the better of the effect's catalogue start and a
point nearer its null value. The second, cold start (and the start grid after it) runs only
for candidates the score test ranks as plausible or whose warm fit fails or ends on a bound or
a relation, not when the warm refit already leaves a correct model's residual or has brought
the base parameters back to the cold start's values, and not after a candidate of the round has
done so (``SETTLED_FRACTION``: the later candidates get their warm
refit only, a sensor delay one pass of its search, and those whose signature explains < 0.1
times the settling candidate's, or < 0.5 % of the residual, are not refitted); after an
acceptable candidate that does not settle the round, the later ones whose signature explains
< 0.1 times its own get the warm refit only (``LEAD_RIVAL_RATIO``). Candidates that
explain < 0.5 % of the residual (``HOPELESS_SCORE``) get a warm refit of at most
``HOPELESS_NFEV`` evaluations in the first round and none after a named effect (a round in which
every candidate is hopeless ends there). The sensor-delay search scans a coarse grid, then the
fine one around its minimum, and later passes only near the last delay.

Sensor offsets of pressure channels (``DiagnosisPlant.sensor_offsets``): every round also
refits a measuring-chain candidate ``sensor_offsets`` (a constant per channel, profiled out of
the fit, carried to the held-out records as a fixed correction) that competes with the
physical candidates under the same rules; when it wins it is kept (not counted as an effect)
and the round is repeated. Estimated offsets, any remaining mean residual and a drift between
the first and second half of the data are flagged in the notes.

Sparse regression is deliberately not used to decide: the score test only orders the refits;
the decision is always the held-out free-run error of refitted physical models.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from hydro_envs.jsonutil import to_jsonable as jsonable
from hydro_envs.params import ParameterError, PhysicalParams
from identification import greybox as gb
from identification.diagnosis.base_estimates import estimate_base, position_shift, shifted
from identification.diagnosis.candidates import Candidate, _fit_candidate, _fit_delay, _judge, _round_scores
from identification.diagnosis.catalogue import Effect, effects_for
from identification.diagnosis.decision import (
    check_correlated,
    check_distinct,
    decide,
    implausible_best_notes,
    named_entry,
    offset_candidate,
    verdict_reason,
)
from identification.diagnosis.final_model import final_model_rows
from identification.diagnosis.fitting import (
    FitOutcome,
    _check_windows,
    _mean,
    fit_model,
    heldout_nrmse,
    heldout_scores,
    input_noise_floor,
    noise_cost_tol,
)
from identification.diagnosis.floor import (
    UNEXPLAINED_FACTOR,
    heldout_rms,
    noise_floor,
    over_threshold,
    ratios,
    where_mismatch,
)
from identification.diagnosis.models import (
    ACCEPT_GAIN,
    AT_NOISE_FLOOR,
    HOPELESS_SCORE,
    MARGIN,
    SENSOR_OFFSETS,
    SETTLED_FRACTION,
    Model,
    base_fit_bounds,
    null_base,
)
from identification.diagnosis.pairs import PAIR_MEMBERS, explained_in_final_model, pair_candidates
from identification.diagnosis.plants import DiagnosisPlant, diagnosis_plant
from identification.diagnosis.records import DiagnosisFitError, Record, check_records
from identification.diagnosis.residuals import (
    _base_bound_notes,
    _candidates,
    _sensor_notes,
    _stiffness_cap_notes,
    prediction_residual,
    residual_maps,
)

__all__ = ["Round", "DiagnosisResult", "diagnose", "Options", "Prepared", "BaseFit", "Run", "Located", "Ranked",
           "Scored", "prepare", "fit_base", "locate", "rank", "refit", "score", "advance", "verdict"]


@dataclasses.dataclass
class Round:
    """One round of the loop: the current model's scores, the candidates and the decision."""

    current_heldout: float
    current_nrmse_heldout: dict[str, float]
    locate: dict[str, Any]
    prediction_residual: dict[str, float]
    candidates: list[Candidate]
    decision: str  # effect name, "none" or "ambiguous: A vs B"
    separating_experiment: str = ""

    def to_json_dict(self) -> dict[str, Any]:
        return jsonable({
            "current_heldout_nrmse": self.current_heldout, "current_nrmse_heldout": self.current_nrmse_heldout,
            "locate": self.locate, "prediction_residual": self.prediction_residual,
            "candidates": [c.to_json_dict() for c in self.candidates], "decision": self.decision,
            "separating_experiment": self.separating_experiment,
        })


@dataclasses.dataclass
class DiagnosisResult:
    """Outcome of :func:`diagnose` (``to_json_dict`` is what ``hydro diagnose --json`` prints)."""

    plant: str
    verdict: str  # "named", "none", "ambiguous" or "unexplained"
    effects: list[dict[str, Any]]
    rounds: list[Round]
    base_model: Model
    final_model: Model
    base_fit: dict[str, float]
    notes: list[str]
    seconds: float
    sigma: dict[str, float]  # channel weights of the base fit (noise-level estimates)
    ambiguous: str = ""
    # per channel: unit, white-noise level, its part in the score band, input-noise part, floor
    noise_floor: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    # held-out residual after each step: {"step", "rms" [channel unit], "floors" (rms / floor)}
    residual: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    mismatch: dict[str, Any] = dataclasses.field(default_factory=dict)  # where it remains (unexplained)
    reason: str = ""  # why this verdict
    unexplained_factor: float = UNEXPLAINED_FACTOR  # the plant's minimum threshold of the verdict [noise floors]
    # every parameter of the final model with its standard error, unit, bounds, on-bound flag
    final_model_table: list[dict[str, Any]] = dataclasses.field(default_factory=list)

    def to_json_dict(self) -> dict[str, Any]:
        cands = []
        for i, r in enumerate(self.rounds):
            for c in r.candidates:
                d = c.to_json_dict()
                d["round"] = i + 1
                cands.append(d)
        return jsonable({
            "plant": self.plant, "verdict": self.verdict, "reason": self.reason, "effects": self.effects,
            "noise_floor": self.noise_floor, "residual": self.residual, "mismatch": self.mismatch,
            "unexplained_factor": self.unexplained_factor, "candidates": cands,
            "ambiguous": self.ambiguous, "base_fit": self.base_fit, "final_model": self.final_model_table,
            "rounds": [r.to_json_dict() for r in self.rounds], "notes": self.notes, "seconds": self.seconds,
        })



# ======================================================================================
# the data of one run, phase by phase
# ======================================================================================


@dataclasses.dataclass(frozen=True)
class Options:
    """The caller's choices for one run (the keyword arguments of :func:`diagnose`)."""

    effects: Sequence[str] | None
    max_effects: int
    accept_gain: float
    margin: float
    maps: bool
    say: Callable[[str], None]


@dataclasses.dataclass(frozen=True)
class Prepared:
    """Before the base fit: the plant settings (windows adapted to the base model), the checked
    fit and held-out records, the base model's parameters and the notes on the data."""

    spec: DiagnosisPlant
    records: list[Record]
    holdout: list[Record]
    base: PhysicalParams | None
    notes: list[str]


@dataclasses.dataclass(frozen=True)
class BaseFit:
    """Phase *base fit*: the start model (with its base-fit bounds), the fitted base model, its
    channel weights and values, its held-out score and the noise floor of the held-out data."""

    start: Model
    outcome: FitOutcome
    sigma: dict[str, float]
    values: dict[str, float]
    nrmse_heldout: dict[str, float]
    heldout: float
    floor: dict[str, dict[str, Any]]
    notes: list[str]


@dataclasses.dataclass
class Run:
    """What one round hands to the next: the current fit and its held-out score, the model
    after each step, the rounds so far, the named effects, an ambiguous decision and notes."""

    cur: FitOutcome
    h_cur: float
    h_nr: dict[str, float]
    steps: list[tuple[str, Model]]
    notes: list[str]
    rounds: list[Round] = dataclasses.field(default_factory=list)
    accepted: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    ambiguous: str = ""
    ambiguous_model: Model | None = None
    beyond: list[str] = dataclasses.field(default_factory=list)  # best fits beyond a plausible bound


@dataclasses.dataclass(frozen=True)
class Located:
    """Phase *locate*: residual maps and k-step prediction residual of the current model (empty
    without ``maps``) and, after a named effect, its held-out residual in noise floors."""

    maps: dict[str, Any]
    prediction: dict[str, float]
    left: dict[str, float] | None


@dataclasses.dataclass(frozen=True)
class Ranked:
    """Phase *rank*: the candidate effects, best signature score first; ``stop``: nothing to refit."""

    effects: list[Effect]
    scores: dict[str, float]
    stop: bool = False


@dataclasses.dataclass(frozen=True)
class Scored:
    """Phase *score*: every judged candidate of the round (pairs included), best held-out score
    first, the round's decision and the experiment that separates an ambiguous one."""

    results: list[Candidate]
    decision: str
    separating: str = ""


class _HeldoutScores:
    """Held-out NRMSE and residual in noise floors of a model, one free run per model (a
    round's refits and its pair check share them)."""

    def __init__(self, spec: DiagnosisPlant, holdout: Sequence[Record], floor: dict[str, dict[str, Any]]):
        self.spec, self.holdout, self.floor = spec, holdout, floor
        self._done: dict[int, tuple[Model, dict[str, float], dict[str, float]]] = {}

    def __call__(self, m: Model) -> tuple[dict[str, float], dict[str, float]]:
        if id(m) not in self._done:
            ((nr_m, rms_m),) = heldout_scores(self.spec, [m], self.holdout)
            self._done[id(m)] = (m, nr_m, ratios(rms_m, self.floor))
        return self._done[id(m)][1:]

    def settles(self, m: Model) -> bool:
        """Whether ``m`` leaves a correct model's residual (:func:`_settled_by`)."""
        return _settled_by(self.spec, self(m)[1], self.floor)


# ======================================================================================
# the loop
# ======================================================================================


def diagnose(plant: str | DiagnosisPlant, records: Sequence[Record], holdout: Sequence[Record] | None = None, *,
             base: PhysicalParams | None = None, effects: Sequence[str] | None = None, max_effects: int = 3,
             accept_gain: float = ACCEPT_GAIN, margin: float = MARGIN, holdout_fraction: float = 0.3,
             maps: bool = True, progress=None) -> DiagnosisResult:
    """Run the diagnosis loop (module docstring) on ``records``; ``holdout`` records score the
    candidates (default: the last ``holdout_fraction`` of every record). ``base`` is the model
    to start from (default: the plant's nominal parameters with every catalogue effect at its
    null value); ``effects`` restricts the candidates to these catalogue names.

    The phases: :func:`prepare` the data, :func:`fit_base`; per round :func:`locate`,
    :func:`rank`, :func:`refit`, :func:`score` and :func:`advance`; at the end :func:`verdict`."""
    t0 = time.perf_counter()
    opts = Options(effects, max_effects, accept_gain, margin, maps, progress or (lambda msg: None))
    data = prepare(plant, records, holdout, base=base, effects=effects, holdout_fraction=holdout_fraction)
    bf = fit_base(data, opts)
    run = Run(bf.outcome, bf.heldout, bf.nrmse_heldout, [("base model", bf.outcome.model)], data.notes + bf.notes)
    while len(run.accepted) < max_effects and len(run.rounds) <= max_effects:
        if not _round(data, bf, run, opts):
            break
    return verdict(data, bf, run, t0)


def _round(data: Prepared, bf: BaseFit, run: Run, opts: Options) -> bool:
    """One round: locate, rank, refit, score, advance; False when the run ends here."""
    where = locate(data, bf, run, opts)
    if where.left is not None and max(where.left.values(), default=math.inf) <= AT_NOISE_FLOOR:
        opts.say(f"  the residual left is at the noise floor (<= {AT_NOISE_FLOOR:g} floors in every channel): "
                 "nothing more to name")
        run.rounds.append(Round(run.h_cur, run.h_nr, where.maps, where.prediction, [], "none"))
        return False
    ranked = rank(data, bf, run, opts)
    if ranked.stop:
        run.rounds.append(Round(run.h_cur, run.h_nr, where.maps, where.prediction, [], "none"))
        return False
    scores = _HeldoutScores(data.spec, data.holdout, bf.floor)
    results = refit(data, bf, run, ranked, scores, opts)
    return advance(data, run, where, score(data, bf, run, where, results, scores, opts), opts)


def prepare(plant: str | DiagnosisPlant, records: Sequence[Record], holdout: Sequence[Record] | None, *,
            base: PhysicalParams | None, effects: Sequence[str] | None, holdout_fraction: float) -> Prepared:
    """Check the data and the effect names, split off the held-out data (when not given), read
    the base model off the data (plants with ``base_from_data`` and no ``base``) and lengthen the
    windows of slowly settling base models."""
    spec = plant if isinstance(plant, DiagnosisPlant) else diagnosis_plant(plant)
    records = list(records)
    notes: list[str] = [n for r in records for n in r.notes]
    if effects is not None:
        known = {e.name for e in effects_for(spec.name, diagnosable_only=True)}
        bad = [e for e in effects if e not in known]
        if bad:
            raise ValueError(f"effects {bad} do not apply to {spec.name}; applicable: {sorted(known)}")
    if holdout is None:
        pairs = [r.split(1 - holdout_fraction) for r in records]
        records = [a for a, _ in pairs]
        holdout = [b for _, b in pairs]
        notes.append(f"held-out data: the last {holdout_fraction:.0%} of each record")
    else:
        holdout = list(holdout)
    if base is None and spec.base_from_data:
        dx = position_shift(list(records) + list(holdout), spec.position_channel)
        if dx:
            records = shifted(records, spec.position_channel, dx)
            holdout = shifted(holdout, spec.position_channel, dx)
            notes.append(f"position {spec.position_channel!r} shifted by {dx:+.4g} m so that the recorded motion lies "
                         "inside the base model's end stops (its zero is not the lower stop)")
        base, note = estimate_base(spec, null_base(spec), records)
        notes.append(note)
    if spec.settling_time is not None:
        tau = float(spec.settling_time(base if base is not None else null_base(spec)))
        if 3 * tau > spec.warmup_seconds:
            spec = dataclasses.replace(spec, warmup_seconds=3 * tau, segment_seconds=max(spec.segment_seconds, 5 * tau))
            notes.append(f"windows: {spec.warmup_seconds:.3g} s unscored warm-up and {spec.segment_seconds:.3g} s "
                         f"scored (3 and 5 start-error time constants of the base model, {tau:.3g} s)")
    notes += check_records(records, spec, role="fit data", min_segments=3)
    notes += check_records(holdout, spec, role="held-out data", min_segments=1)
    return Prepared(spec, records, holdout, base, notes)


def fit_base(data: Prepared, opts: Options) -> BaseFit:
    """Phase *base fit*: fit the base parameters (within ``BASE_FIT_FACTOR`` of the start
    model's), score the fitted model on the held-out windows and estimate their noise floor;
    :class:`DiagnosisFitError` when the fitted base model does not run or breaks a relation."""
    spec, records, holdout = data.spec, data.records, data.holdout
    model = Model(data.base if data.base is not None else null_base(spec))
    model = model.copy(base_bounds=base_fit_bounds(spec, model.params))
    notes = _stroke_notes(spec, model.params, list(records) + list(holdout))
    opts.say(f"fit base model of {spec.name} ({', '.join(spec.base_fit)})")
    try:
        cur = fit_model(spec, model, records)
    except (ParameterError, gb.GreyboxError) as err:
        raise DiagnosisFitError(f"the base fit of {spec.name} failed: {err} -- base model "
                                f"{_describe_params(spec, model.params)}; give a base model that matches the rig "
                                "(--base preset)") from err
    if cur.result.params is None:  # the fitted values break a parameter relation (e.g. F_S < F_C)
        why = "; ".join(n for n in cur.result.notes if "relation" in n)
        raise DiagnosisFitError(f"the base fit of {spec.name} gives an impossible parameter set ({why}) -- "
                                f"fitted {_describe_params(spec, cur.model.params)}; the base model carries an "
                                "effect the data do not support: give a base model without it (--base preset)")
    _check_base_fit(spec, cur, model, records, "fit")
    (h_nr,) = heldout_nrmse(spec, [cur.model], holdout)
    _check_base_fit(spec, cur, model, holdout, "held-out", h_nr)
    floor = noise_floor(spec, cur.model, holdout)
    opts.say("noise floor: " + ", ".join(f"{k} {v['floor']:.3g} {v['unit']}" for k, v in floor.items()))
    return BaseFit(model, cur, dict(cur.result.sigma), dict(cur.result.values), h_nr, _mean(h_nr), floor, notes)


def locate(data: Prepared, bf: BaseFit, run: Run, opts: Options) -> Located:
    """Phase *locate*: where the current model's residual lies (module docstring, step 2)."""
    spec, model = data.spec, run.cur.model
    maps = residual_maps(spec, model, data.records, bf.sigma) if opts.maps else {}
    pred = prediction_residual(spec, model, data.records, bf.sigma) if opts.maps else {}
    left = _floors_left(spec, model, data.holdout, bf.floor) if run.accepted else None
    return Located(maps, pred, left)


def rank(data: Prepared, bf: BaseFit, run: Run, opts: Options) -> Ranked:
    """Phase *rank*: the applicable absent effects, ordered by the share of the residual their
    signature explains (step 3); ``stop`` when there is none, or when after a named effect every
    signature explains less than ``HOPELESS_SCORE``."""
    cands = _candidates(data.spec, run.cur.model, opts.effects)
    if not cands:
        return Ranked([], {}, stop=True)
    scores = _round_scores(data.spec, run.cur.model, bf.start, data.records, bf.sigma, cands)
    cands.sort(key=lambda e: -scores.get(e.name, 0.0))
    if run.accepted and max(scores.get(e.name, 0.0) for e in cands) < HOPELESS_SCORE:
        opts.say("  every candidate's signature explains < "
                 f"{HOPELESS_SCORE:.1%} of the residual left: nothing more to name")
        return Ranked(cands, scores, stop=True)
    return Ranked(cands, scores)


def refit(data: Prepared, bf: BaseFit, run: Run, ranked: Ranked, scores: _HeldoutScores,
          opts: Options) -> list[Candidate]:
    """Phase *refit*: refit each ranked candidate (step 4), judge its parameters and score it on
    the held-out windows; once one leaves a correct model's residual the round is settled (the
    later ones get a warm refit only, or none: ``SETTLED_RIVAL_RATIO``); after an acceptable one
    that does not, those far below its signature get a warm refit only (``LEAD_RIVAL_RATIO``)."""
    results: list[Candidate] = []
    settled = False  # a candidate of this round already leaves a correct model's residual
    rival_score = HOPELESS_SCORE  # in a settled round, candidates scoring below this are not refitted
    lead_score = 0.0  # below this signature a candidate gets its warm refit only (LEAD_RIVAL_RATIO)
    for e in ranked.effects:
        s = ranked.scores.get(e.name, 0.0)
        skip = (NOT_REFITTED if settled and s < rival_score else
                HOPELESS_AFTER_NAMED if run.accepted and s < HOPELESS_SCORE else None)
        if skip:
            opts.say(f"  candidate {e.name} (signature {s:.4f}): not refitted")
            results.append(_unfitted(e.name, s, skip, 0.0))
            continue
        warm_only = settled or s < lead_score
        opts.say(f"  candidate {e.name} (signature {s:.4f})" + (" (warm refit only)" if warm_only else ""))
        c = _refit_one(data, bf, run, e, s, warm_only, scores)
        results.append(c)
        opts.say(f"    {c.seconds:.1f} s: " + (f"held-out gain {c.gain:+.1%}" if math.isfinite(c.gain) else c.reasons[-1]))
        if not settled and c.model is not None and c.plausible and c.identifiable and c.gain >= opts.accept_gain:
            settled = scores.settles(c.model)
            if settled:
                rival_score = max(HOPELESS_SCORE, SETTLED_RIVAL_RATIO * s)
            lead_score = max(lead_score, LEAD_RIVAL_RATIO * s)
    return results


def _unfitted(name: str, signature: float, reason: str, seconds: float) -> Candidate:
    """A candidate without a refit (skipped, or its fit failed) and the reason."""
    return Candidate(name, signature, {}, {}, {}, {}, math.inf, -math.inf, False, False, [reason], seconds)


def _refit_one(data: Prepared, bf: BaseFit, run: Run, e: Effect, signature: float, warm_only: bool,
               scores: _HeldoutScores) -> Candidate:
    """The refit of one candidate (a sensor delay by its search), judged and scored."""
    spec, records, sigma, cur = data.spec, data.records, bf.sigma, run.cur
    tc = time.perf_counter()
    try:
        if e.kind == "sensor":
            fit = _fit_delay(spec, cur.model, records, sigma, e, bf.start, signature, cold=not warm_only)
        else:
            fit = _fit_candidate(spec, cur.model, bf.start, e.name, records, sigma, signature, cold=not warm_only,
                                 ceiling=cur.result.cost if cur.result is not None else None,
                                 settles=lambda f: scores.settles(f.model), cost_tol=noise_cost_tol(sigma, bf.floor))
    except (ParameterError, gb.GreyboxError) as err:
        return _unfitted(e.name, signature, f"fit failed: {err}", time.perf_counter() - tc)
    nr = scores(fit.model)[0]
    h = _mean(nr)
    vals, ses, plausible, ident, reasons = _judge(spec, e, fit)
    if not math.isfinite(h):
        reasons.append("its free run is not finite on the held-out windows")
    return Candidate(e.name, signature, vals, ses, dict(fit.result.nrmse) if fit.result else {}, nr, h,
                     (run.h_cur - h) / run.h_cur, plausible, ident, reasons, time.perf_counter() - tc, fit.model, fit)


def score(data: Prepared, bf: BaseFit, run: Run, where: Located, results: list[Candidate], scores: _HeldoutScores,
          opts: Options) -> Scored:
    """Phase *score*: the input-noise distinctness and leave-one-window-out checks, the
    measuring-chain candidate, the round's decision (step 6) and, when room for two is left,
    the pairs (step 7)."""
    spec, records, holdout, cur = data.spec, data.records, data.holdout, run.cur
    in_floor = input_noise_floor(spec, cur.model, holdout)
    if in_floor:
        check_distinct(spec, cur.model, results, holdout, in_floor)
    if cur.model.offsets is None and any(c in r.channels for r in records for c in spec.sensor_offsets):
        opts.say(f"  candidate {SENSOR_OFFSETS} (measuring chain: {', '.join(spec.sensor_offsets)})")
        results.append(offset_candidate(spec, cur, records, holdout, bf.sigma, run.h_cur))
    _check_windows(spec, cur.model, results, holdout, opts.accept_gain)
    results.sort(key=lambda c: c.heldout)
    decision, sep = decide(spec, results, opts.accept_gain, opts.margin)
    if decision not in ("none", SENSOR_OFFSETS) and not decision.startswith("ambiguous"):
        decision, sep = check_correlated(spec, next(c for c in results if c.name == decision),
                                         [a["name"] for a in run.accepted], decision, sep)
    out = Scored(results, decision, sep)
    return _with_pairs(data, bf, run, where, out, scores, opts) if len(run.accepted) + 2 <= opts.max_effects else out


def _with_pairs(data: Prepared, bf: BaseFit, run: Run, where: Located, out: Scored, scores: _HeldoutScores,
                opts: Options) -> Scored:
    """Step 7: pair refits when no single effect wins while the residual stays above the
    plant's threshold, or the single that wins leaves it above (beside a winning single only the
    two best others are paired); a pair replaces a winning single only when it explains clearly
    more (the ambiguity margin)."""
    spec, cur, decision = data.spec, run.cur, out.decision
    why, single = None, None
    if decision == "none":
        left = where.left if where.left is not None else _floors_left(spec, cur.model, data.holdout, bf.floor)
        if max(over_threshold(left, bf.floor, spec.unexplained_factor).values(), default=0.0) > 1:
            why = "no single effect wins and the residual stays above the noise floor"
    elif decision != SENSOR_OFFSETS and not decision.startswith("ambiguous"):
        single = next(c for c in out.results if c.name == decision)
        left = scores(single.model)[1]
        over = over_threshold(left, bf.floor, spec.unexplained_factor)
        ch = max(over, key=over.get, default=None)
        if ch is not None and over[ch] > 1:
            why = (f"{decision} wins but leaves {left[ch]:.3g} noise floors in {ch} (> its threshold "
                   f"{left[ch] / over[ch]:.3g}: unexplained)")
    if not why:
        return out
    opts.say(f"  {why}: pairs")
    pairs = pair_candidates(spec, cur.model, [c for c in out.results if c is not single], data.records, data.holdout,
                            bf.sigma, run.h_cur, opts.accept_gain,
                            ceiling=cur.result.cost if cur.result is not None else None,
                            cost_tol=noise_cost_tol(bf.sigma, bf.floor), members=PAIR_MEMBERS if single is None else 2,
                            rival_cost=None if single is None or single.fit.result is None else single.fit.result.cost)
    pair_decision, pair_sep = decide(spec, pairs, opts.accept_gain, opts.margin)
    results = out.results + pairs
    if single is None:
        if pair_decision != "none":
            return Scored(results, pair_decision, pair_sep)
    elif "+" in pair_decision and not pair_decision.startswith("ambiguous"):
        pair = next(c for c in pairs if c.name == pair_decision)
        if pair.heldout * (1 + opts.margin) < single.heldout:  # the pair explains clearly more
            return Scored(results, pair_decision, pair_sep)
    return Scored(results, decision, out.separating)


def advance(data: Prepared, run: Run, where: Located, out: Scored, opts: Options) -> bool:
    """Record the round in ``run`` and make its winner the current model (a pair names both
    members; a measuring-chain correction is kept but not named); False when the run ends
    (``none`` or ambiguous)."""
    decision = out.decision
    run.rounds.append(Round(run.h_cur, run.h_nr, where.maps, where.prediction, out.results, decision,
                            out.separating))
    opts.say(f"  -> {decision}")
    for n in implausible_best_notes(out.results, decision, opts.accept_gain, len(run.rounds)):
        opts.say(f"  {n}")
        run.notes.append(n)
        run.beyond.append(n.split(": ", 2)[1].split(" explains")[0])
    if decision.startswith("ambiguous"):
        run.ambiguous = decision
        first = decision.split(": ")[1].split(" vs ")[0]
        run.ambiguous_model = next(c for c in out.results if c.name == first).model
        return False
    if decision == "none":
        return False
    best = next(c for c in out.results if c.name == decision)
    if decision != SENSOR_OFFSETS:
        run.accepted += [named_entry(data.spec, name, best, run.h_cur, run.h_nr, decision if "+" in decision else None)
                         for name in decision.split("+")]
    run.cur = best.fit
    run.h_cur, run.h_nr = best.heldout, best.nrmse_heldout
    run.steps.append((decision, run.cur.model))
    return True


def verdict(data: Prepared, bf: BaseFit, run: Run, t0: float) -> DiagnosisResult:
    """Phase *verdict*: the held-out residual after each step in noise floors, where a mismatch
    remains, the named effects in order of what each explains in the final model, the one
    verdict and its reason, the final model's parameters and the closing notes."""
    spec, holdout, floor, cur, accepted = data.spec, data.holdout, bf.floor, run.cur, run.accepted
    steps = list(run.steps)
    if run.ambiguous_model is not None:
        steps.append((f"best of the {run.ambiguous} (not added)", run.ambiguous_model))
    rms = heldout_rms(spec, [m for _, m in steps], holdout)
    residual = [{"step": name, "rms": r, "floors": ratios(r, floor)} for (name, _), r in zip(steps, rms)]
    over = over_threshold(residual[-1]["floors"], floor, spec.unexplained_factor)
    factor = spec.unexplained_factor
    mismatch = where_mismatch(spec, steps[-1][1], holdout, floor) if max(over.values(), default=0.0) > 1 else {}
    notes = list(run.notes)
    if len(accepted) > 1:
        notes += _order_named(spec, cur.model, accepted, holdout)
    name, reason = verdict_reason(accepted, run.ambiguous, residual[-1]["floors"], floor, mismatch,
                                  residual[-1]["step"], factor)
    if run.beyond:
        reason += (f"; best fit beyond its plausible bound, not named: {', '.join(dict.fromkeys(run.beyond))} "
                   "(value and bound in the notes: check the rig)")
    for a in accepted:  # every named effect's values in the final model (later rounds refit them)
        a["final_parameters"] = {k: (float(cur.model.delay) if k == "delay" else float(getattr(cur.model.params, k)))
                                 for k in a["parameters"]}
    notes += _sensor_notes(spec, cur, data.records, bf.sigma)
    notes += _base_bound_notes(bf.outcome.model, "base fit") + _base_bound_notes(cur.model, "final model")
    notes += _stiffness_cap_notes(bf.outcome, "base fit")
    if cur is not bf.outcome:
        notes += _stiffness_cap_notes(cur, "final model")
    return DiagnosisResult(spec.name, name, accepted, run.rounds, bf.outcome.model, cur.model, bf.values, notes,
                           time.perf_counter() - t0, bf.sigma, run.ambiguous, floor, residual, mismatch, reason,
                           factor, final_model_rows(spec, cur, accepted))


def _order_named(spec: DiagnosisPlant, model: Model, accepted: list[dict[str, Any]],
                 holdout: Sequence[Record]) -> list[str]:
    """Sort several named effects (in place) by the held-out residual each explains in the final
    model; a note when that is not the order the rounds found them in."""
    found = [a["name"] for a in accepted]
    explained = explained_in_final_model(spec, model, found, holdout)
    for i, a in enumerate(accepted):
        a["found_in_step"] = i + 1
        a["explained_in_final_model"] = explained[a["name"]]
    accepted.sort(key=lambda a: -a["explained_in_final_model"])
    if [a["name"] for a in accepted] == found:
        return []
    return ["named in order of the held-out residual each explains in the final model (NRMSE lost without it: "
            + ", ".join(f"{a['name']} {a['explained_in_final_model']:.3g}" for a in accepted)
            + "); found in the order " + ", ".join(found)]


# in a settled round a candidate is not refitted when its signature explains less than this
# fraction of what the settling candidate's explains (and never when it is hopeless): a rival
# must come near a correct model's residual, i.e. explain about as much as the winner; the
# score test is linearised, hence the wide margin. On the rodless record with hidden Stribeck
# friction (score 0.76) the sensor delay and the valve dynamics (0.009 each) took 13 s of 65 s
SETTLED_RIVAL_RATIO = 0.1
# in a round with an acceptable candidate (plausible, identifiable, held-out gain >= accept_gain) that
# leaves more than a correct model's residual, a later candidate whose signature explains less
# than this fraction of the leader's gets its warm refit only (no cold start, no start grid): it
# is still refitted and scored, and the leader is accepted in its round only if it beats it. On
# the rodless record with Coulomb friction and a drooping supply through a hose (the hose's lag
# outside the catalogue) the cold lap and valve-dynamics refits of the second round (signatures
# 0.078 and 0.052 beside Coulomb friction's 0.95) retraced their warm minima in 13 s
LEAD_RIVAL_RATIO = 0.1
# after a named effect, a hopeless candidate (HOPELESS_SCORE) is not refitted, as no candidate is when
# all are: the score is the larger of the one at the current fit and at the cold start, so an
# effect the base fit absorbed is not ranked hopeless. On the rodless record with a drooping supply
# through a hose (the hose's lag outside the catalogue) the hopeless Stribeck and lap refits of the
# second round took 25 s and changed the held-out score by +0.8 % and -2.3 %
HOPELESS_AFTER_NAMED = (f"not refitted: after a named effect its signature explains < {HOPELESS_SCORE:.1%} of the "
                        "residual left")
NOT_REFITTED = ("not refitted: an earlier candidate of the round already leaves a correct model's residual and this "
                f"one's signature explains < {SETTLED_RIVAL_RATIO:g} times as much of it (or < {HOPELESS_SCORE:.1%})")


def _settled_by(spec: DiagnosisPlant, left: dict[str, float], floor: dict[str, dict[str, Any]]) -> bool:
    """Whether a held-out residual of ``left`` noise floors per channel is a correct model's: at
    most ``SETTLED_FRACTION`` of the channel's threshold factor (``floor``; the plant's
    ``unexplained_factor`` where it carries none) in every channel."""
    return max(over_threshold(left, floor, spec.unexplained_factor).values(), default=math.inf) <= SETTLED_FRACTION


def _floors_left(spec: DiagnosisPlant, model: Model, holdout: Sequence[Record],
                 floor: dict[str, Any]) -> dict[str, float]:
    """Held-out residual of ``model`` per channel, in noise floors."""
    (left,) = heldout_rms(spec, [model], holdout)
    return ratios(left, floor)



def _stroke_notes(spec: DiagnosisPlant, params: PhysicalParams, records: Sequence[Record]) -> list[str]:
    """A note when the recorded position leaves the base model's travel (a base model of another
    rig: its end stops act inside the recorded motion). The travel is ``[0, stroke]``, or
    ``[-stroke/2, stroke/2]`` for plants whose position is zero at mid-stroke (test motion
    centred at 0)."""
    if spec.units.get(spec.position_channel) != "m" or "stroke" not in type(params).names():
        return []
    pos = [r.channels[spec.position_channel] for r in records if spec.position_channel in r.channels]
    if not pos:
        return []
    lo, hi = min(float(p.min()) for p in pos), max(float(p.max()) for p in pos)
    stroke = float(params.stroke)
    a, b = (-0.5 * stroke, 0.5 * stroke) if spec.reference_centre(params) == 0.0 else (0.0, stroke)
    if lo < a or hi > b:
        return [f"the recorded position {spec.position_channel!r} spans [{lo:.4g}, {hi:.4g}] m, outside the base "
                f"model's travel [{a:.4g}, {b:.4g}] m: the base model is not this rig's (give its stroke and mass, "
                "--base), or the position's zero is elsewhere"]
    return []


def _describe_params(spec: DiagnosisPlant, params: PhysicalParams) -> str:
    """The base-fit parameters and, where the plant has them, mass and stroke of ``params``."""
    names = list(spec.base_fit) + [n for n in ("mass", "stroke") if n in type(params).names()
                                   and n not in spec.base_fit]
    return "(" + ", ".join(f"{n} = {float(getattr(params, n)):.4g}" for n in names) + ")"


def _check_base_fit(spec: DiagnosisPlant, fit: FitOutcome, start: Model, records: Sequence[Record], role: str,
                    nrmse: dict[str, float] | None = None) -> None:
    """Raise :class:`DiagnosisFitError` when the fitted base model's free run is not finite on the
    ``role`` windows (fit NRMSE from the fit result, or ``nrmse`` of the held-out windows)."""
    nr = nrmse if nrmse is not None else dict(fit.result.nrmse)
    bad = sorted(k for k, v in nr.items() if not math.isfinite(v))
    if bad:
        raise DiagnosisFitError(
            f"the base fit of {spec.name} failed: the fitted base model has no finite score in channel(s) {bad} on "
            f"the {role} windows (its free run diverges there, or the channel is constant) -- start model {_describe_params(spec, start.params)}, fitted "
            f"{_describe_params(spec, fit.model.params)}; give a base model that matches the rig (--base preset: "
            "mass, stroke and geometry of the record)")


