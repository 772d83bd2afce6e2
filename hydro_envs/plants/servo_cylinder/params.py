"""Parameters of the seed-002 servo cylinder: value, unit, allowed range and source per field.

Defaults are Table 1 of ``002_af30b681d6ccfd6c.txt`` unless a field's ``source`` says
otherwise; pressures are absolute. The index constants ``I_*`` are the columns of the packed
kernel parameter array (:meth:`hydro_envs.params.PhysicalParams.to_array`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical

__all__ = ["PLANT", "ServoCylinderParams", "N_PARAMS"]

PLANT = "servo_cylinder"
_ATM = 1.0e5  # Pa, atmosphere used to turn the seed's gauge pressures into absolute ones

@dataclasses.dataclass(frozen=True)
class ServoCylinderParams(PhysicalParams):
    """Parameters of the seed-002 servo cylinder (SI; pressures absolute).

    Defaults are Table 1 of 002 unless the field's ``source`` says otherwise.
    """

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ('piston_area', 'stroke', 'line_volume_1', 'line_volume_2')

    supply_pressure: float = physical(
        13.8e6 + _ATM, "Pa", (2e5, 35e6),
        "002 sec. 3: operated at about 13.8 MPa (gauge) + 0.1 MPa atmosphere; Table 1 P_s <= 17 MPa",
    )
    tank_pressure: float = physical(
        _ATM, "Pa", (0.0, 5e6),
        "assumed: tank at atmosphere (002 Table 1: P_R < 0.25 MPa)",
    )
    mass: float = physical(12.3, "kg", (0.05, 1e4), "002 Table 1: m")
    piston_area: float = physical(6.63e-4, "m^2", (0.0, 0.5), "002 Table 1: A", open_low=True)
    stroke: float = physical(0.0696, "m", (0.0, 10.0), "002 Table 1: L", open_low=True)
    line_volume_1: float = physical(88.7e-6, "m^3", (0.0, 1.0), "002 Table 1: V1", open_low=True)
    line_volume_2: float = physical(88.7e-6, "m^3", (0.0, 1.0), "002 Table 1: V2", open_low=True)
    oil_density: float = physical(847.0, "kg/m^3", (500.0, 1500.0), "002 Table 1: rho_oil")
    bulk_modulus: float = physical(689e6, "Pa", (1e7, 3e9), "002 Table 1: beta_h")
    discharge_coefficient: float = physical(
        0.6, "1", (0.0, 1.0), "002 Table 1: C_v", open_low=True
    )
    area_gradient: float = physical(
        20.75e-3, "m", (0.0, 1.0), "002 Table 1: w = 20.75 mm^2/mm", open_low=True
    )
    spool_stroke: float = physical(
        0.279e-3, "m", (0.0, 0.01), "002 Table 1: x_vm", open_low=True
    )
    spool_gain: float = physical(
        0.0279e-3, "m/V", (0.0, 1e-3), "002 Table 1: k_v = 0.0279 mm/V", open_low=True
    )
    valve_natural_frequency: float = physical(
        2.0 * math.pi * 175.0, "rad/s", (10.0, 2e4), "002 Table 1: omega_v = 175 Hz"
    )
    valve_damping: float = physical(
        0.65, "1", (0.05, 5.0), "002 Table 1: zeta_v (printed unit cm^3 is an extraction defect)"
    )
    command_max: float = physical(
        10.0, "V", (0.0, 100.0), "002 Table 1: x_vm / k_v = 10 V", open_low=True
    )
    viscous_friction: float = physical(
        250.0, "N s/m", (0.0, 1e5), "002 Table 1: d (eq (7)); the F_V v term of eq (1)"
    )
    coulomb_friction: float = physical(
        40.0, "N", (0.0, 3000.0), "assumed: 002 Fig. 6-7 missing; tens of N for a 6.63 cm^2 seal set"
    )
    static_friction: float = physical(
        60.0, "N", (0.0, 3000.0), "assumed: F_S/F_C = 1.5, typical for lubricated hydraulic seals"
    )
    stribeck_velocity: float = physical(
        0.01, "m/s", (1e-5, 1.0), "assumed: 10 mm/s, inside 002's constant-velocity test range"
    )
    bristle_stiffness: float = physical(
        2e6, "N/m", (1e4, 1e9),
        "assumed: LuGre sigma0 of the piston and rod seals (002 gives no dynamic friction); "
        "pre-sliding displacement F_S/sigma0 = 30 um, inside the 10-100 um of elastomer "
        "hydraulic seals (the force actuator's 001 seals: 26 um)",
    )
    bristle_damping: float = physical(
        9.9e3, "N s/m", (0.0, 5e6),
        "assumed: LuGre sigma1 = 2 sqrt(sigma0 m), critically damped pre-sliding oscillation of the "
        "12.3 kg piston on its seals; fades with speed as exp(-(v/v_d)^2), v_d = v_S or less "
        "(hydro_envs.laws.seal_friction), which keeps the law dissipative",
    )
    bristle_relaxation_cap: float = physical(
        4000.0, "1/s", (0.0, 1e7),
        "assumed (numerics): bristle relaxation faster than this is taken as instantaneous, the "
        "quasi-static limit of LuGre (hydro_envs.laws.seal_friction): 1/(0.25 ms), a quarter of the "
        "1 ms control period; LuGre exactly below |v| = cap F_C / sigma0 = 80 mm/s (8 v_S); 0 = none",
    )
    load_force: float = physical(0.0, "N", (-5e4, 5e4), "002 eq (7): F_L, no load on the rig")
    stop_stiffness: float = physical(
        1e8, "N/m", (1e5, 1e11),
        "assumed: steel stop, 0.09 mm penetration at full thrust A*p_s",
    )
    stop_damping: float = physical(
        2.0, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, restitution ~0.3 at 0.5 m/s"
    )
    orifice_transition_pressure: float = physical(
        1e5, "Pa", (1.0, 1e7),
        "assumed: laminar transition of the regularised root (docs/references.md: 1e5 Pa -> |lambda| 4.1e3 1/s)",
    )
    pressure_floor: float = physical(
        1e3, "Pa", (0.0, 1e5), "assumed: cavitation floor, about the oil's vapour/gas-release pressure"
    )
    min_chamber_volume: float = physical(
        1e-7, "m^3", (0.0, 1.0), "assumed: guard only; line volumes keep chambers >= 88.7 cm^3",
        open_low=True,
    )
    # --- effects outside the seed model (0 = the seed's model); the diagnosis catalogue
    # (identification/diagnosis/catalogue.py) adds them when measured data call for them.
    valve_overlap: float = physical(
        0.0, "m", (-0.1e-3, 0.1e-3),
        "002 eqs (3)-(4): critically lapped (0). > 0 overlap (dead band), < 0 underlap (all four "
        "edges open at null); Hopsan lap convention, hydro_envs.laws.orifice.spool_edge_opening",
    )
    internal_leakage: float = physical(
        0.0, "m^3/(s Pa)", (0.0, 1e-10),
        "002 eq (8): leak-free piston seal (0); laminar cross-piston leak Q = C_il (p1 - p2), "
        "as 003 eq (4)-(5) C_il",
    )
    external_leakage: float = physical(
        0.0, "m^3/(s Pa)", (0.0, 1e-10),
        "002 eq (8): no rod-seal leak (0); laminar leak of each chamber to tank Q = C_el (p_i - p_R), "
        "as 003 eq (4)-(5) C_el",
    )
    friction_asymmetry: float = physical(
        0.0, "1", (-0.9, 0.9),
        "002 eq (1): symmetric friction (0); Coulomb and static levels times (1 + a) for v > 0 and "
        "(1 - a) for v < 0 (rod-side vs cap-side seal lips, cf. 001 stiction +99/-54 N)",
    )
    friction_pressure_coefficient: float = physical(
        0.0, "N/Pa", (0.0, 1e-4),
        "002 eq (1): pressure-independent friction (0); Coulomb and static levels rise by "
        "c_p |p1 - p2| (piston seal pressed by the pressure difference; seal data in "
        "tests/data/pneumatic_seal_friction rise 5.4 -> 16.8 N from 1 to 7 bar)",
    )
    supply_line_resistance: float = physical(
        0.0, "Pa s/m^3", (0.0, 1e12),
        "002 eqs (3)-(4): constant supply pressure (0); the pressure at the valve's P port falls by "
        "R Q with the drawn flow Q (supply hose, pump compensator droop; "
        "hydro_envs.laws.orifice.supply_pressure_at_flow)",
    )
    # --- port relief valves, one per chamber to tank (hydro_envs.laws.relief); 002 prints none
    relief_pressure: float = physical(
        16.0e6 + _ATM, "Pa", (2e5, 1e8),
        "assumed: cracking pressure of the chambers' port reliefs to tank, 16 MPa gauge = 16 % above the "
        "13.8 MPa supply (002 sec. 3), usual practice (10-20 % above the system pressure), below the "
        "17 MPa of 002 Table 1; 002 prints no relief",
    )
    relief_override: float = physical(
        2.0e6, "Pa", (1e4, 5e7),
        "assumed: pressure rise from cracking to the rated flow, 12.5 % of the setting (direct-acting "
        "relief valves' p-Q curves rise 10-20 % over their flow range)", open_low=True,
    )
    relief_flow: float = physical(
        6.7e-4, "m^3/s", (0.0, 1e-1),
        "assumed: rated flow 40 L/min at full opening, 1.5 x the valve's 27 L/min no-load flow "
        "(002 Table 1 at 13.8 MPa): the displacement flow A v of the piston braking from 1.5 x its "
        "0.67 m/s no-load speed; 0 = no relief",
    )

    def _check_relations(self) -> None:
        if self.static_friction < self.coulomb_friction:
            raise ParameterError(
                f"ServoCylinderParams.static_friction = {self.static_friction} must be >= "
                f"coulomb_friction = {self.coulomb_friction} (Stribeck: F_S >= F_C)"
            )
        if self.static_friction > 0.0 and not self.coulomb_friction > 0.0:
            raise ParameterError(
                f"ServoCylinderParams.coulomb_friction = {self.coulomb_friction} must be > 0 when "
                f"static_friction = {self.static_friction} > 0 (the LuGre level must stay positive at "
                "speed); set both to 0 for seals without dry friction"
            )
        if not (self.pressure_floor < self.tank_pressure < self.supply_pressure):
            raise ParameterError(
                "ServoCylinderParams: need pressure_floor < tank_pressure < supply_pressure, got "
                f"{self.pressure_floor}, {self.tank_pressure}, {self.supply_pressure} Pa"
            )
        if not self.relief_pressure > self.tank_pressure:
            raise ParameterError(
                f"ServoCylinderParams.relief_pressure = {self.relief_pressure} Pa must be above tank_pressure "
                f"= {self.tank_pressure} Pa (the port reliefs crack at relief_pressure - tank_pressure > 0)"
            )
        if self.min_chamber_volume >= min(self.line_volume_1, self.line_volume_2):
            raise ParameterError(
                "ServoCylinderParams.min_chamber_volume must be below the line volumes line_volume_1 "
                f"and line_volume_2 ({self.min_chamber_volume} >= "
                f"{min(self.line_volume_1, self.line_volume_2)} m^3)"
            )

    #: derived kernel column: the speed over which the seals' micro-damping fades, the Stribeck
    #: velocity or less where that keeps the friction dissipative
    #: (hydro_envs.laws.seal_friction.dissipative_fade_velocity at the lowest sliding level)
    derived_names: ClassVar[tuple[str, ...]] = ("micro_damping_velocity",)

    def derived_columns(self) -> list[float]:
        from hydro_envs.laws.seal_friction import dissipative_fade_velocity

        g_min = (1.0 - abs(self.friction_asymmetry)) * self.coulomb_friction
        return [dissipative_fade_velocity(self.bristle_damping, self.stribeck_velocity, g_min)]


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(ServoCylinderParams)
N_FIELDS = len(ServoCylinderParams.names())
N_PARAMS = len(_COL)
I_PS = _COL["supply_pressure"]
I_PT = _COL["tank_pressure"]
I_M = _COL["mass"]
I_A = _COL["piston_area"]
I_L = _COL["stroke"]
I_V1 = _COL["line_volume_1"]
I_V2 = _COL["line_volume_2"]
I_RHO = _COL["oil_density"]
I_BETA = _COL["bulk_modulus"]
I_CD = _COL["discharge_coefficient"]
I_W = _COL["area_gradient"]
I_XVM = _COL["spool_stroke"]
I_KV = _COL["spool_gain"]
I_WV = _COL["valve_natural_frequency"]
I_ZV = _COL["valve_damping"]
I_UMAX = _COL["command_max"]
I_D = _COL["viscous_friction"]
I_FC = _COL["coulomb_friction"]
I_FS = _COL["static_friction"]
I_VS = _COL["stribeck_velocity"]
I_SIG0 = _COL["bristle_stiffness"]
I_SIG1 = _COL["bristle_damping"]
I_ZCAP = _COL["bristle_relaxation_cap"]
I_FL = _COL["load_force"]
I_KSTOP = _COL["stop_stiffness"]
I_ASTOP = _COL["stop_damping"]
I_DPTR = _COL["orifice_transition_pressure"]
I_PFLOOR = _COL["pressure_floor"]
I_VMIN = _COL["min_chamber_volume"]
I_LAP = _COL["valve_overlap"]
I_CIL = _COL["internal_leakage"]
I_CEL = _COL["external_leakage"]
I_FASYM = _COL["friction_asymmetry"]
I_FPC = _COL["friction_pressure_coefficient"]
I_RS = _COL["supply_line_resistance"]
I_PRV = _COL["relief_pressure"]
I_POV = _COL["relief_override"]
I_QRV = _COL["relief_flow"]
I_DFADE = _COL["micro_damping_velocity"]
