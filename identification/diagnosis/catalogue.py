r"""Effect catalogue of the diagnosis workflow: named, parametrised augmentations of a plant.

An :class:`Effect` is a physical mechanism (Stribeck friction, internal leakage, the
modified-IFAS stiffness dip, ...) with, for every plant it applies to, a
:class:`Realisation`: which fields of the plant's parameter dataclass carry it, their value
when the effect is absent (``null``), their physically plausible fit bounds, the range the
hidden-effect tests draw from (``draw``: magnitudes of real components, large enough to be
seen above sensor noise), other fields the effect switches (``switch``, e.g. the bulk-modulus
law), and the effects it needs first (``requires``: a Stribeck peak is defined relative to a
Coulomb level). Effects of the measuring chain (``kind="sensor"``) act on the recorded
channels instead of the plant.

Presence: an effect is *present* in a parameter set when any of its fields differs from its
null value; the workflow refits present effects with the base model and proposes the absent
ones. While an effect is absent its ``ties`` keep dependent fields consistent (without a
Stribeck effect the static level equals the Coulomb level).

Every realisation names its source: the seed equation it comes from or the seed/data sheet
its range is taken from.

The hydraulic damping by flow forces of 001 eq (5) acts only on a moving piston: it is
diagnosed on ``force_actuator_load`` (001's actuator driving a spring-loaded mass, static
friction curve instead of the Dahl state; identification.diagnosis.plants), not on the
blocked-piston rig ``force_actuator``.

Stribeck friction is kept for the shaking table only for its null value (static = Coulomb
level in the base model) and is never proposed (``diagnosable=False``): 003 eqs (11)-(12) multiply the whole
friction curve by the soft sign tanh(7.33 v) (v_eps = 0.14 m/s), so the Stribeck excess is
multiplied by <= 0.2 at any speed where it has not decayed; in simulated records with F_s =
2 F_c hidden, the fitted Coulomb level absorbed it to within 4 % of the held-out error
(measured while building the catalogue) -- the data cannot name it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

__all__ = ["EffectParameter", "Realisation", "Effect", "CATALOGUE", "effect", "effects_for", "catalogue_table"]


@dataclasses.dataclass(frozen=True)
class EffectParameter:
    """One fitted field of an effect.

    ``bounds``: physical plausibility (fit bounds; a fit that ends on a bound is implausible);
    ``plausible``: where the fit needs room beyond what a working rig can have, the narrower range
    of plausible values (a fit outside it is not named; None: the bounds);
    ``start``: start value of the fit; ``draw``: range of the hidden-effect tests; with
    ``relative_to`` both ``start`` and ``draw`` are factors times the current value of that
    field (bounds stay absolute); ``log``: fit log(value).
    """

    field: str
    bounds: tuple[float, float]
    start: float
    draw: tuple[float, float]
    relative_to: str | None = None
    log: bool = True
    plausible: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        lo, hi = self.bounds
        if not lo < hi:
            raise ValueError(f"EffectParameter {self.field}: bounds {self.bounds} must have lo < hi")
        if self.plausible is not None:
            a, b = self.plausible
            if not lo <= a < b <= hi:
                raise ValueError(f"EffectParameter {self.field}: plausible range {self.plausible} must lie inside "
                                 f"the bounds {self.bounds}")
            if self.relative_to is None and not a <= self.draw[0] <= self.draw[1] <= b:
                raise ValueError(f"EffectParameter {self.field}: draw range {self.draw} outside the plausible "
                                 f"range {self.plausible}")
        if self.relative_to is None and not (lo < self.start < hi):
            raise ValueError(f"EffectParameter {self.field}: start {self.start} outside bounds {self.bounds}")
        if self.relative_to is None and not (lo <= self.draw[0] <= self.draw[1] <= hi):
            raise ValueError(f"EffectParameter {self.field}: draw range {self.draw} outside bounds {self.bounds}")


@dataclasses.dataclass(frozen=True)
class Realisation:
    """How an effect is carried by one plant (see the module docstring)."""

    parameters: tuple[EffectParameter, ...]
    null: Mapping[str, float | str]  # absent when every listed field equals this (value or field)
    switch: Mapping[str, float] = dataclasses.field(default_factory=dict)
    requires: tuple[str, ...] = ()
    ties: Mapping[str, str] = dataclasses.field(default_factory=dict)  # absent: target <- source field
    source: str = ""
    channels: tuple[str, ...] = ()  # sensor effects: the channels they act on
    present: Any = None  # optional ``params -> bool``; default: a field differs from ``null``
    diagnosable: bool = True  # False: kept for its null/ties only, never proposed (reason in source)
    # optional ``(params, channels, inputs, dt, around=None, level=0) -> [ {field: value} ]``: start
    # points of a refit read off a record, in place of the grid over the bounds; ``level`` > 0 a
    # finer set about ``around`` (the best of the level before), [] when there is none (at level 0:
    # the grid over the bounds instead). An effect that has them is refitted from them even when
    # its score test ranks it low (examples: ``stribeck_starts`` of the slider and the servo)
    start_points: Any = None

    def is_present(self, params: Any) -> bool:
        """True when ``params`` already carry this effect."""
        if self.present is not None:
            return bool(self.present(params))
        for f, null in self.null.items():
            ref = getattr(params, null) if isinstance(null, str) else null
            if float(getattr(params, f)) != float(ref):
                return True
        return False

    @property
    def fields(self) -> tuple[str, ...]:
        return tuple(p.field for p in self.parameters)


@dataclasses.dataclass(frozen=True)
class Effect:
    """A named physical effect of the catalogue."""

    name: str
    title: str
    signature: str  # where its residual shows (what the residual maps look for)
    realisations: Mapping[str, Realisation] = dataclasses.field(default_factory=dict)  # base -> realisation
    kind: str = "plant"  # or "sensor"
    separating_experiment: str = ""  # what to run when it is confused with another effect

    def applies_to(self, plant: str) -> bool:
        return plant in self.realisations

    def on(self, plant: str) -> Realisation:
        try:
            return self.realisations[plant]
        except KeyError:
            raise KeyError(f"effect {self.name!r} does not apply to plant {plant!r}; "
                           f"it applies to {sorted(self.realisations)}") from None



# --------------------------------------------------------------------------- the catalogue
_EFFECTS: list[Effect] = [
    Effect(
        "coulomb", "Coulomb friction",
        "a step in the force balance at every velocity reversal (residual vs velocity: odd, "
        "constant magnitude away from v = 0)",
        separating_experiment="slow constant-velocity passes in both directions (002 sec. 4): "
        "Coulomb friction is a velocity-independent level",
    ),
    Effect(
        "stribeck", "Stribeck friction (static > Coulomb)",
        "extra friction at low speed decaying over a few v_S (residual vs velocity concentrated "
        "below ~3 v_S), stick-slip at velocity reversals",
        separating_experiment="constant-velocity tests below and above 3 v_S (002 sec. 4): the "
        "Stribeck peak decays with speed, a Coulomb level does not",
    ),
    Effect(
        "asymmetric_friction", "Asymmetric (direction-dependent) friction",
        "friction residual of one sign for both directions of motion (residual vs velocity: even "
        "part)",
        separating_experiment="constant-velocity passes at the same speed in both directions",
    ),
    Effect(
        "force_offset", "Constant force on the axis (force-sensor bias, gravity, cable drag)",
        "a force of one sign whatever the motion: residual vs velocity even, present at rest "
        "(a force-sensor zero error, gravity on an inclined axis and cable-chain drag are one "
        "constant in force and position data)",
        separating_experiment="force reading with the axis at rest and unloaded (sensor bias), or "
        "the axis tilted (gravity); a direction-dependent friction level differs from it only "
        "near standstill",
    ),
    Effect(
        "backlash", "Backlash (play between the drive and the measured load)",
        "lost motion at every reversal of the drive force: the measured position lags the "
        "commanded motion by up to twice the play, then the load is caught with a jolt (residual "
        "concentrated just after force reversals, of either sign)",
        separating_experiment="a slow triangle of the drive with a second sensor on the driven "
        "side (motor encoder): the two positions differ by a dead band of 2 g at each reversal",
    ),
    Effect(
        "pressure_friction", "Pressure-dependent friction",
        "friction residual growing with the pressure difference across the piston seal "
        "(residual vs |p1 - p2|)",
        separating_experiment="constant-velocity passes under different loads (pressure "
        "differences) or supply pressures",
    ),
    Effect(
        "internal_leakage", "Internal (cross-piston) leakage",
        "load pressure decays through the piston: pressure difference and position drift at "
        "null command, extra damping of the oil-spring resonance",
        separating_experiment="blocked piston, valve at null, load pressure step: internal leakage "
        "equalises p1 and p2, external leakage lowers both",
    ),
    Effect(
        "external_leakage", "External leakage (chambers to tank)",
        "both chamber pressures sag below the valve's null pressure (residual in p1 + p2)",
        separating_experiment="blocked piston, valve at null: watch the mean chamber pressure",
    ),
    Effect(
        "valve_lap", "Valve underlap / overlap (dead band)",
        "flow gain changes near null command: dead band (overlap) or leakage flow and pressure "
        "gain loss at null (underlap); residual vs command concentrated at small |u|",
        separating_experiment="slow command ramp through null with the piston blocked (pressure gain) "
        "and free (flow gain)",
    ),
    Effect(
        "supply_droop", "Supply pressure droop with flow",
        "the valve delivers less flow than the orifice law at a constant supply pressure when it "
        "draws much flow: velocity gain lost at large openings in both directions, the supply-side "
        "chamber pressure lower while moving fast (residual grows with |command| and |velocity|)",
        separating_experiment="a pressure gauge on the valve's P port during fast full-opening moves: "
        "a stiff supply holds p_s, a drooping one falls with the flow; valve lap acts near null instead",
    ),
    Effect(
        "valve_dynamics", "Valve dynamics (finite spool bandwidth)",
        "phase lag and gain loss of the response to fast commands in every channel (residual "
        "vs frequency rising with frequency)",
        separating_experiment="frequency response of the spool (or of the blocked-piston pressure) "
        "to a swept sine: a second-order roll-off, not a pure delay",
    ),
    Effect(
        "ifas", "Pressure-dependent bulk modulus (IFAS, entrained air)",
        "the oil spring softens at low chamber pressure: resonance frequency and damping change "
        "with the pressure level (residual vs pressure, at the oil-spring frequency)",
        separating_experiment="oil-spring resonance (blocked-valve ring-down) at two supply pressures",
    ),
    Effect(
        "modified_ifas", "Modified-IFAS stiffness dip at small load pressure",
        "extra compliance while |pa - pb| < P_Lt: low-amplitude motion rings at a lower frequency "
        "than large motion (residual at small load pressure)",
        separating_experiment="the six inputs of 003 Table 3: small- and large-amplitude sines",
    ),
    Effect(
        "presliding", "Pre-sliding (LuGre / Dahl bristle) dynamics",
        "elastic micro-displacement before breakaway and friction lag after reversals: residual at "
        "velocity reversals and small motions, hysteresis of friction vs position",
        separating_experiment="small-amplitude position steps below breakaway: pre-sliding "
        "moves elastically and springs back, a static friction curve does not move",
    ),
    Effect(
        "lvdt", "Added sensor mass and friction (LVDT core on the spool)",
        "lower mechanical resonance (added mass) and more damping: residual of the spool motion "
        "at the spool-spring resonance",
        separating_experiment="method-2 resonance with and without the LVDT (000 sec. 5): the mass "
        "shifts the resonance, a viscosity change does not",
    ),
    Effect(
        "viscous_temperature", "Viscous friction changed by oil temperature",
        "more damping of the spool and more pipe resistance (both scale with the oil viscosity) "
        "at an unchanged resonance frequency",
        separating_experiment="repeat the test at a measured oil temperature (000 sec. 3.4)",
    ),
    Effect(
        "valve_hysteresis", "Valve hysteresis",
        "the output depends on the direction the command came from: residual of opposite sign on "
        "rising and falling command, largest right after command reversals",
        separating_experiment="slow triangular current sweep with the piston blocked (001 sec. 3.1): "
        "the force branches separate by the hysteresis width",
    ),
    Effect(
        "flow_force_damping", "Hydraulic damping by flow forces (001 eq (5))",
        "a force opposing the piston velocity that grows steeply as the speed approaches the "
        "valve's flow-limited (knee) speed and saturates past it: sensed-force residual odd in "
        "velocity, small at low speed, largest in the fast parts of the motion",
        separating_experiment="constant-current steps with the piston free against the load: the "
        "force drop with speed saturates at the valve's flow-limited speed (eq (5)); viscous "
        "damping grows linearly",
    ),
    Effect(
        "sensor_delay", "Transport delay of the measurement (sensor dynamics)",
        "the measured position lags the model by a constant time at every frequency (residual "
        "proportional to velocity)",
        kind="sensor",
        separating_experiment="a step of the command: a delay shifts the whole response, valve "
        "dynamics round it",
    ),
]



def _realisation(d: Mapping[str, Any]) -> Realisation:
    """A :class:`Realisation` from a plant folder's plain-data description."""
    extra = {k: v for k, v in d.items() if k not in ("parameters", "null")}
    return Realisation(tuple(EffectParameter(**p) for p in d["parameters"]), d["null"], **extra)


