r"""What the diagnosis workflow needs to know about the servo cylinder, as plain data.

:data:`BASES` maps the name the workflow (:mod:`identification.diagnosis`) knows this rig by to
its base-model settings -- the parameters calibrated in every model (``base_fit``), realistic
sensor noise, the start-state estimate of a record window, the position loop and reference of
the hidden-effect records, window lengths, the score band (keys described in
:mod:`identification.diagnosis.plants`) -- and to ``effects``: each catalogue effect this plant
can carry and the fields of :class:`~.params.ServoCylinderParams` that realise it (fit bounds =
physical plausibility, start value, the range hidden-effect records draw from, the value when
the effect is absent, prerequisites, the source of every number). Imports nothing outside
:mod:`hydro_envs`; the model is loaded when a function below is first called.
"""

from __future__ import annotations

import math

import numpy as np

from hydro_envs.data.friction_reading import binned_friction_peak, smoothed, smoothing_samples
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

__all__ = ["BASES", "initial_state", "controller", "measured_breakaway", "stribeck_starts"]

_SERVO = "002_af30b681d6ccfd6c.txt"


def _model():
    from hydro_envs.plants.servo_cylinder import model

    return model


def initial_state(params, m):
    """State at a window start from measured ``m`` (x, v, p1, p2, u): missing pressures at the
    mean of supply and tank, the spool at its static position for the command."""
    sc = _model()
    y = np.zeros(sc.N_STATES)
    pm = 0.5 * (params.supply_pressure + params.tank_pressure)
    y[sc.X] = m["x"]
    y[sc.V] = m.get("v", 0.0)
    y[sc.P1] = m.get("p1", pm)
    y[sc.P2] = m.get("p2", pm)
    y[sc.XV] = float(np.clip(params.spool_gain * m.get("u", 0.0), -params.spool_stroke, params.spool_stroke))
    return y


def controller(meas, ref, params):
    """P position loop with velocity feedforward, K_v = 40 1/s (the demo's gain)."""
    kq = _model().no_load_velocity(params) / params.command_max  # m/s per V
    u = (40.0 * (ref[0] - meas["x"]) + ref[1]) / kq
    return float(np.clip(u, -params.command_max, params.command_max))


def _reference_centre(p):
    return 0.5 * p.stroke


def measured_breakaway(params, channels, dt: float) -> float:
    """Static friction level [N] read off a record with the position and both chamber pressures:
    the friction force ``A (p1 - p2) - m a - d v - F_L`` (002 eq (7); velocity, acceleration and
    pressures smoothed by :func:`~hydro_envs.data.friction_reading.smoothed`) signed with the velocity,
    over the asymmetry's level ``1 + a sgn v`` and less the pressure term ``c_p |p1 - p2|``, its
    largest median over the speed bins of :func:`~hydro_envs.data.friction_reading.binned_friction_peak`
    (samples within 1 mm of an end stop left out). The law's level at v -> 0
    is ``F_S`` (002 eq (1)); the medians read it low where the Stribeck dip is narrow, and the
    caller scans above it. NaN without the three channels."""
    if not all(k in channels for k in ("x", "p1", "p2")):
        return float("nan")
    x = np.asarray(channels["x"], float)
    if x.size < 2 * smoothing_samples(dt):
        return float("nan")
    v, a = smoothed(x, dt, 1), smoothed(x, dt, 2)
    dp = smoothed(np.asarray(channels["p1"], float) - np.asarray(channels["p2"], float), dt)
    s = np.sign(v)
    fr = s * (params.piston_area * dp - params.mass * a - params.viscous_friction * v - params.load_force)
    fr = fr / (1.0 + params.friction_asymmetry * s) - params.friction_pressure_coefficient * np.abs(dp)
    inside = (x > 1e-3) & (x < params.stroke - 1e-3)
    return binned_friction_peak(v[inside], fr[inside])


