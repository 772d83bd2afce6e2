"""The chamber-temperature estimate of the rodless cylinder from a record's measured position and
pressures (hydro_envs.plants.rodless_cylinder.observer), against the temperatures of a full
RK4 simulation of the plant (seed 004 eqs (8)-(18))."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydro_envs.plants.rodless_cylinder import model as rc
from hydro_envs.plants.rodless_cylinder.observer import chamber_temperature_track
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.spec import SPEC
from hydro_envs.sim.simulate import simulate

DT = 1e-3


def _record(params: RodlessCylinderParams, seconds: float = 6.0):
    """Valve command: steps and a sine around the centre that move the slider back and forth
    with pauses at mid position (where an underlapped valve renews the gas)."""
    t = DT * np.arange(int(seconds / DT))
    u = params.command_centre + 0.6 * np.sign(np.sin(2 * np.pi * 0.5 * t)) * (np.sin(2 * np.pi * 0.25 * t) > -0.3)
    u = u + 0.2 * np.sin(2 * np.pi * 3.0 * t)
    x0 = rc.rest_state(params, 0.5 * params.stroke)
    states = simulate(SPEC, params, u[:, None], x0, DT)[:-1]
    ta, tb = rc.chamber_temperatures(states, params)
    return u, states, ta, tb


@pytest.mark.parametrize("underlap", [0.0, 1.27e-4])
def test_temperatures_follow_the_full_simulation(underlap):
    p = dataclasses.replace(RodlessCylinderParams(), valve_underlap=underlap)
    u, s, ta, tb = _record(p)
    assert max(np.ptp(ta), np.ptp(tb)) > 10.0  # the gas is compressed and expanded: T_s is wrong
    ea, eb = chamber_temperature_track(p.to_array(), s[:, rc.Y], s[:, rc.PA], s[:, rc.PB], u, DT)
    err = np.sqrt(np.mean(np.concatenate([ea - ta, eb - tb]) ** 2))
    assert err < 1.0, err


def test_temperatures_depend_on_the_valve():
    """A closed-centre valve conserves the gas at mid position, an underlapped one renews it: the
    estimate with the wrong valve misses the record's temperatures."""
    p = dataclasses.replace(RodlessCylinderParams(), valve_underlap=1.27e-4)
    u, s, ta, _ = _record(p)
    closed = dataclasses.replace(p, valve_underlap=0.0)
    ea, _ = chamber_temperature_track(closed.to_array(), s[:, rc.Y], s[:, rc.PA], s[:, rc.PB], u, DT)
    assert np.sqrt(np.mean((ea - ta) ** 2)) > 3.0


@pytest.mark.parametrize("flow_model, resistance", [(0.0, 0.0), (1.0, 3e8)])
def test_track_ignores_the_slider_mechanics(flow_model, resistance):
    """Every field of ``TRACK_IGNORES`` (the key of the diagnosis' track cache leaves them out)
    changes nothing in the track, with either flow law and a drooping supply; a valve field does."""
    from hydro_envs.params import ParameterError
    from hydro_envs.plants.rodless_cylinder.diagnosis import TRACK_IGNORES

    p = dataclasses.replace(RodlessCylinderParams(), valve_underlap=1.27e-4, flow_model=flow_model,
                            supply_line_resistance=resistance)
    u, s, _, _ = _record(p, seconds=2.0)
    args = (s[:, rc.Y], s[:, rc.PA], s[:, rc.PB], u, DT)
    ref = chamber_temperature_track(p.to_array(), *args)
    for name in TRACK_IGNORES:
        v = getattr(p, name)
        try:
            q = dataclasses.replace(p, **{name: 1.5 * v if v else 0.5})
        except ParameterError:
            q = dataclasses.replace(p, **{name: 0.5 * v})
        got = chamber_temperature_track(q.to_array(), *args)
        assert all(np.array_equal(a, b) for a, b in zip(got, ref)), name
    q = dataclasses.replace(p, valve_underlap=0.5 * p.valve_underlap)
    assert not np.array_equal(chamber_temperature_track(q.to_array(), *args)[0], ref[0])


def test_diagnosis_track_cache_is_keyed_by_record_and_valve():
    """The diagnosis' hidden states reuse a track for the same record and a parameter set that
    differs only in the mechanics, and recompute it for another record or valve."""
    from hydro_envs.plants.rodless_cylinder.diagnosis import hidden_states

    p = dataclasses.replace(RodlessCylinderParams(), valve_underlap=1.27e-4)
    u, s, _, _ = _record(p, seconds=2.0)
    chans = {"y": s[:, rc.Y], "pa": s[:, rc.PA], "pb": s[:, rc.PB]}
    first = hidden_states(p, chans, u[:, None], DT)
    again = hidden_states(dataclasses.replace(p, viscous_friction=2.0 * p.viscous_friction), chans, u[:, None], DT)
    assert again["ta"] is first["ta"]
    other_valve = hidden_states(dataclasses.replace(p, valve_underlap=0.0), chans, u[:, None], DT)
    assert not np.array_equal(other_valve["ta"], first["ta"])
    shifted = dict(chans, pa=chans["pa"] + 100.0)
    assert not np.array_equal(hidden_states(p, shifted, u[:, None], DT)["ta"], first["ta"])
    direct = chamber_temperature_track(p.to_array(), chans["y"], chans["pa"], chans["pb"], u, DT)
    assert np.array_equal(direct[0], first["ta"]) and np.array_equal(direct[1], first["tb"])
