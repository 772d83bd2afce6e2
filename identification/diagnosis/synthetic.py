r"""Hidden-effect data: closed-loop records of a plant with one catalogue effect hidden in it.

:func:`hidden_effect_records` draws the effect's parameters inside the catalogue's ``draw``
range (the magnitudes of real components), builds the truth = base model + effect, runs the
plant's position loop (:class:`~identification.diagnosis.plants.DiagnosisPlant.controller`,
fed with noisy measurements) around the compiled kernel at twice the sub-steps the fits use,
and records the input and the measured channels with the plant's realistic sensor noise.
It returns a fit record and a separate held-out record (another reference draw), the truth
and the base model the workflow should start from. The tests, the bench and the demo all use it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hydro_envs.params import PhysicalParams
from hydro_envs import registry
from hydro_envs.sim.stiffness import substeps_from_stiffness
from identification.diagnosis.catalogue import effect, effects_for
from identification.diagnosis.plants import DiagnosisPlant, diagnosis_plant, reference_signal
from identification.diagnosis.records import Record
from identification.diagnosis.models import Model, null_base, with_effect

__all__ = ["HiddenEffectCase", "hidden_effect_records", "closed_loop_record", "base_for"]


@dataclasses.dataclass
class HiddenEffectCase:
    plant: str
    effect: str | None
    truth: Model
    base: Model
    drawn: dict[str, float]
    fit: Record
    holdout: Record


def base_for(spec: DiagnosisPlant, effect_name: str | None, params: PhysicalParams | None = None) -> PhysicalParams:
    """The base model a hidden ``effect_name`` is tested against: every effect null except its
    prerequisites (recursively) and -- as on every real rig -- Coulomb friction where the plant
    has it (unless Coulomb friction is the hidden effect); those stay at nominal values."""
    keep: list[str] = []
    todo = list(effect(effect_name).on(spec.name).requires) if effect_name else []
    if effect_name != "coulomb" and any(e.name == "coulomb" for e in effects_for(spec.name)):
        todo.append("coulomb")
    while todo:
        n = todo.pop()
        if n not in keep:
            keep.append(n)
            todo += list(effect(n).on(spec.name).requires)
    return null_base(spec, params, keep=keep)


def closed_loop_record(spec: DiagnosisPlant, truth: Model, duration: float, dt: float, rng: np.random.Generator,
                       name: str = "") -> Record:
    """Run the plant's position loop on ``truth`` for ``duration`` s; noisy record at ``dt``."""
    p = truth.params
    n = int(round(duration / dt)) + 1
    t = dt * np.arange(n)
    if spec.reference is not None:  # open-loop test signal (the controller maps it to the input)
        ref = spec.reference(t, rng)
        x0 = spec.reference_centre(p)
    else:
        ref = spec.reference_centre(p) + reference_signal(t, spec.reference_amplitude, spec.reference_speed, rng)
        x0 = float(ref[0])
    dref = np.gradient(ref, dt)
    u0 = spec.controller({"x": x0, "v": 0.0}, (ref[0], dref[0]), p)
    y = spec.initial_state(p, {spec.position_channel: x0, "v": 0.0, "u": u0})[None, :].copy()
    P = p.to_array()[None, :]
    plant = registry.get(type(p).plant)
    nsub = 2 * substeps_from_stiffness(plant.stiffness_modes(p), dt)[0]
    NSUB = np.array([nsub], dtype=np.int64)
    W = np.empty((1, 5, spec.n_states))
    clamps = np.zeros(1, dtype=np.int64)
    U = np.zeros((1, max(len(spec.inputs), spec.kernel_inputs)))
    states = np.empty((n, spec.n_states))
    derivs = {k: np.empty(n) for k in spec.derivative_outputs}
    inputs = np.empty((n, len(spec.inputs)))
    noise = {k: spec.noise.get(k, 0.0) for k in list(spec.outputs) + list(spec.derivative_outputs)}
    v_filt = 0.0
    x_prev = None
    alpha = dt / (dt + 0.005)
    dy = np.empty(spec.n_states)
    meas_hist = []
    for k in range(n):
        states[k] = y[0]
        x_meas = y[0, spec.position_state] + noise[spec.position_channel] * rng.standard_normal()
        meas_hist.append(x_meas)
        # measurement seen by the controller (delayed when a sensor delay is hidden)
        kd = int(round(truth.delay / dt))
        x_c = meas_hist[max(0, k - kd)]
        if x_prev is not None:
            v_filt += alpha * ((x_c - x_prev) / dt - v_filt)
        x_prev = x_c
        U[0, 0] = spec.controller({"x": x_c, "v": v_filt}, (ref[k], dref[k]), p)
        inputs[k] = U[0, : len(spec.inputs)]
        if derivs:
            plant.kernels.rhs(y[0], U[0], P[0], dy)
            for c, i in spec.derivative_outputs.items():
                derivs[c][k] = dy[i]
        if k < n - 1:
            plant.kernels.step_serial(y, U, P, dt, NSUB, W, clamps)
    if not np.all(np.isfinite(states)):
        raise RuntimeError(f"synthetic {spec.name} record diverged")
    chans = {}
    for c, i in spec.outputs.items():
        clean = i(states[None], P)[0] if callable(i) else states[:, i]
        chans[c] = clean + noise[c] * rng.standard_normal(n)
    for c in spec.derivative_outputs:
        chans[c] = derivs[c] + noise[c] * rng.standard_normal(n)
    if truth.delay > 0:
        for e in effects_for(spec.name):
            if e.kind == "sensor":
                for c in e.on(spec.name).channels:
                    o = spec.outputs.get(c)
                    src = derivs[c] if o is None else (o(states[None], P)[0] if callable(o) else states[:, o])
                    clean = np.interp(t - truth.delay, t, src)
                    chans[c] = clean + noise[c] * rng.standard_normal(n)
    rec_inputs = inputs.copy()
    for j, c in enumerate(spec.inputs):
        s = spec.noise.get(c, 0.0)
        if s > 0:
            rec_inputs[:, j] = inputs[:, j] + s * rng.standard_normal(n)
    return Record(dt, rec_inputs, chans, name or f"{spec.name} closed loop")