#: the scans of :func:`stribeck_starts`, coarse to fine: (static-friction factors, Stribeck-velocity
#: factors). The first scan's factors multiply the measured level (0.95-1.5 in 4 % steps: the binned
#: medians read the static level low or not at all) and give the Stribeck velocities (0.75-30 mm/s,
#: steps of 1.6); each later one multiplies the best point of the scan before (1 % and 12 % steps
#: over +-4 % and +-60 %, then 0.25 % and 4 % over +-1 % and +-12 %). Where a position loop reverses quickly the bristles never reach the static
#: level, and the Stribeck velocity acts through the micro-damping that fades over it: on the
#: independent record with F_S 80 N, v_S 1 mm/s the friction read off it stays below 48 N, the cost
#: varies by 2 % over F_S 41-90 N at v_S 1 mm/s and rises by 40 % from v_S 1 to 4 mm/s, and a refit
#: from the catalogue start (10 mm/s) stops in a local minimum at 8.2 mm/s. Hence the wide v_S scan
PEAK_SCANS = (
    (np.geomspace(0.95, 1.5, 12), np.geomspace(7.5e-4, 3e-2, 9)),
    (np.geomspace(1 / 1.04, 1.04, 9), np.geomspace(1 / 1.6, 1.6, 9)),
    (np.geomspace(1 / 1.01, 1.01, 9), np.geomspace(1 / 1.12, 1.12, 7)),
)


def stribeck_starts(params, channels, inputs, dt, around=None, level=0) -> list[dict[str, float]]:
    """Start points (``static_friction``, ``stribeck_velocity``) of a Stribeck refit: scan
    ``level`` of :data:`PEAK_SCANS`, the first about the static level of
    :func:`measured_breakaway` over a wide range of Stribeck velocities, each later one about
    ``around`` (the best point of the scan before); [] past the last scan or without the
    pressures; points below the Coulomb level left out."""
    if level >= len(PEAK_SCANS):
        return []
    fs_factors, speed_factors = PEAK_SCANS[level]
    if level == 0:  # the first scan's speed factors are the velocities [m/s] themselves
        fs0, vs0 = measured_breakaway(params, channels, dt), 1.0
    else:
        fs0, vs0 = around["static_friction"], around["stribeck_velocity"]
    if not np.isfinite(fs0):
        return []
    return [{"static_friction": float(fs0 * kf), "stribeck_velocity": float(vs0 * kv)}
            for kv in speed_factors for kf in fs_factors if fs0 * kf >= params.coulomb_friction]


# a leakage coefficient above _LEAK_MAX m^3/(s Pa) leaks, at half the supply pressure (6.9 MPa),
# 3.5e-5 m^3/s = 8 % of the valve's no-load flow (0.669 m/s x 6.63 cm^2 = 4.4e-4 m^3/s: model.no_load_velocity
# times piston_area of the nominal parameters):
# an axis that worn no longer holds position under load; the fit bound (1e-10) leaves the fit room
_LEAK_MAX = 5e-12
_LEAK_WHY = "above it the leak at half the supply pressure exceeds 8 % of the valve's no-load flow"

