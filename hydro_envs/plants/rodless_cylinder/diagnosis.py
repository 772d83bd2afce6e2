r"""What the diagnosis workflow needs to know about the pneumatic rodless cylinder, as plain data.

:data:`BASES` maps the name the workflow (:mod:`identification.diagnosis`) knows this rig by to
its base-model settings (keys described in :mod:`identification.diagnosis.plants`) and to
``effects``: each catalogue effect the cylinder can carry and the fields of
:class:`~.params.RodlessCylinderParams` that realise it (fit bounds = physical plausibility,
start value, draw range of hidden-effect records, value when absent, prerequisites, source).
Imports nothing outside :mod:`hydro_envs`; the model is loaded when a function below is first
called.
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib
import math

import numpy as np

__all__ = ["BASES", "initial_state", "hidden_states", "controller"]

_PNEU = "004 (seed pneumatic rodless cylinder)"


def _model():
    from hydro_envs.plants.rodless_cylinder import model

    return model


def initial_state(params, m):
    """State at a window start: measured position, velocity and pressures (the rest state's
    where not measured), the chamber temperatures ``ta``, ``tb`` of :func:`hidden_states`
    (T_s where not given); the spool at its static position for the command."""
    rc = _model()
    y = rc.rest_state(params, m["y"], m.get("v", 0.0), m.get("pa"), m.get("pb"), m.get("ta"), m.get("tb"))
    du = m.get("u", params.command_centre) - params.command_centre
    y[rc.XV] = float(np.clip(du / (params.command_max - params.command_centre) * params.spool_stroke,
                             -params.spool_stroke, params.spool_stroke))
    return y


#: parameters the chamber temperature track does not read: the slider's mechanics (it takes the
#: measured position and pressures as given); a fit that moves only these reuses the track
#: (tests/test_rodless_observer.py perturbs each one)
TRACK_IGNORES = ("mass", "static_friction", "coulomb_friction", "stribeck_velocity", "viscous_friction",
                 "bristle_stiffness", "bristle_damping", "friction_sign_velocity", "load_force", "stop_stiffness",
                 "stop_damping", "wall_heat_transfer_coefficient", "pressure_floor")
_TRACKS: collections.OrderedDict = collections.OrderedDict()
_TRACKS_KEPT = 32


def hidden_states(params, channels, inputs, dt):
    """Chamber temperatures ``ta``, ``tb`` [K] at every sample of a record, implied by its
    measured position and pressures (:func:`~.observer.chamber_temperature_track`); {} without
    both pressures. The last few tracks are kept, keyed by the record's content and the
    parameters outside :data:`TRACK_IGNORES`."""
    if not all(c in channels for c in ("y", "pa", "pb")):
        return {}
    from hydro_envs.plants.rodless_cylinder.observer import chamber_temperature_track

    data = [np.ascontiguousarray(a, dtype=np.float64) for a in (channels["y"], channels["pa"], channels["pb"],
                                                                inputs[:, 0])]
    digest = hashlib.blake2b(digest_size=16)
    for a in data:
        digest.update(a.tobytes())
    key = (digest.digest(), float(dt), data[0].size,
           tuple(float(getattr(params, f.name)) for f in dataclasses.fields(params) if f.name not in TRACK_IGNORES))
    got = _TRACKS.get(key)
    if got is None:
        ta, tb = chamber_temperature_track(params.to_array(), *data, dt)
        ta.flags.writeable = tb.flags.writeable = False  # shared by every caller of the same key
        got = _TRACKS[key] = (ta, tb)
        if len(_TRACKS) > _TRACKS_KEPT:
            _TRACKS.popitem(last=False)
    else:
        _TRACKS.move_to_end(key)
    return {"ta": got[0], "tb": got[1]}


def controller(meas, ref, params):
    """P position loop around the 5 V centre (004 sec. 4.2 uses kp = 50 V/m) with velocity
    feedforward through the valve's no-load speed gain (~0.3 m/s per V at 6 bar)."""
    u = params.command_centre + 150.0 * (ref[0] - meas["x"]) + ref[1] / 0.3
    return float(np.clip(u, 0.0, params.command_max))


def _reference_centre(p):
    return 0.5 * p.stroke


