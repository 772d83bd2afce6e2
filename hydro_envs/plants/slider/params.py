"""Parameters of the generic force-driven slider: value, unit, allowed range and source."""

from __future__ import annotations

import dataclasses

from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical

__all__ = ["PLANT", "SliderParams", "N_PARAMS"]

PLANT = "slider"
_GENERIC = "assumed: generic stage"


@dataclasses.dataclass(frozen=True)
class SliderParams(PhysicalParams):
    """Parameters of the generic force-driven slider (SI)."""

    plant = PLANT
    #: a force-driven axis: no dimension the record cannot reveal
    geometry = ()

    mass: float = physical(1.0, "kg", (0.0, 1e5), f"{_GENERIC} (1 kg carriage)", open_low=True)
    coulomb_friction: float = physical(
        10.0, "N", (0.0, 1e6), f"{_GENERIC}; cf. 004 Table 2 F_c = 15.31 N (pneumatic cylinder)"
    )
    static_friction: float = physical(
        15.0, "N", (0.0, 1e6), f"{_GENERIC}: F_S/F_C = 1.5; cf. 004 Table 2 F_s = 35.48 N"
    )
    stribeck_velocity: float = physical(
        5e-3, "m/s", (1e-6, 10.0), f"{_GENERIC}: 5 mm/s; cf. 004 Table 2 v_s = 3.27 mm/s"
    )
    viscous_friction: float = physical(
        20.0, "N s/m", (0.0, 1e7), f"{_GENERIC}: lubricated guide, 002 eq (1) F_V term"
    )
    force_offset: float = physical(
        0.0, "N", (-1e6, 1e6),
        "assumed: level stage, no cable drag, unbiased force sensor (F_0 opposes +x)",
    )
    friction_sign_velocity: float = physical(
        5e-4, "m/s", (1e-7, 1.0),
        "assumed: tanh regularisation v_eps = v_S / 10 (Simscape's v_C/v_St ratio, docs/references.md); "
        "sets the stiffest mode",
    )
    stroke: float = physical(0.2, "m", (0.0, 100.0), f"{_GENERIC}: 200 mm travel", open_low=True)
    force_max: float = physical(
        100.0, "N", (0.0, 1e8),
        f"{_GENERIC}: actuator force range; bounds the stop-contact stiffness estimate",
        open_low=True,
    )
    stop_stiffness: float = physical(
        1e6, "N/m", (1e2, 1e11), "assumed: elastomer-padded stop, 0.1 mm penetration at force_max"
    )
    stop_damping: float = physical(
        2.0, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, restitution ~0.3 at 0.5 m/s"
    )
    backlash_gap: float = physical(
        0.0, "m", (0.0, 0.01),
        "assumed: rigid drive (0); > 0: a play of +-gap between the driven part and the measured "
        "load (gear, screw nut, coupling; hydro_envs.laws.contact.backlash_force)",
    )
    load_mass_fraction: float = physical(
        0.2, "1", (0.01, 0.99),
        "assumed: the measured load beyond the play carries this fraction of the mass and of the "
        "friction (guide friction grows with the carried weight); used only with a play",
    )
    coupling_stiffness: float = physical(
        1e6, "N/m", (1e3, 1e9),
        "assumed: drive-load contact across the play, 10 um at 10 N (a small screw or belt stage)",
    )
    coupling_damping: float = physical(
        240.0, "N s/m", (0.0, 1e5),
        "assumed: damping ratio 0.3 of the contact mode of the default stage (reduced mass "
        "0.16 kg at load_mass_fraction 0.2; lubricated gear or nut contact, restitution about 0.4)",
    )

    def _check_relations(self) -> None:
        if self.static_friction < self.coulomb_friction:
            raise ParameterError(
                f"SliderParams.static_friction = {self.static_friction} must be >= "
                f"coulomb_friction = {self.coulomb_friction} (Stribeck: F_S >= F_C)"
            )


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(SliderParams)
N_PARAMS = len(_COL)
I_M = _COL["mass"]
I_FC = _COL["coulomb_friction"]
I_FS = _COL["static_friction"]
I_VS = _COL["stribeck_velocity"]
I_B = _COL["viscous_friction"]
I_F0 = _COL["force_offset"]
I_VEPS = _COL["friction_sign_velocity"]
I_L = _COL["stroke"]
I_FMAX = _COL["force_max"]
I_KSTOP = _COL["stop_stiffness"]
I_ASTOP = _COL["stop_damping"]
I_GAP = _COL["backlash_gap"]
I_MU = _COL["load_mass_fraction"]
I_KC = _COL["coupling_stiffness"]
I_AC = _COL["coupling_damping"]
