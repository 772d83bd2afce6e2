r"""Virtual constant-velocity friction test of the differential cylinder, logged as a rig would.

A square wave of valve commands, one level per target speed: extend at ``+u_k`` for the time
that travels ``travel``, then retract at ``-u_k'`` as far back, ``u_k`` and ``u_k'`` the
commands of the no-load speeds (:func:`~hydro_envs.plants.differential_cylinder.model.no_load_velocity`,
so the retracting command is the extending one times the speed ratio ``1 / sqrt(alpha)``: the
piston returns to where it started). In each constant-velocity window the friction is the
force the chambers carry, ``F = A1 (p1 - p_amb) - A2 (p2 - p_amb)`` (gauge pressures; the
ambient pressure also acts on the rod's end) -- what
:func:`identification.constant_velocity.friction_points_from_square_wave` extracts with
``area_2`` and ``ambient_pressure`` (``hydro identify friction --plant differential_cylinder``).

Speeds: 12 log-spaced from 20 to 200 mm/s by default. Below about 5 v_S (the Stribeck slope
``(F_S - F_C)/v_S`` = 4300 N s/m exceeds the 540 N s/m viscous damping) the piston sticks and
slips on its LuGre seals, as the servo plant's does (its ``friction_test`` docstring), and a
window's mean force is the cycle's mean, not the static curve's value at the mean speed.
The record carries the rig's geometry as ``param.NAME`` metadata, as ``hydro simulate`` writes it.
"""

from __future__ import annotations


import numpy as np

from hydro_envs.data.measured import MeasuredData
from hydro_envs.plants.differential_cylinder import model as dc
from hydro_envs.plants.differential_cylinder.params import DifferentialCylinderParams
from hydro_envs.plants.differential_cylinder.spec import SPEC
from hydro_envs.sim.simulate import simulate

__all__ = ["square_wave_command", "friction_record"]


def square_wave_command(params: DifferentialCylinderParams, speeds, travel: float, dt: float) -> np.ndarray:
    """Commands [V] of the test: per speed ``v``, ``travel / v`` seconds extending at the
    command of ``v``, then as long retracting at the command of ``-v`` (no-load orifice law)."""
    v_out, v_in = dc.no_load_velocity(params, 1), dc.no_load_velocity(params, -1)
    parts = []
    for v in np.asarray(speeds, dtype=float):
        if not (0.0 < v < v_in):
            raise ValueError(f"speed {v} m/s; allowed (0, {v_in:.3g}) m/s (the retracting no-load speed)")
        n = max(1, int(round(travel / v / dt)))
        parts += [np.full(n, params.command_max * v / v_out), np.full(n, -params.command_max * v / v_in)]
    return np.concatenate(parts)


def friction_record(params: DifferentialCylinderParams | None = None, speeds=None, *, travel: float = 0.06,
                    dt: float = 1e-3) -> MeasuredData:
    """The test's record (channels u, x, p1, p2, noise-free; the piston starts at rest mid-stroke)."""
    p = params if params is not None else DifferentialCylinderParams()
    speeds = np.geomspace(0.02, 0.2, 12) if speeds is None else speeds
    if not (0.0 < travel < 0.5 * p.stroke):
        raise ValueError(f"travel = {travel} m; allowed (0, {0.5 * p.stroke:g}) m (half the stroke)")
    u = square_wave_command(p, speeds, travel, dt)
    y = simulate(SPEC, p, u[:, None], dc.rest_state(p, 0.5 * p.stroke - 0.5 * travel), dt)
    u_rows = np.append(u, u[-1])  # row k: the input held over [t_k, t_k+1)
    units = {d["name"]: d["unit"] for d in DifferentialCylinderParams.describe()}
    meta = {f"param.{k}": f"{v!r} [{units[k]}]" for k, v in p.as_dict().items()}
    meta["source"] = "hydro_envs.plants.differential_cylinder.friction_test"
    t = dt * np.arange(u_rows.size)
    return MeasuredData(plant=SPEC.name, t=t, channels={"u": u_rows, "x": y[:, dc.X], "p1": y[:, dc.P1],
                                                        "p2": y[:, dc.P2]},
                        units={"t": "s", "u": "V", "x": "m", "p1": "Pa", "p2": "Pa"}, metadata=meta)