_EFFECTS = {
    "coulomb": dict(
        parameters=(dict(field="coulomb_friction", bounds=(0.5, 2e3), start=30.0, draw=(25.0, 80.0)),),
        null={"coulomb_friction": 0.0},
        source=f"{_SERVO} eq (1) F_C; range: tens of N for a 6.63 cm^2 seal set"),
    "stribeck": dict(
        parameters=(dict(field="static_friction", bounds=(0.5, 3e3), start=1.6, draw=(1.4, 2.2),
                         relative_to="coulomb_friction"),
                    dict(field="stribeck_velocity", bounds=(5e-4, 0.5), start=0.01, draw=(5e-3, 2e-2))),
        null={"static_friction": "coulomb_friction"}, requires=("coulomb",),
        ties={"static_friction": "coulomb_friction"}, start_points=stribeck_starts,
        source=f"{_SERVO} eq (1) F_S, v_S; ratio F_S/F_C 1.4-2.2 of lubricated seals"),
    "asymmetric_friction": dict(
        parameters=(dict(field="friction_asymmetry", bounds=(-0.9, 0.9), start=0.1, draw=(0.2, 0.5), log=False),),
        null={"friction_asymmetry": 0.0}, requires=("coulomb",),
        source="001 Table: stiction +99 N / -54 N (asymmetry 0.29) for a rod/cap seal pair"),
    "pressure_friction": dict(
        parameters=(dict(field="friction_pressure_coefficient", bounds=(1e-8, 1e-4), start=1e-5,
                         draw=(1e-5, 3e-5)),),
        null={"friction_pressure_coefficient": 0.0}, requires=("coulomb",),
        source="seal data tests/data/pneumatic_seal_friction: +11.4 N over 6 bar, i.e. "
        "~1.9e-5 N/Pa for a 25 mm seal; draws 1-3e-5 N/Pa: 10-30 N at 10 bar"),
    "internal_leakage": dict(
        parameters=(dict(field="internal_leakage", bounds=(1e-15, 1e-10), start=5e-13, draw=(5e-13, 2e-12),
                         plausible=(1e-15, _LEAK_MAX)),),
        null={"internal_leakage": 0.0},
        source="003_54985feb8193da53.txt eqs (4)-(5) C_il (Table 2: 4.343e-13 m^3/(s Pa)); draws: worn piston "
        f"seals, 0.3-1.2 L/min at 100 bar; plausible up to {_LEAK_MAX:g}: {_LEAK_WHY}"),
    "external_leakage": dict(
        parameters=(dict(field="external_leakage", bounds=(1e-15, 1e-10), start=3e-13, draw=(2e-13, 8e-13),
                         plausible=(1e-15, _LEAK_MAX)),),
        null={"external_leakage": 0.0},
        source="003_54985feb8193da53.txt eqs (4)-(5) C_el (Table 2: 4.05e-14 m^3/(s Pa)); range of worn rod seals; "
        f"plausible up to {_LEAK_MAX:g}: {_LEAK_WHY}"),
    "valve_lap": dict(
        parameters=(dict(field="valve_overlap", bounds=(-0.1e-3, 0.1e-3), start=0.01e-3, draw=(0.02e-3, 0.05e-3),
                         log=False),),
        null={"valve_overlap": 0.0},
        source="Hopsan lap convention max(+-xv - x_lap, 0); 003 eq (3) underlap U; servo-valve "
        "laps of 1-3 % of a 0.279 mm spool stroke (draws: overlap of 7-18 %)"),
    "supply_droop": dict(
        parameters=(dict(field="supply_line_resistance", bounds=(1e8, 1e12), start=5e9, draw=(1e10, 4e10),
                         plausible=(1e8, 1e11)),),
        null={"supply_line_resistance": 0.0},
        source="hydro_envs.laws.orifice.supply_pressure_at_flow (assumed linear droop); draws: 1-4 MPa "
        "(7-29 % of the 13.8 MPa supply) at 1e-4 m^3/s, the 99th-percentile flow of the test records "
        "(0.15 m/s); plausible up to 1e11 (a 10 MPa drop at that flow: the rig no longer works)"),
    "valve_dynamics": dict(
        parameters=(dict(field="valve_natural_frequency", bounds=(60.0, 6000.0), start=2 * math.pi * 100,
                         draw=(2 * math.pi * 50, 2 * math.pi * 120)),),
        null={"valve_natural_frequency": ServoCylinderParams().valve_natural_frequency},
        source=f"{_SERVO} eq (2), Table 1: 175 Hz (D765) in the base model; a hidden slower valve "
        "(50-120 Hz: a worn or detuned one) is the effect"),
    "sensor_delay": dict(
        parameters=(dict(field="delay", bounds=(1e-5, 0.05), start=2e-3, draw=(2e-3, 6e-3), log=False),),
        null={"delay": 0.0}, channels=("x",),
        source="assumed: fieldbus/encoder interface delay of 1-10 ms"),
}

#: base-model settings of the servo cylinder rig (the workflow's names for the keys: see
#: :mod:`identification.diagnosis.plants`)
BASES = {
    "servo_cylinder": dict(
        base_fit=("viscous_friction", "bulk_modulus", "discharge_coefficient"),
        # 1 um encoder (quantisation + electronics), 0.05 bar filtered pressure transducer
        noise={"x": 1e-6, "p1": 5e3, "p2": 5e3, "u": 0.0},
        initial_state=initial_state, controller=controller,
        position_channel="x", position_state="x",
        reference_centre=_reference_centre, reference_amplitude=0.025, reference_speed=0.02,
        # warm-up: ~3 times the oil column's 1/(zeta_h omega_h) = 0.1 s
        segment_seconds=0.7, warmup_seconds=0.3, score_bandwidth=50.0,
        offset_free=("x",), sensor_offsets=("p1", "p2"), pressure_difference=("p1", "p2"),
        # the example of ``make demo-diagnose``: (hidden effect, seed); base model: Coulomb + viscous
        demo=("stribeck", 11),
        effects=_EFFECTS,
    ),
}