def _with_realisations(effects: list[Effect]) -> list[Effect]:
    """The catalogue's effects with their per-plant realisations, read from the ``diagnosis``
    module of every registered plant folder (:data:`BASES` there: one entry per base model)."""
    from hydro_envs import registry

    per_effect: dict[str, dict[str, Realisation]] = {e.name: {} for e in effects}
    for spec in registry.specs():
        if not spec.has_module("diagnosis"):
            continue
        for base, settings in spec.module("diagnosis").BASES.items():
            for name, d in settings.get("effects", {}).items():
                if name not in per_effect:
                    raise KeyError(f"plant {spec.name!r} base {base!r}: unknown effect {name!r}; "
                                   f"catalogue: {sorted(per_effect)}")
                per_effect[name][base] = _realisation(d)
    return [dataclasses.replace(e, realisations=per_effect[e.name]) for e in effects]


_EFFECTS = _with_realisations(_EFFECTS)
CATALOGUE: dict[str, Effect] = {e.name: e for e in _EFFECTS}


def effect(name: str) -> Effect:
    """The catalogue effect ``name`` (clear error listing the known names)."""
    try:
        return CATALOGUE[name]
    except KeyError:
        raise KeyError(f"unknown effect {name!r}; catalogue: {sorted(CATALOGUE)}") from None


def effects_for(plant: str, diagnosable_only: bool = False) -> list[Effect]:
    """Effects that apply to ``plant``, in catalogue order (``diagnosable_only``: the ones the
    workflow may propose)."""
    return [e for e in _EFFECTS if e.applies_to(plant) and (not diagnosable_only or e.on(plant).diagnosable)]


def catalogue_table() -> list[dict[str, Any]]:
    """One row per (effect, plant): fields, bounds, draw range, requirements, source."""
    rows = []
    for e in _EFFECTS:
        for plant, r in e.realisations.items():
            rows.append({
                "effect": e.name, "title": e.title, "plant": plant, "kind": e.kind,
                "parameters": {p.field: {"bounds": list(p.bounds), "draw": list(p.draw),
                                         "relative_to": p.relative_to} for p in r.parameters},
                "switch": dict(r.switch), "requires": list(r.requires), "source": r.source,
            })
    return rows
