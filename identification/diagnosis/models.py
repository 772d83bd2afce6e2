"""Base-model settings of the diagnosis workflow: acceptance thresholds, the :class:`Model`
(parameters plus the effects it carries), effect switching, ties and the fitted-parameter sets."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from hydro_envs.params import PhysicalParams
from identification import greybox as gb
from identification.diagnosis.catalogue import effect, effects_for
from identification.diagnosis.plants import DiagnosisPlant

ACCEPT_GAIN = 0.10
MARGIN = 0.15
MAX_REL_SE = 0.3
BOUND_TOL = 1e-3
# noise level of a channel: the standard deviation of the final model's residual over the
# scored samples. An estimated sensor offset, or a mean residual, above OFFSET_ESTIMATE_FLAG
# noise levels is a finding (the constant part of model error on effect-free rodless records
# is ~0.7 levels; a transducer zero error of 0.1-0.5 % of full scale is several); a change of
# the mean residual between the two halves of the data above DRIFT_FLAG levels is flagged as
# drift
OFFSET_ESTIMATE_FLAG = 2.0
DRIFT_FLAG = 1.0
# a candidate whose signature explains at least this fraction of the weighted residual (score
# test, :func:`signature_scores`) is refitted from a second, cold start as well (see
# :func:`_fit_candidate`); below it a cold start runs only when the warm fit fails or ends on
# a bound or violates a relation. On effect-free data every score is ~0; the true effect of the
# hidden-effect tests scores far above it
COLD_START_SCORE = 0.05
# below this score (the signature explains < 0.5 % of the weighted residual: on the
# hidden-effect tests the true effect scored >= 0.013, effect-free records ~0) a candidate is
# ranked hopeless: its refit (warm start only) stops after HOPELESS_NFEV residual evaluations
# instead of 25; in the first round it is still refitted and scored on the held-out data like
# every other candidate (on the effect-free rodless record the two hopeless candidates took 10
# and 8 evaluations for a held-out change of +0.1 % and -42 %: the first few steps already show
# the effect explains nothing); after a named effect it is not refitted (a round where every
# candidate is hopeless ends without refits)
HOPELESS_SCORE = 0.005
HOPELESS_NFEV = 5
# a round is settled once a plausible, identifiable candidate that passes ``accept_gain`` leaves at
# most this fraction of the plant's ``unexplained_factor`` noise floors of held-out residual (the
# factor is twice what a correctly named model leaves, so this is a correct model's residual); the
# candidates after it get their warm refit only (no cold start, no start grid, also when the warm fit
# ends implausible): a rival would have to match that residual to make the round ambiguous, and its
# warm refit shows whether it comes near. The rodless 20 s underlap record spent 68 of its 165 s on
# the Stribeck candidate's warm and cold refits after valve_lap had left 8.7 floors
SETTLED_FRACTION = 0.5
# after a named effect, a held-out residual of at most this many noise floors in every channel is
# noise: nothing more is named (a further "gain" there fits the noise: on the independent axis record
# with Coulomb friction hidden, a 12 % gain named a backlash with 97 % of the mass beyond the play after
# coulomb had left 1.24 floors)
AT_NOISE_FLOOR = 2.0


# ======================================================================================
# models
# ======================================================================================


@dataclasses.dataclass
class Model:
    """A plant parameter set plus the measuring-chain effects (delay of named channels)."""

    params: PhysicalParams
    delay: float = 0.0
    # sensor offsets of the plant's ``sensor_offsets`` channels (None: not modelled); fitted
    # as nuisance parameters, then applied as fixed corrections when the model is simulated
    offsets: dict[str, float] | None = None
    # bounds of the base-fit parameters (:func:`base_fit_bounds`, fixed from the start model
    # for the whole diagnosis); None: their allowed ranges
    base_bounds: dict[str, tuple[float, float]] | None = None

    def copy(self, **kw) -> Model:
        return dataclasses.replace(self, **kw)


# the diagnosis refines a calibrated base model: its base-fit parameters stay within this
# factor of the start values. Unbounded, a base fit that tries to absorb a missing effect can
# run to values no rig has (slider with a hidden force offset: mass 1 kg -> 0.036 kg), and the
# cost of a rollout grows with the stiffness of such a model (sub-steps ~ 1/mass: 28 times, a
# 4-minute base fit); a parameter ending on this bound is flagged in the notes (a better base
# model is needed). An order of magnitude, not less: a refit that starts next to a bound moves
# away from it slowly (trust-region scaling), and a factor of 4 cost a Stribeck case whose base
# fit had put the viscous coefficient at 1/4 of its value.
BASE_FIT_FACTOR = 10.0


def base_fit_bounds(spec: DiagnosisPlant, params: PhysicalParams, factor: float = BASE_FIT_FACTOR
                    ) -> dict[str, tuple[float, float]]:
    """Bounds of the base-fit parameters: ``[v / factor, v * factor]`` around the start value
    ``v``, inside the field's allowed range (fields with a value <= 0 keep their allowed range)."""
    allowed = {f.name: f.metadata.get("allowed") for f in dataclasses.fields(params)}
    out = {}
    for n in spec.base_fit:
        v = float(getattr(params, n))
        if not v > 0:
            continue
        lo, hi = allowed.get(n) or (0.0, math.inf)
        out[n] = (max(lo, v / factor), min(hi, v * factor))
    return out