_EFFECTS = {
    "coulomb": dict(
        parameters=(dict(field="coulomb_friction", bounds=(0.1, 500.0), start=10.0, draw=(10.0, 25.0)),),
        null={"coulomb_friction": 0.0},
        source=f"{_PNEU} eq (1), Table 2: F_c = 15.31 N"),
    "stribeck": dict(
        parameters=(dict(field="static_friction", bounds=(0.1, 1e3), start=1.8, draw=(1.8, 2.6),
                         relative_to="coulomb_friction"),
                    dict(field="stribeck_velocity", bounds=(2e-4, 0.1), start=3e-3, draw=(2e-3, 6e-3))),
        null={"static_friction": "coulomb_friction"}, requires=("coulomb",),
        ties={"static_friction": "coulomb_friction"},
        source=f"{_PNEU} eq (1), Table 2: F_s/F_c = 2.32, v_s = 3.27 mm/s"),
    "valve_lap": dict(
        # signed: u > 0 an underlap (mid-position leakage), u < 0 an overlap (both edge
        # openings u +- x_v of eq (2) stay shut while |x_v| < -u: a dead band around the centre)
        parameters=(dict(field="valve_underlap", bounds=(-3e-4, 1e-3), start=2e-5, draw=(5e-5, 2e-4),
                         log=False),),
        null={"valve_underlap": 0.0},
        source=f"{_PNEU} eq (2) u = r - d (u < 0: an overlap, a dead band of 27 % of the 1.13 mm "
        "spool stroke at the bound); MPYE-5 mid-position leakage order 6 L/min at 0.1 mm"),
    "supply_droop": dict(
        parameters=(dict(field="supply_line_resistance", bounds=(1e6, 1e10), start=3e7, draw=(1e8, 3e8),
                         plausible=(1e6, 2e9)),),
        null={"supply_line_resistance": 0.0},
        source=f"{_PNEU} eqs (3)-(4) at a constant 0.6 MPa supply; model.supply_port_pressure (assumed "
        "linear droop of a regulator or hose)"),
    "valve_dynamics": dict(
        parameters=(dict(field="valve_natural_frequency", bounds=(30.0, 6000.0), start=2 * math.pi * 60,
                         draw=(2 * math.pi * 25, 2 * math.pi * 60)),),
        null={"valve_natural_frequency": 2 * math.pi * 800},
        source=f"{_PNEU} eq (28) (a pure gain); MPYE-5 spool bandwidth order 100 Hz, slower valves 25-60 Hz"),
    "presliding": dict(
        parameters=(dict(field="bristle_stiffness", bounds=(1e3, 1e6), start=1e5, draw=(3e4, 2e5)),),
        null={"bristle_stiffness": 0.0}, requires=("coulomb",),
        source=f"{_PNEU} Fig. 4 ('displacement before sliding'); LuGre sigma0, F_s/sigma0 = 0.2-1 mm "
        "for soft lip seals and the sealing band; upper bound 1e6 N/m (35 um): stiffer bristles "
        "need > 30 sub-steps per ms (2600 at 1e8) and act as the static curve anyway"),
    "sensor_delay": dict(
        parameters=(dict(field="delay", bounds=(1e-5, 0.05), start=2e-3, draw=(2e-3, 6e-3), log=False),),
        null={"delay": 0.0}, channels=("y",),
        source="assumed: encoder interface delay of 1-10 ms"),
}

#: base-model settings of the rodless cylinder (see the module docstring)
BASES = {
    "rodless_cylinder": dict(
        base_fit=("viscous_friction", "discharge_coefficient"),
        # 1 um encoder, 0.5 kPa (5 mbar) pressure transducers of a 10-bar range
        noise={"y": 1e-6, "pa": 500.0, "pb": 500.0, "u": 0.0},
        initial_state=initial_state, controller=controller, hidden_states=hidden_states,
        position_channel="y", position_state="y",
        reference_centre=_reference_centre, reference_amplitude=0.035, reference_speed=0.02,
        # warm-up: covers the friction-damped air spring
        segment_seconds=0.7, warmup_seconds=0.3, score_bandwidth=50.0,
        offset_free=("y",), sensor_offsets=("pa", "pb"),
        # verdict unexplained above 60 noise floors: twice the largest held-out residual a correctly named
        # model left on the bench records (`bench/diagnosis.py --plants rodless_cylinder --seeds 1`): 30 floors
        # on y after presliding (seed 5000), whose fitted discharge coefficient is 0.16 % low -- the position
        # of an integrating plant replayed open loop drifts with any gain error; the true model leaves at most
        # 8.5 floors on 21 records, the windows started from the chamber temperatures of hidden_states
        # (from T_s instead: 69 floors and more)
        unexplained_factor=60.0,
        effects=_EFFECTS,
    ),
}
