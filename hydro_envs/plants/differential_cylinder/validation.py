"""Validation rows of the differential cylinder against analytic results (issue 54).

No seed paper prints numbers for this rig, so every row is a ``consistency`` row: the full
nonlinear model, simulated, against a closed form derived independently of the code.

* the extend / retract no-load speed ratio at full opening, ``1 / sqrt(alpha)`` from the orifice
  law with the force balance ``A1 p1 = A2 p2`` (:func:`~hydro_envs.plants.differential_cylinder.model.no_load_velocity`),
  against two simulated constant-command runs;
* the rest pressures of a hold, ``p1 A1 = p2 A2 + F_L`` (gauge pressures: the ambient pressure
  also acts on the rod's end face), against a simulated hold with the valve closed under a 10 kN load;
* the hydraulic natural frequency at its minimum over the stroke,
  ``omega^2 = beta / m (A1^2 / V1 + A2^2 / V2)`` at ``V2 = (A2/A1)^(3/2) V1``, against the frequency
  of the simulated free oscillation after a 1 bar pressure step there.

The runs remove the friction the closed forms leave out (named in each row's source).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from hydro_envs.plants.differential_cylinder import model as dc
from hydro_envs.plants.differential_cylinder.params import DifferentialCylinderParams
from hydro_envs.plants.differential_cylinder.spec import SPEC
from hydro_envs.sim.simulate import simulate
from hydro_envs.validation import ValidationRow

__all__ = ["rows", "constant_command_speed", "hold_force", "free_oscillation_frequency"]

DT = 1e-4  # s, sampling of the validation runs
HOLD_LOAD = 1e4  # N, the load of the hold row


def frictionless(params: DifferentialCylinderParams, viscous: bool = False) -> DifferentialCylinderParams:
    """``params`` without dry friction (and without viscous friction unless ``viscous``)."""
    return dataclasses.replace(params, coulomb_friction=0.0, static_friction=0.0,
                               viscous_friction=params.viscous_friction if viscous else 0.0)


def constant_command_speed(params: DifferentialCylinderParams, direction: int, duration: float = 0.4) -> float:
    """Steady speed [m/s] at full opening (``direction`` +1 extend from the cap end, -1 retract
    from the rod end): the mean over the last quarter of the run."""
    x0 = 0.01 if direction > 0 else params.stroke - 0.01
    n = int(round(duration / DT))
    out = simulate(SPEC, params, np.full((n, 1), direction * params.command_max), dc.rest_state(params, x0), DT)
    return float(np.mean(out[-n // 4:, dc.V]))


def hold_force(params: DifferentialCylinderParams, load: float = HOLD_LOAD, duration: float = 3.0) -> float:
    """``A1 p1 - A2 p2`` [N] (gauge pressures) at the end of a hold: valve closed, load ``load``, started from both
    chambers at the valve's null pressure (out of balance), mid-stroke; the oil springs settle."""
    p = dataclasses.replace(params, load_force=load)
    y0 = dc.rest_state(p)
    y0[dc.P1] = y0[dc.P2]
    n = int(round(duration / DT))
    out = simulate(SPEC, p, np.zeros((n, 1)), y0, DT)
    amb = p.ambient_pressure
    return float(p.piston_area * (out[-1, dc.P1] - amb) - p.annulus_area * (out[-1, dc.P2] - amb))


def free_oscillation_frequency(params: DifferentialCylinderParams, x: float, step: float = 1e5,
                               duration: float = 0.15) -> float:
    """Frequency [Hz] of the free oscillation at ``x`` after a ``step`` [Pa] in p1 (valve closed):
    the mean spacing of the velocity's zero crossings."""
    y0 = dc.rest_state(dataclasses.replace(params, load_force=0.0), x)
    y0[dc.P1] += step
    n = int(round(duration / DT))
    v = simulate(SPEC, params, np.zeros((n, 1)), y0, DT)[:, dc.V]
    s = np.flatnonzero(np.sign(v[1:]) != np.sign(v[:-1]))
    t = DT * (s + v[s] / (v[s] - v[s + 1]))  # linear interpolation of each crossing
    return float(1.0 / (2.0 * np.mean(np.diff(t))))


def rows() -> list[ValidationRow]:
    nominal = DifferentialCylinderParams()
    p0 = frictionless(nominal)
    ratio = constant_command_speed(p0, 1) / -constant_command_speed(p0, -1)
    x_min = dc.minimum_natural_frequency_position(nominal)
    return [
        ValidationRow(
            name="differential_cylinder: extend/retract no-load speed ratio at full opening",
            published=dc.speed_ratio(nominal), reproduced=ratio, tolerance=0.002, unit="1",
            source="orifice law (edge K from 40 L/min at 35 bar) with A1 p1 = A2 p2: v_out/v_in = 1/sqrt(A2/A1); "
                   "simulated +-10 V runs without friction",
            kind="consistency",
        ),
        ValidationRow(
            name="differential_cylinder: rest pressures of a hold, A1 p1 = A2 p2 + F_L (gauge, 10 kN)",
            published=HOLD_LOAD, reproduced=hold_force(frictionless(nominal, viscous=True)), tolerance=1e-3,
            unit="N",
            source="force balance at rest; simulated 3 s hold with the valve closed, viscous friction only "
                   "(the seals' stiction would hold up to F_S = 130 N of the difference)",
            kind="consistency",
        ),
        ValidationRow(
            name="differential_cylinder: hydraulic natural frequency at its minimum over the stroke",
            published=dc.minimum_natural_frequency(nominal) / (2.0 * math.pi),
            reproduced=free_oscillation_frequency(p0, x_min), tolerance=0.01, unit="Hz",
            source="omega^2 = beta/m (A1^2/V1 + A2^2/V2), minimum at V2 = (A2/A1)^(3/2) V1 "
                   f"(x = {1e3 * x_min:.1f} mm); simulated free oscillation after a 1 bar step, valve closed, no friction",
            kind="consistency",
        ),
    ]