def draw_effect(spec: DiagnosisPlant, effect_name: str, base: Model, rng: np.random.Generator) -> dict[str, float]:
    """Parameters of a hidden effect drawn from its catalogue ``draw`` range (log-uniform for
    log parameters, factors of ``relative_to`` fields applied)."""
    e = effect(effect_name)
    r = e.on(spec.name)
    drawn = {}
    for p in r.parameters:
        lo, hi = p.draw
        f = float(np.exp(rng.uniform(math.log(lo), math.log(hi)))) if (p.log and lo > 0) else float(rng.uniform(lo, hi))
        drawn[p.field] = f * float(getattr(base.params, p.relative_to)) if p.relative_to else f
        # signed effects (a signed field whose null is 0: asymmetry, force offset): both
        # signs; not the valve lap (the draws are overlaps) nor a field with another null
        # (an oil temperature of -23 C instead of 23 C)
        signed = not p.log and p.bounds[0] < 0 < p.bounds[1] and r.null.get(p.field) == 0.0
        if signed and rng.uniform() < 0.5 and effect_name not in ("valve_lap",):
            drawn[p.field] = -drawn[p.field]
    return drawn


def hidden_effect_records(plant: str, effect_name: str | None, seed: int, *, duration: float = 6.0,
                          holdout_duration: float | None = None, dt: float | None = None) -> HiddenEffectCase:
    """Fit and held-out records of ``plant`` with ``effect_name`` (or none) hidden in them."""
    spec = diagnosis_plant(plant)
    dt = spec.sample_time if dt is None else dt
    rng = np.random.default_rng(seed)
    base = Model(base_for(spec, effect_name))
    drawn: dict[str, float] = {}
    truth = base
    if effect_name is not None:
        drawn = draw_effect(spec, effect_name, base, rng)
        truth = with_effect(spec, base, effect_name, drawn)
    fit = closed_loop_record(spec, truth, duration, dt, rng, f"{plant}+{effect_name or 'none'} seed {seed}")
    hold = closed_loop_record(spec, truth, holdout_duration or duration / 2, dt, rng, "held-out")
    return HiddenEffectCase(plant, effect_name, truth, base, drawn, fit, hold)
