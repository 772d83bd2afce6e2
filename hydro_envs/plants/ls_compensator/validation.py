"""Validation rows of the flow compensator against seed 000 (``000_d7d5fd9bd6b165a2.txt``).

Table 1 coefficients of the lumped pipe + spool model, the spool resonances of eq (19) and
sec. 5, and the resonances measured by the two virtual rigs.
"""

from __future__ import annotations

import math

from hydro_envs.plants.ls_compensator.experiments import rig_validation_rows
from hydro_envs.plants.ls_compensator.model import lumped_coefficients, lvdt_configuration, mechanical_resonance_hz, method2_configuration
from hydro_envs.plants.ls_compensator.params import TABLE_1, LSCompensatorParams
from hydro_envs.validation import ValidationRow

__all__ = ["rows"]


def rows() -> list[ValidationRow]:
    p = LSCompensatorParams()
    co = lumped_coefficients(p)
    two_pi = 2.0 * math.pi
    src_t1 = "000 Table 1 (lumped model eqs (1)-(17), defaults backed out, c = 3.5 N s/m at 40 C)"
    out = []
    for key, unit, scale in (
        ("L", "kg/m^4", 1.0), ("R", "Pa s/m^3", 1.0), ("C", "m^3/Pa", 1.0),
        ("a0", "1/s^4", 1.0), ("a1", "1/s^3", 1.0), ("a2", "1/s^2", 1.0), ("a3", "1/s", 1.0),
        ("omega_m", "Hz", two_pi), ("xi_m", "1", 1.0), ("omega_h", "Hz", two_pi),
        ("xi_h", "1", 1.0), ("omega_1", "Hz", two_pi), ("omega_2", "Hz", two_pi),
    ):
        out.append(ValidationRow(
            name=f"ls_compensator: {key} (lumped pipe + spool, method 1 at 40 C)",
            published=TABLE_1[key],
            reproduced=co[key] / scale,
            tolerance=0.01,
            unit=unit,
            source=src_t1,
        ))
    out.append(ValidationRow(
        name="ls_compensator: spool resonance eq (19), original spring (method 2)",
        published=294.0,
        reproduced=mechanical_resonance_hz(method2_configuration(p)),
        tolerance=0.01,
        unit="Hz",
        source="000 eq (19): sqrt(k_tot/m_tot)/(2 pi) = 294 Hz",
    ))
    out.append(ValidationRow(
        name="ls_compensator: spool resonance eq (19) with the LVDT fitted",
        published=237.0,
        reproduced=mechanical_resonance_hz(lvdt_configuration(p)),
        tolerance=0.01,
        unit="Hz",
        source="000 sec. 5: 'With the theoretical formula a value of 237 Hz was found'",
    ))
    out.extend(rig_validation_rows())
    return out
