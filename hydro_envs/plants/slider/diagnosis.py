r"""What the diagnosis workflow needs to know about the slider, as plain data.

:data:`BASES` maps the name the workflow (:mod:`identification.diagnosis`) knows this stage by
to its base-model settings (keys described in :mod:`identification.diagnosis.plants`) and to
``effects``: each catalogue effect the slider can carry and the fields of
:class:`~.params.SliderParams` that realise it (fit bounds = physical plausibility, start value,
draw range of hidden-effect records, value when absent, prerequisites, source). Imports nothing
outside :mod:`hydro_envs`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BASES", "initial_state", "hidden_states", "controller", "settling_time"]

_SERVO = "002_af30b681d6ccfd6c.txt"


def initial_state(params, m):
    """State at a window start: measured position, estimated velocity; the driven body at
    ``xd``, ``vd`` of :func:`hidden_states` where given (with a play), else at the load."""
    x = m["x"]
    v = m.get("v", 0.0)
    return np.array([x, v, m.get("xd", x), m.get("vd", v)])


def hidden_states(params, channels, inputs, dt):
    """Driven-body position ``xd`` [m] and velocity ``vd`` [m/s] at every sample of a record,
    implied by its measured position and force (:func:`~.observer.drive_track`); {} without a
    play or without the position."""
    if params.backlash_gap <= 0.0 or "x" not in channels:
        return {}
    from hydro_envs.plants.slider.observer import drive_track

    xd, vd = drive_track(params, channels["x"], inputs[:, 0], dt)
    return {"xd": xd, "vd": vd}


def controller(meas, ref, params):
    """PD position loop, 40 rad/s bandwidth for the 1 kg stage, clipped to ``force_max``."""
    e = ref[0] - meas["x"]
    f = params.mass * (40.0**2 * e + 2 * 0.7 * 40.0 * (ref[1] - meas["v"]))
    return float(np.clip(f, -params.force_max, params.force_max))


def settling_time(params):
    """Time constant [s] of a start-velocity error of the effect-free axis: ``m / b``."""
    return params.mass / max(params.viscous_friction, 1e-9)


def _reference_centre(p):
    return 0.5 * p.stroke


_EFFECTS = {
    "coulomb": dict(
        parameters=(dict(field="coulomb_friction", bounds=(0.05, 1e3), start=5.0, draw=(4.0, 15.0)),),
        null={"coulomb_friction": 0.0},
        source=f"{_SERVO} eq (1) F_C"),
    "stribeck": dict(
        parameters=(dict(field="static_friction", bounds=(0.05, 1e3), start=1.6, draw=(1.4, 2.2),
                         relative_to="coulomb_friction"),
                    dict(field="stribeck_velocity", bounds=(2e-4, 0.2), start=4e-3, draw=(2.5e-3, 1e-2))),
        null={"static_friction": "coulomb_friction"}, requires=("coulomb",),
        ties={"static_friction": "coulomb_friction"},
        source=f"{_SERVO} eq (1); 004 Table 2: F_s/F_c = 2.3, v_s = 3.27 mm/s"),
    "force_offset": dict(
        parameters=(dict(field="force_offset", bounds=(-1e3, 1e3), start=1.0, draw=(2.0, 6.0), log=False),),
        null={"force_offset": 0.0},
        source="slider F_0 (model.py): a constant force opposing +x; the EMPS reference model "
        "(Janot, Gautier, Brunot 2019) carries one, OF = -3.16 N"),
    "backlash": dict(
        parameters=(dict(field="backlash_gap", bounds=(2e-6, 5e-3), start=3e-5, draw=(5e-5, 2e-4)),
                    dict(field="load_mass_fraction", bounds=(0.02, 0.98), start=0.3, draw=(0.15, 0.4),
                         log=False)),
        null={"backlash_gap": 0.0},
        source="model.py dead-zone play between drive and load (Nordin & Gutman 2002, Automatica 38:1633); "
        "plays of 0.05-0.2 mm: ball-screw nuts without preload, belt and gear stages"),
    "sensor_delay": dict(
        parameters=(dict(field="delay", bounds=(1e-5, 0.05), start=2e-3, draw=(2e-3, 6e-3), log=False),),
        null={"delay": 0.0}, channels=("x",),
        source="assumed: fieldbus/encoder interface delay of 1-10 ms"),
}

#: base-model settings of the slider (see the module docstring)
BASES = {
    "slider": dict(
        base_fit=("mass", "viscous_friction"),
        # 1 um encoder, 0.02 N load cell
        noise={"x": 1e-6, "f": 0.02},
        initial_state=initial_state, controller=controller, hidden_states=hidden_states,
        position_channel="x", position_state="x",
        reference_centre=_reference_centre, reference_amplitude=0.06, reference_speed=0.05,
        # warm-up: 3 times the stage's m/b = 50 ms. Scored 0.5 s per window: a free run through
        # stick-slip drifts in the timing of its stick and slip phases, and over 1 s windows the
        # output-error cost of a Stribeck dip (F_S, v_S) has narrow basins that the refits miss
        # (hidden 21.2 N / 7.9 mm/s fitted as 26.6 N / 2.0 mm/s); over 0.5 s, 21.19 N / 7.91 mm/s
        segment_seconds=0.5, warmup_seconds=0.15, score_bandwidth=50.0, offset_free=("x",),
        effects=_EFFECTS,
        settling_time=settling_time, base_from_data="rigid_axis",
    ),
}
