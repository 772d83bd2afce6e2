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
import math
from collections.abc import Mapping
from typing import Any

__all__ = ["EffectParameter", "Realisation", "Effect", "CATALOGUE", "effect", "effects_for", "catalogue_table"]


@dataclasses.dataclass(frozen=True)
class EffectParameter:
    """One fitted field of an effect.

    ``bounds``: physical plausibility (fit bounds; a fit that ends on a bound is implausible);
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

    def __post_init__(self) -> None:
        lo, hi = self.bounds
        if not lo < hi:
            raise ValueError(f"EffectParameter {self.field}: bounds {self.bounds} must have lo < hi")
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
    realisations: Mapping[str, Realisation]
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


def _p(field, bounds, start, draw, relative_to=None, log=True):
    return EffectParameter(field, bounds, start, draw, relative_to, log)


_SERVO = "002_af30b681d6ccfd6c.txt"
_TABLE = "003_54985feb8193da53.txt"
_PNEU = "004 (seed pneumatic rodless cylinder)"
_FORCE = "001 (seed force actuator)"

# --------------------------------------------------------------------------- the catalogue
_EFFECTS: list[Effect] = [
    Effect(
        "coulomb", "Coulomb friction",
        "a step in the force balance at every velocity reversal (residual vs velocity: odd, "
        "constant magnitude away from v = 0)",
        {
            "slider": Realisation(
                (_p("coulomb_friction", (0.05, 1e3), 5.0, (4.0, 15.0)),), {"coulomb_friction": 0.0},
                source=f"{_SERVO} eq (1) F_C"),
            "servo_cylinder": Realisation(
                (_p("coulomb_friction", (0.5, 2e3), 30.0, (25.0, 80.0)),), {"coulomb_friction": 0.0},
                source=f"{_SERVO} eq (1) F_C; range: tens of N for a 6.63 cm^2 seal set"),
            "shaking_table": Realisation(
                (_p("coulomb_friction", (5.0, 2e4), 400.0, (300.0, 900.0)),), {"coulomb_friction": 0.0},
                source=f"{_TABLE} eq (11) F_c; Table 2: 573.7 N (modified IFAS), 531.9 N (IFAS)"),
            "rodless_cylinder": Realisation(
                (_p("coulomb_friction", (0.1, 500.0), 10.0, (10.0, 25.0)),), {"coulomb_friction": 0.0},
                source=f"{_PNEU} eq (1), Table 2: F_c = 15.31 N"),
        },
        separating_experiment="slow constant-velocity passes in both directions (002 sec. 4): "
        "Coulomb friction is a velocity-independent level",
    ),
    Effect(
        "stribeck", "Stribeck friction (static > Coulomb)",
        "extra friction at low speed decaying over a few v_S (residual vs velocity concentrated "
        "below ~3 v_S), stick-slip at velocity reversals",
        {
            "slider": Realisation(
                (_p("static_friction", (0.05, 1e3), 1.6, (1.4, 2.2), "coulomb_friction"),
                 _p("stribeck_velocity", (2e-4, 0.2), 4e-3, (2.5e-3, 1e-2))),
                {"static_friction": "coulomb_friction"}, requires=("coulomb",),
                ties={"static_friction": "coulomb_friction"},
                source=f"{_SERVO} eq (1); 004 Table 2: F_s/F_c = 2.3, v_s = 3.27 mm/s"),
            "servo_cylinder": Realisation(
                (_p("static_friction", (0.5, 4e3), 1.6, (1.4, 2.2), "coulomb_friction"),
                 _p("stribeck_velocity", (5e-4, 0.5), 0.01, (5e-3, 2e-2))),
                {"static_friction": "coulomb_friction"}, requires=("coulomb",),
                ties={"static_friction": "coulomb_friction"},
                source=f"{_SERVO} eq (1) F_S, v_S; ratio F_S/F_C 1.4-2.2 of lubricated seals"),
            "shaking_table": Realisation(
                (_p("static_friction", (5.0, 4e4), 1.8, (1.5, 2.4), "coulomb_friction"),
                 _p("stribeck_velocity", (1e-3, 0.5), 0.06, (0.04, 0.1))),
                {"static_friction": "coulomb_friction"}, requires=("coulomb",),
                ties={"static_friction": "coulomb_friction"}, diagnosable=False,
                source=f"{_TABLE} eqs (11)-(12); Table 2: F_s/F_c = 2.19 / 1.79, v_s = 0.014 / 0.08 m/s "
                "(not diagnosable: see the module docstring)"),
            "rodless_cylinder": Realisation(
                (_p("static_friction", (0.1, 1e3), 1.8, (1.8, 2.6), "coulomb_friction"),
                 _p("stribeck_velocity", (2e-4, 0.1), 3e-3, (2e-3, 6e-3))),
                {"static_friction": "coulomb_friction"}, requires=("coulomb",),
                ties={"static_friction": "coulomb_friction"},
                source=f"{_PNEU} eq (1), Table 2: F_s/F_c = 2.32, v_s = 3.27 mm/s"),
        },
        separating_experiment="constant-velocity tests below and above 3 v_S (002 sec. 4): the "
        "Stribeck peak decays with speed, a Coulomb level does not",
    ),
    Effect(
        "asymmetric_friction", "Asymmetric (direction-dependent) friction",
        "friction residual of one sign for both directions of motion (residual vs velocity: even "
        "part)",
        {
            "slider": Realisation(
                (_p("force_offset", (-1e3, 1e3), 1.0, (2.0, 6.0), log=False),), {"force_offset": 0.0},
                requires=("coulomb",),
                source="slider F_0: a level difference F_0 between the two directions of motion "
                "(sliding levels F_C + F_0 and F_C - F_0); cf. 001 stiction +99 / -54 N"),
            "servo_cylinder": Realisation(
                (_p("friction_asymmetry", (-0.9, 0.9), 0.1, (0.2, 0.5), log=False),),
                {"friction_asymmetry": 0.0}, requires=("coulomb",),
                source="001 Table: stiction +99 N / -54 N (asymmetry 0.29) for a rod/cap seal pair"),
        },
        separating_experiment="constant-velocity passes at the same speed in both directions",
    ),
    Effect(
        "pressure_friction", "Pressure-dependent friction",
        "friction residual growing with the pressure difference across the piston seal "
        "(residual vs |p1 - p2|)",
        {
            "servo_cylinder": Realisation(
                (_p("friction_pressure_coefficient", (1e-8, 1e-4), 1e-5, (1e-5, 3e-5)),),
                {"friction_pressure_coefficient": 0.0}, requires=("coulomb",),
                source="seal data tests/data/pneumatic_seal_friction: +11.4 N over 6 bar, i.e. "
                "~1.9e-5 N/Pa for a 25 mm seal; draws 1-3e-5 N/Pa: 10-30 N at 10 bar"),
        },
        separating_experiment="constant-velocity passes under different loads (pressure "
        "differences) or supply pressures",
    ),
    Effect(
        "internal_leakage", "Internal (cross-piston) leakage",
        "load pressure decays through the piston: pressure difference and position drift at "
        "null command, extra damping of the oil-spring resonance",
        {
            "servo_cylinder": Realisation(
                (_p("internal_leakage", (1e-15, 1e-10), 5e-13, (5e-13, 2e-12)),), {"internal_leakage": 0.0},
                source=f"{_TABLE} eqs (4)-(5) C_il (Table 2: 4.343e-13 m^3/(s Pa)); draws: worn piston "
                "seals, 0.3-1.2 L/min at 100 bar"),
            "shaking_table": Realisation(
                (_p("internal_leakage", (1e-15, 1e-10), 1e-12, (1e-12, 4e-12)),), {"internal_leakage": 0.0},
                source=f"{_TABLE} eqs (4)-(5) C_il; Table 2: 4.343e-13 m^3/(s Pa)"),
        },
        separating_experiment="blocked piston, valve at null, load pressure step: internal leakage "
        "equalises p1 and p2, external leakage lowers both",
    ),
    Effect(
        "external_leakage", "External leakage (chambers to tank)",
        "both chamber pressures sag below the valve's null pressure (residual in p1 + p2)",
        {
            "servo_cylinder": Realisation(
                (_p("external_leakage", (1e-15, 1e-10), 3e-13, (2e-13, 8e-13)),), {"external_leakage": 0.0},
                source=f"{_TABLE} eqs (4)-(5) C_el (Table 2: 4.05e-14 m^3/(s Pa)); range of worn rod seals"),
        },
        separating_experiment="blocked piston, valve at null: watch the mean chamber pressure",
    ),
    Effect(
        "valve_lap", "Valve underlap / overlap (dead band)",
        "flow gain changes near null command: dead band (overlap) or leakage flow and pressure "
        "gain loss at null (underlap); residual vs command concentrated at small |u|",
        {
            "servo_cylinder": Realisation(
                (_p("valve_overlap", (-0.1e-3, 0.1e-3), 0.01e-3, (0.02e-3, 0.05e-3), log=False),),
                {"valve_overlap": 0.0},
                source="Hopsan lap convention max(+-xv - x_lap, 0); 003 eq (3) underlap U; servo-valve "
                "laps of 1-3 % of a 0.279 mm spool stroke (draws: overlap of 7-18 %)"),
            "rodless_cylinder": Realisation(
                (_p("valve_underlap", (1e-6, 1e-3), 1e-4, (5e-5, 2e-4)),), {"valve_underlap": 0.0},
                source=f"{_PNEU} eq (2) u = r - d; MPYE-5 mid-position leakage order 6 L/min at 0.1 mm"),
        },
        separating_experiment="slow command ramp through null with the piston blocked (pressure gain) "
        "and free (flow gain)",
    ),
    Effect(
        "valve_dynamics", "Valve dynamics (finite spool bandwidth)",
        "phase lag and gain loss of the response to fast commands in every channel (residual "
        "vs frequency rising with frequency)",
        {
            "servo_cylinder": Realisation(
                (_p("valve_natural_frequency", (60.0, 6000.0), 2 * math.pi * 100, (2 * math.pi * 50, 2 * math.pi * 120)),),
                {"valve_natural_frequency": 2 * math.pi * 800},
                source=f"{_SERVO} eq (2), Table 1: 175 Hz (D765); range of industrial servo-valves"),
            "rodless_cylinder": Realisation(
                (_p("valve_natural_frequency", (30.0, 6000.0), 2 * math.pi * 60, (2 * math.pi * 25, 2 * math.pi * 60)),),
                {"valve_natural_frequency": 2 * math.pi * 800},
                source=f"{_PNEU} eq (28) (a pure gain); MPYE-5 spool bandwidth order 100 Hz, slower valves 25-60 Hz"),
        },
        separating_experiment="frequency response of the spool (or of the blocked-piston pressure) "
        "to a swept sine: a second-order roll-off, not a pure delay",
    ),
    Effect(
        "ifas", "Pressure-dependent bulk modulus (IFAS, entrained air)",
        "the oil spring softens at low chamber pressure: resonance frequency and damping change "
        "with the pressure level (residual vs pressure, at the oil-spring frequency)",
        {
            "shaking_table": Realisation(
                (_p("air_content", (1e-6, 0.05), 3e-3, (2e-3, 1e-2)),), {"bulk_modulus_model": 0.0},
                switch={"bulk_modulus_model": 1.0}, present=lambda p: p.bulk_modulus_model >= 1.0,
                source=f"{_TABLE} eq (13) IFAS; entrained air 0.2-1 % of a hydraulic oil at atmosphere"),
        },
        separating_experiment="oil-spring resonance (blocked-valve ring-down) at two supply pressures",
    ),
    Effect(
        "modified_ifas", "Modified-IFAS stiffness dip at small load pressure",
        "extra compliance while |pa - pb| < P_Lt: low-amplitude motion rings at a lower frequency "
        "than large motion (residual at small load pressure)",
        {
            "shaking_table": Realisation(
                (_p("lambda_2", (1e-3, 0.49), 0.2, (0.15, 0.42)),), {"lambda_2": 0.0},
                switch={"bulk_modulus_model": 2.0, "lambda_1": 1.0}, requires=("ifas",),
                present=lambda p: p.bulk_modulus_model == 2.0 and p.lambda_2 > 0.0,
                source=f"{_TABLE} eq (19), Table 2 (lambda_2 = 0.32 valid reading; h > 0 needs "
                "lambda_2 < 0.54)"),
        },
        separating_experiment="the six inputs of 003 Table 3: small- and large-amplitude sines",
    ),
    Effect(
        "presliding", "Pre-sliding (LuGre / Dahl bristle) dynamics",
        "elastic micro-displacement before breakaway and friction lag after reversals: residual at "
        "velocity reversals and small motions, hysteresis of friction vs position",
        {
            "rodless_cylinder": Realisation(
                (_p("bristle_stiffness", (1e3, 1e6), 1e5, (3e4, 2e5)),), {"bristle_stiffness": 0.0},
                requires=("coulomb",),
                source=f"{_PNEU} Fig. 4 ('displacement before sliding'); LuGre sigma0, F_s/sigma0 = 0.2-1 mm "
                "for soft lip seals and the sealing band; upper bound 1e6 N/m (35 um): stiffer bristles "
                "need > 30 sub-steps per ms (2600 at 1e8) and act as the static curve anyway"),
        },
        separating_experiment="small-amplitude position steps below breakaway: pre-sliding "
        "moves elastically and springs back, a static friction curve does not move",
    ),
    Effect(
        "lvdt", "Added sensor mass and friction (LVDT core on the spool)",
        "lower mechanical resonance (added mass) and more damping: residual of the spool motion "
        "at the spool-spring resonance",
        {
            "ls_compensator": Realisation(
                (_p("lvdt_mass", (1e-4, 0.1), 5e-3, (6e-3, 15e-3)),
                 _p("lvdt_friction_40c", (1e-3, 50.0), 2.0, (2.0, 5.0))),
                {"lvdt_mass": 0.0, "lvdt_friction_40c": 0.0},
                source="000 sec. 5: the LVDT adds 11.03 g and 3.5 N s/m (Figs. 17-19)"),
        },
        separating_experiment="method-2 resonance with and without the LVDT (000 sec. 5): the mass "
        "shifts the resonance, a viscosity change does not",
    ),
    Effect(
        "viscous_temperature", "Viscous friction changed by oil temperature",
        "more damping of the spool and more pipe resistance (both scale with the oil viscosity) "
        "at an unchanged resonance frequency",
        {
            "ls_compensator": Realisation(
                (_p("oil_temperature", (-10.0, 100.0), 30.0, (18.0, 30.0), log=False),),
                {"oil_temperature": 40.0},
                source="000 sec. 3.4, Fig. 14: c at 40 / 30 / 22 C (ISO VG 46, viscosity law "
                "hydro_envs.laws.viscosity)"),
        },
        separating_experiment="repeat the test at a measured oil temperature (000 sec. 3.4)",
    ),
    Effect(
        "valve_hysteresis", "Valve hysteresis",
        "the output depends on the direction the command came from: residual of opposite sign on "
        "rising and falling command, largest right after command reversals",
        {
            "force_actuator": Realisation(
                (_p("hysteresis_width", (1e-3, 0.3), 0.03, (0.04, 0.10)),), {"hysteresis_width": 0.0},
                source=f"{_FORCE} sec. 3.3 (Prandtl-Ishlinskii play model, hydro_envs.laws.hysteresis); "
                "'significant' hysteresis, above the <= 3 % of catalogue servo-valves"),
            "force_actuator_load": Realisation(
                (_p("hysteresis_width", (1e-3, 0.3), 0.03, (0.04, 0.10)),), {"hysteresis_width": 0.0},
                source=f"{_FORCE} sec. 3.3 (as the blocked-piston rig)"),
        },
        separating_experiment="slow triangular current sweep with the piston blocked (001 sec. 3.1): "
        "the force branches separate by the hysteresis width",
    ),
    Effect(
        "flow_force_damping", "Hydraulic damping by flow forces (001 eq (5))",
        "a force opposing the piston velocity that grows steeply as the speed approaches the "
        "valve's flow-limited (knee) speed and saturates past it: sensed-force residual odd in "
        "velocity, small at low speed, largest in the fast parts of the motion",
        {
            "force_actuator_load": Realisation(
                (_p("damping_force_scale", (1.0, 2e4), 1000.0, (1000.0, 2500.0)),
                 _p("damping_knee_velocity", (0.01, 3.0), 0.25, (0.15, 0.4)),
                 _p("damping_sharpness", (0.3, 15.0), 3.0, (2.0, 5.0))),
                {"damping_force_scale": 0.0},
                source=f"{_FORCE} eq (5) F_d = A (tanh(s(|v| + d)) - tanh(s d)) sgn(v) + c v, sec. 4.4 "
                "(output gain 0.4, 40 Hz velocity filter); A(x_v), d(x_v), s(x_v) by the family of "
                "hydro_envs.plants.force_actuator (fig. 6 missing: A_sat 1700 N, knee 0.25 m/s, kappa 3 "
                "assumed); draws around those; the linear term c is the base model's viscous damping "
                "(damping_linear, calibrated in every model)"),
        },
        separating_experiment="constant-current steps with the piston free against the load: the "
        "force drop with speed saturates at the valve's flow-limited speed (eq (5)); viscous "
        "damping grows linearly",
    ),
    Effect(
        "sensor_delay", "Transport delay of the measurement (sensor dynamics)",
        "the measured position lags the model by a constant time at every frequency (residual "
        "proportional to velocity)",
        {
            "slider": Realisation(
                (_p("delay", (1e-5, 0.05), 2e-3, (2e-3, 6e-3), log=False),), {"delay": 0.0},
                channels=("x",), source="assumed: fieldbus/encoder interface delay of 1-10 ms"),
            "servo_cylinder": Realisation(
                (_p("delay", (1e-5, 0.05), 2e-3, (2e-3, 6e-3), log=False),), {"delay": 0.0},
                channels=("x",), source="assumed: fieldbus/encoder interface delay of 1-10 ms"),
            "shaking_table": Realisation(
                (_p("delay", (1e-5, 0.05), 2e-3, (2e-3, 6e-3), log=False),), {"delay": 0.0},
                channels=("x",), source="assumed: potentiometer acquisition delay of 1-10 ms"),
            "rodless_cylinder": Realisation(
                (_p("delay", (1e-5, 0.05), 2e-3, (2e-3, 6e-3), log=False),), {"delay": 0.0},
                channels=("y",), source="assumed: encoder interface delay of 1-10 ms"),
            "force_actuator": Realisation(
                (_p("delay", (1e-5, 0.05), 5e-4, (4e-4, 1.2e-3), log=False),), {"delay": 0.0},
                channels=("f",), source="assumed: strain-gauge amplifier and acquisition delay of 0.4-1.2 ms"),
            "force_actuator_load": Realisation(
                (_p("delay", (1e-5, 0.05), 5e-4, (4e-4, 1.2e-3), log=False),), {"delay": 0.0},
                channels=("f",), source="assumed: strain-gauge amplifier and acquisition delay of 0.4-1.2 ms"),
        },
        kind="sensor",
        separating_experiment="a step of the command: a delay shifts the whole response, valve "
        "dynamics round it",
    ),
]

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