def present_effects(spec: DiagnosisPlant, model: Model) -> list[str]:
    """Catalogue effects already present in ``model``."""
    out = []
    for e in effects_for(spec.name):
        if e.kind == "sensor":
            if model.delay > 0:
                out.append(e.name)
        elif e.on(spec.name).is_present(model.params):
            out.append(e.name)
    return out


def _replace_tied(spec: DiagnosisPlant, params: PhysicalParams, changes: dict[str, float],
                  present: Sequence[str]) -> PhysicalParams:
    """``params`` with ``changes`` and the ties of every absent effect applied on the changed
    values (one ``replace``, so relations are checked only on the consistent result)."""
    changes = dict(changes)
    for e in effects_for(spec.name):
        if e.kind == "plant" and e.name not in present:
            for tgt, src in e.on(spec.name).ties.items():
                changes[tgt] = changes.get(src, getattr(params, src))
    return dataclasses.replace(params, **changes)


def _tie_function(spec: DiagnosisPlant, params: PhysicalParams, present: Sequence[str]):
    names = type(params).names()
    pairs = []
    for e in effects_for(spec.name):
        if e.kind == "plant" and e.name not in present:
            for tgt, src in e.on(spec.name).ties.items():
                pairs.append((names.index(tgt), names.index(src)))
    if not pairs:
        return None

    def tie(P):
        for t, s in pairs:
            P[:, t] = P[:, s]
    return tie


def prerequisites(spec: DiagnosisPlant, name: str) -> set[str]:
    """Every effect that effect ``name`` needs on ``spec``'s plant, directly or through another."""
    out, todo = set(), list(effect(name).on(spec.name).requires)
    while todo:
        n = todo.pop()
        if n not in out:
            out.add(n)
            todo += list(effect(n).on(spec.name).requires)
    return out


def null_base(spec: DiagnosisPlant, params: PhysicalParams | None = None,
              keep: Sequence[str] = ()) -> PhysicalParams:
    """``params`` (default nominal) with every applicable plant effect not in ``keep`` at its
    null value (the effect-free base model)."""
    p = params or spec.params_factory()
    changes: dict[str, float] = {}
    for e in effects_for(spec.name):
        if e.kind != "plant" or e.name in keep:
            continue
        for f, v in e.on(spec.name).null.items():
            if not isinstance(v, str):
                changes[f] = v
    return _replace_tied(spec, p, changes, keep)


def with_effect(spec: DiagnosisPlant, model: Model, name: str, values: dict[str, float] | None = None) -> Model:
    """``model`` with effect ``name`` added at ``values`` (default: the effect's start values)."""
    e = effect(name)
    r = e.on(spec.name)
    vals = {}
    for p in r.parameters:
        if values and p.field in values:
            vals[p.field] = float(values[p.field])
        elif p.relative_to is not None:
            vals[p.field] = p.start * float(getattr(model.params, p.relative_to))
        else:
            vals[p.field] = p.start
    if e.kind == "sensor":
        return model.copy(delay=vals["delay"])
    present = present_effects(spec, model) + [name]
    return model.copy(params=_replace_tied(spec, model.params, {**dict(r.switch), **vals}, present))


def _scored(e: gb.Experiment) -> np.ndarray | slice:
    """Samples of a window that are scored (after its warm-up)."""
    return slice(None) if e.weights is None else e.weights > 0


def _demeaned_state(i: int, frac: float):
    """Output function: state ``i`` minus its mean over the scored part of the window."""
    def func(S, P):
        kw = int(round(frac * S.shape[1]))
        y = S[:, :, i]
        return y - y[:, kw:].mean(axis=1, keepdims=True)
    return func


def _channels(spec: DiagnosisPlant) -> list[gb.OutputChannel]:
    frac = spec.warmup_seconds / (spec.warmup_seconds + spec.segment_seconds)
    ch = [gb.OutputChannel(k, func=i) if callable(i)
          else gb.OutputChannel(k, func=_demeaned_state(i, frac)) if k in spec.offset_free
          else gb.OutputChannel(k, state=i) for k, i in spec.outputs.items()]
    ch += [gb.OutputChannel(k, derivative=i) for k, i in spec.derivative_outputs.items()]
    return ch


def _delayed_channels(spec: DiagnosisPlant) -> tuple[str, ...]:
    for e in effects_for(spec.name):
        if e.kind == "sensor":
            return e.on(spec.name).channels
    return ()


def _fit_names(spec: DiagnosisPlant, model: Model) -> tuple[list[str], dict[str, tuple[float, float]], dict[str, bool]]:
    """Fitted fields (base-fit + present effects), their bounds and log-scaling."""
    names = list(spec.base_fit)
    bounds = dict(model.base_bounds or {})
    log = {n: float(getattr(model.params, n)) > 0 for n in names}  # signed ones (offsets) linear
    for name in present_effects(spec, model):
        e = effect(name)
        if e.kind == "sensor":
            continue
        for p in e.on(spec.name).parameters:
            if p.field not in names:
                names.append(p.field)
                bounds[p.field] = p.bounds
                log[p.field] = p.log
    return names, bounds, log


# ======================================================================================
# fit and score
# ======================================================================================



#: name of the measuring-chain candidate (a constant offset per pressure channel)
SENSOR_OFFSETS = "sensor_offsets"
