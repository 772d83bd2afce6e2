"""Experiments of seed 003 on the shaking table (``003_54985feb8193da53.txt``): the six inputs of
Table 3 (valve commands in volts)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["TABLE3_INPUTS", "table3_input"]


#: The six inputs of 003 Table 3 in volts (+-10 V = full spool stroke, the plant module's
#: scale; the text's 0.3 sin(2 pi 2 t) is Table 3's 3 sin(4 pi t)), with the specimen mass,
#: the paper's MSEs (modified IFAS, IFAS) and the record length used here (shortened: the
#: fits need a few periods, and six rows must run in about 20 s).
TABLE3_INPUTS: dict[str, dict[str, Any]] = {
    "3 sin(4 pi t)": {"specimen": "200kg", "paper": (31.4, 119.1), "seconds": 1.0},
    "3 sin(16 pi t)": {"specimen": "200kg", "paper": (53.88, 310.92), "seconds": 0.5},
    "9 sin(28 pi t)": {"specimen": "200kg", "paper": (132.71, 141.51), "seconds": 0.5},
    "eq (23)": {"specimen": "500kg", "paper": (17.6, 50.57), "seconds": 1.5},
    "2 sin(10 pi t)": {"specimen": "200kg", "paper": (54.49, 188.1), "seconds": 0.8},
    "pulse (Fig. 11)": {"specimen": "200kg", "paper": (41.69, 125.8), "seconds": 1.0},
}


def table3_input(name: str, t: np.ndarray) -> np.ndarray:
    """Valve command [V] of a Table 3 input at times ``t`` [s].

    * sines as printed in Table 3 (volts);
    * eq (23): ``0.1 sin(2 pi 2 t)`` then ``0.2 sin(2 pi 2 t)`` (normalised) = 1 V then 2 V; the
      paper switches at 4.35 s of a 6 s record; the shortened 1.5 s record here switches at
      1.0 s (after two whole periods, at a zero of the sine);
    * pulse (Fig. 11, not extracted numerically): assumed +2 V for 0.2 s from 0.1 s, then
      -2 V for 0.2 s from 0.5 s (a move out and back).
    """
    t = np.asarray(t, dtype=float)
    if name == "3 sin(4 pi t)":
        return 3.0 * np.sin(4 * np.pi * t)
    if name == "3 sin(16 pi t)":
        return 3.0 * np.sin(16 * np.pi * t)
    if name == "9 sin(28 pi t)":
        return 9.0 * np.sin(28 * np.pi * t)
    if name == "2 sin(10 pi t)":
        return 2.0 * np.sin(10 * np.pi * t)
    if name == "eq (23)":
        t_sw = 1.0  # whole periods of the 2 Hz sine (1.5 s record)
        return np.where(t < t_sw, 1.0, 2.0) * np.sin(2 * np.pi * 2 * t)
    if name == "pulse (Fig. 11)":
        return np.where((t >= 0.1) & (t < 0.3), 2.0, 0.0) + np.where((t >= 0.5) & (t < 0.7), -2.0, 0.0)
    raise ValueError(f"unknown Table 3 input {name!r}; known: {list(TABLE3_INPUTS)}")


def full_opening_flow(params, valve_drop: float = 70.0e5, seconds: float = 0.8, dt: float = 1e-4) -> float:
    """Flow [m^3/s] the table's valve passes at full command (+10 V) with the supply set
    ``valve_drop`` [Pa] above the tank: the platform runs from near one end over the stroke and
    the flow is ``A`` times its mean speed over the middle half of the stroke (NaN if it does not
    get there)."""
    import dataclasses

    from hydro_envs.plants.shaking_table import model as st
    from hydro_envs.plants.shaking_table.spec import SPEC
    from hydro_envs.sim.simulate import simulate

    p = dataclasses.replace(params, supply_pressure=params.tank_pressure + valve_drop)
    x0 = -0.45 * p.stroke
    n = int(round(seconds / dt))
    out = simulate(SPEC, p, np.full((n, 1), p.command_max), st.rest_state(p, x0), dt)
    t = dt * np.arange(n + 1)
    idx = np.flatnonzero(np.abs(out[:, st.X]) < 0.25 * p.stroke)
    if idx.size < 10 or out[idx[-1], st.X] < 0.2 * p.stroke:
        return float("nan")
    return float(p.piston_area * (out[idx[-1], st.X] - out[idx[0], st.X]) / (t[idx[-1]] - t[idx[0]]))
