"""Validation rows of the rodless cylinder against seed 004 (``004_f1423316a055addb.txt``).

* natural frequency, velocity gain and damping of the linearised model (eqs (22)-(24))
  against a fit of the nonlinear plant's small-step response;
* the friction read from eq (1) at constant speed against the Table 2 Stribeck curve.

The comparison with the seed's identified model, eq (32), runs the seed's identification
procedure on this plant and lives with the identification tools (:mod:`identification.validation`).
"""

from __future__ import annotations

import math

from hydro_envs.plants.rodless_cylinder.experiments import constant_command_run, small_signal_response
from hydro_envs.plants.rodless_cylinder.model import linearize_mid_stroke, steady_friction
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.validation import ValidationRow

__all__ = ["rows", "damping_with_viscous_friction"]


def damping_with_viscous_friction(lin, sigma: float) -> float:
    """Damping ratio of the mid-stroke linear model (eqs (19)-(24)) with the viscous friction
    ``sigma`` [N s/m] of Table 2 on the slider: the load-pressure/velocity pair
    ``s^2 + (a + sigma/M) s + (omega_n^2 + a sigma/M)`` with ``a = kappa R T_s c2 / V0`` (the
    energy-corrected c2, i.e. ``2 zeta_energy omega_n``)."""
    a = 2.0 * lin.zeta_energy * lin.omega_n
    b = sigma / lin.mass
    return (a + b) / (2.0 * math.sqrt(lin.omega_n**2 + a * b))


def rows() -> list[ValidationRow]:
    nominal = RodlessCylinderParams()
    lin = linearize_mid_stroke(nominal)
    fit = small_signal_response(nominal)
    rows = [
        ValidationRow(
            name="rodless_cylinder: natural frequency omega_n at mid-stroke, small valve step",
            published=lin.omega_n,
            reproduced=fit["omega_n"],
            tolerance=0.05,
            unit="rad/s",
            source="004 eq (24) omega_n = sqrt(2 kappa p0 A^2/(V0 M_L)) vs second-order fit of the nonlinear plant (F_f = 0, eq (21))",
            kind="consistency",
        ),
        ValidationRow(
            name="rodless_cylinder: velocity gain K_T at mid-stroke, small valve step",
            published=lin.k_t,
            reproduced=fit["k_t"],
            tolerance=0.05,
            unit="1/s",
            source="004 eq (22) K_T = c1 R T_s/(p0 A) with c1 of eq (6) vs the same fit",
            kind="consistency",
        ),
    ]
    rows.append(
        ValidationRow(
            name="rodless_cylinder: damping ratio zeta at mid-stroke, small valve step",
            published=lin.zeta_energy,
            reproduced=fit["zeta"],
            tolerance=0.05,
            unit="1",
            source=(
                "004 eq (23) with c2 of this plant's chambers: eq (16) vents the gas at T_s, the "
                "energy balance (eqs (10)-(13)) at the chamber's own temperature, which adds "
                "(kappa-1)/(2 kappa) mdot_out/p0 to c2 (see linearize_mid_stroke) vs the same fit"
            ),
            kind="consistency",
        )
    )
    # 004 sec. 3 / eq (1): constant-speed pressure difference = Table 2 friction curve
    v, f, _ = constant_command_run(nominal, nominal.command_centre + 0.4)
    rows.append(
        ValidationRow(
            name="rodless_cylinder: friction from eq (1) at constant speed (5.4 V)",
            published=float(steady_friction(nominal, v)) if math.isfinite(v) else float("nan"),
            reproduced=f,
            tolerance=0.02,
            unit="N",
            source=f"004 Table 2 Stribeck curve at the simulated speed {v * 1e3:.1f} mm/s vs A (pa - pb) of eq (1)",
            kind="consistency",
        )
    )
    return rows

