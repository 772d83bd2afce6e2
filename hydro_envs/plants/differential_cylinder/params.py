"""Parameters of the differential cylinder: data-sheet values, unit, allowed range and source.

The defaults are the issue's example rig (issue 54: 63 mm bore, 36 mm rod, 300 mm stroke,
160 bar supply, 40 L/min proportional valve at 70 bar, 60 Hz bandwidth); every other value is
``"assumed: reason"``. Pressures are absolute inside (gauge data-sheet values + 1 atm).
The valve is given as a data sheet gives it: rated flow ``Q_N`` at the rated valve pressure
drop ``dp_N`` (the usual convention: ``dp_N`` over the valve, two metering edges in series,
``dp_N / 2`` = 35 bar per edge), the -3 dB bandwidth and damping of its spool, and its lap.
Terms that depend on the parameters only (areas, flow coefficient, spool natural frequency) are
derived kernel columns (``derived_names``). Column indices ``I_*`` are generated from the
dataclass' field order. The allowed ranges are physical and keep every range end under the
envs' sub-step cap (1000 per 1 ms step; tests/test_range_ends.py): rated flow up to 0.1 m^3/s
(6000 L/min), friction levels up to 5 kN, an orifice transition pressure of at least 100 Pa.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical

__all__ = ["PLANT", "DifferentialCylinderParams", "N_PARAMS", "ATMOSPHERE", "bandwidth_to_natural_frequency",
           "edge_flow_coefficient"]

PLANT = "differential_cylinder"
#: ambient pressure [Pa] added to the data sheet's gauge pressures (ISO 2533 standard atmosphere)
ATMOSPHERE = 101325.0
_SHEET = "data sheet of the issue's example rig (issue 54)"


def bandwidth_to_natural_frequency(bandwidth_hz: float, zeta: float) -> float:
    """Natural frequency [rad/s] of a second-order spool whose -3 dB amplitude frequency is
    ``bandwidth_hz`` at damping ``zeta``: ``|G(j w_b)| = 1/sqrt(2)`` gives
    ``w_b = w_n sqrt(1 - 2 zeta^2 + sqrt((1 - 2 zeta^2)^2 + 1))`` (any control text, e.g.
    Ogata, *Modern Control Engineering*, 5th ed., sec. 7-2)."""
    a = 1.0 - 2.0 * zeta * zeta
    return 2.0 * math.pi * bandwidth_hz / math.sqrt(a + math.sqrt(a * a + 1.0))


def edge_flow_coefficient(rated_flow: float, rated_drop: float) -> float:
    """Flow coefficient of one fully open metering edge [m^3/(s sqrt(Pa))]: ``Q = K sqrt(dp)``
    with ``Q_N`` at ``dp_N / 2`` per edge (two edges in series share the rated valve drop;
    Bosch Rexroth/Parker/Moog proportional-valve catalogues quote ``Q_N`` at 70 bar valve drop,
    35 bar per edge)."""
    return rated_flow / math.sqrt(0.5 * rated_drop)


@dataclasses.dataclass(frozen=True)
class DifferentialCylinderParams(PhysicalParams):
    """Parameters of the valve-controlled differential cylinder (SI; pressures absolute)."""

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ("bore", "rod", "stroke", "line_volume_1", "line_volume_2")

    bore: float = physical(0.063, "m", (0.005, 1.0), f"{_SHEET}: 63 mm bore")
    rod: float = physical(0.036, "m", (0.002, 0.9), f"{_SHEET}: 36 mm rod")
    stroke: float = physical(0.3, "m", (0.0, 10.0), f"{_SHEET}: 300 mm stroke", open_low=True)
    line_volume_1: float = physical(
        100e-6, "m^3", (0.0, 0.1),
        "assumed: cap-side dead volume, ~1 m of DN10 hose (79 cm^3) plus port and manifold volume",
        open_low=True,
    )
    line_volume_2: float = physical(
        100e-6, "m^3", (0.0, 0.1), "assumed: rod-side dead volume, as line_volume_1", open_low=True
    )
    mass: float = physical(
        40.0, "kg", (0.1, 1e5), "assumed: piston and rod (~5 kg for 63/36/300) plus a 35 kg carriage"
    )
    supply_pressure: float = physical(160e5 + ATMOSPHERE, "Pa", (2e5, 70e6), f"{_SHEET}: 160 bar (gauge) supply")
    tank_pressure: float = physical(ATMOSPHERE, "Pa", (0.0, 1e6), "assumed: tank line at atmosphere")
    ambient_pressure: float = physical(
        ATMOSPHERE, "Pa", (0.0, 2e5),
        "ISO 2533 standard atmosphere: acts on the rod's end face A1 - A2 (cancels on a double-rod cylinder)",
    )
    bulk_modulus: float = physical(
        1.2e9, "Pa", (1e7, 3e9), "assumed: effective bulk modulus of mineral oil with short hoses (1.0-1.4 GPa)"
    )
    rated_flow: float = physical(
        float(f"{40.0 / 60e3:.15g}"), "m^3/s", (0.0, 0.1), f"{_SHEET}: 40 L/min at the rated pressure drop", open_low=True
    )
    rated_pressure_drop: float = physical(
        70e5, "Pa", (1e5, 700e5),
        f"{_SHEET}: 70 bar over the valve (the catalogues' convention: 35 bar per metering edge)",
    )
    valve_bandwidth: float = physical(
        60.0, "Hz", (1.0, 2000.0), f"{_SHEET}: 60 Hz (-3 dB, small signal)"
    )
    valve_damping: float = physical(
        0.7, "1", (0.1, 5.0), "assumed: 0.7, typical of proportional/servo-valve frequency responses"
    )
    valve_lap: float = physical(
        0.0, "1", (-0.2, 0.5),
        "assumed: zero lap (servo-proportional valve for closed-loop position control); fraction of "
        "the nominal opening, Hopsan convention (> 0 overlap, < 0 underlap), "
        "hydro_envs.laws.orifice.spool_edge_opening",
    )
    command_max: float = physical(10.0, "V", (0.0, 100.0), f"{_SHEET}: +-10 V command for full opening",
                                  open_low=True)
    viscous_friction: float = physical(
        540.0, "N s/m", (0.0, 1e6),
        "assumed: servo plant's 250 N s/m (002 Table 1) x 63/29.05, the ratio of the seal circumferences",
    )
    coulomb_friction: float = physical(
        87.0, "N", (0.0, 5000.0), "assumed: servo plant's 40 N x 63/29.05 (seal circumference ratio)"
    )
    static_friction: float = physical(
        130.0, "N", (0.0, 5000.0), "assumed: servo plant's 60 N x 63/29.05 (F_S/F_C = 1.5)"
    )
    stribeck_velocity: float = physical(
        0.01, "m/s", (1e-5, 1.0), "assumed: 10 mm/s, as the servo plant (lubricated hydraulic seals)"
    )
    bristle_stiffness: float = physical(
        4.3e6, "N/m", (1e4, 1e10),
        "assumed: LuGre sigma0 for a pre-sliding displacement F_S/sigma0 = 30 um, as the servo plant",
    )
    bristle_damping: float = physical(
        2.6e4, "N s/m", (0.0, 1e7),
        "assumed: sigma1 = 2 sqrt(sigma0 m), critically damped pre-sliding oscillation of the 40 kg mass; "
        "fades with speed (hydro_envs.laws.seal_friction)",
    )
    bristle_relaxation_cap: float = physical(
        4000.0, "1/s", (0.0, 1e7), "assumed (numerics): as the servo plant, 1/(0.25 ms)"
    )
    load_force: float = physical(0.0, "N", (-1e6, 1e6), "assumed: no external load (positive opposes extension)")
    stop_stiffness: float = physical(
        1e9, "N/m", (1e5, 1e12), "assumed: steel stop, 0.05 mm penetration at full thrust A1 p_s"
    )
    stop_damping: float = physical(
        2.0, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, as the servo plant"
    )
    orifice_transition_pressure: float = physical(
        2e5, "Pa", (100.0, 1e7), "assumed: laminar core of the regularised root (NOTES.md), 2 bar"
    )
    pressure_floor: float = physical(
        1e3, "Pa", (0.0, 1e5), "assumed: cavitation floor, about the oil's vapour/gas-release pressure"
    )
    min_chamber_volume: float = physical(
        1e-7, "m^3", (0.0, 1.0), "assumed: guard only; the line volumes keep chambers >= 100 cm^3",
        open_low=True,
    )

    def _check_relations(self) -> None:
        name = type(self).__name__
        if not self.rod < self.bore:
            raise ParameterError(f"{name}.rod = {self.rod} m must be below bore = {self.bore} m (annulus area > 0)")
        if self.static_friction < self.coulomb_friction:
            raise ParameterError(f"{name}.static_friction = {self.static_friction} N must be >= coulomb_friction = "
                                 f"{self.coulomb_friction} N (Stribeck: F_S >= F_C)")
        if self.static_friction > 0.0 and not self.coulomb_friction > 0.0:
            raise ParameterError(f"{name}.coulomb_friction = {self.coulomb_friction} N must be > 0 when "
                                 f"static_friction = {self.static_friction} N > 0; set both to 0 for no dry friction")
        if not (self.pressure_floor < self.tank_pressure < self.supply_pressure):
            raise ParameterError(f"{name}: need pressure_floor < tank_pressure < supply_pressure, got "
                                 f"{self.pressure_floor}, {self.tank_pressure}, {self.supply_pressure} Pa")
        if self.min_chamber_volume >= min(self.line_volume_1, self.line_volume_2):
            raise ParameterError(f"{name}.min_chamber_volume = {self.min_chamber_volume} m^3 must be below "
                                 "line_volume_1 and line_volume_2")

    @property
    def piston_area(self) -> float:
        """Cap-side area A1 = pi/4 bore^2 [m^2]."""
        return 0.25 * math.pi * self.bore**2

    @property
    def annulus_area(self) -> float:
        """Rod-side area A2 = pi/4 (bore^2 - rod^2) [m^2]."""
        return 0.25 * math.pi * (self.bore**2 - self.rod**2)

    @property
    def area_ratio(self) -> float:
        """alpha = A2 / A1."""
        return self.annulus_area / self.piston_area

    #: derived kernel columns: the two areas, the ambient force on the rod's end face
    #: (A1 - A2) p_amb, one edge's flow coefficient at full opening, the spool's natural
    #: frequency, the seals' micro-damping fade velocity
    derived_names: ClassVar[tuple[str, ...]] = (
        "piston_area_1", "annulus_area_2", "ambient_rod_force", "edge_flow_coefficient", "valve_natural_frequency",
        "micro_damping_velocity",
    )

    def derived_columns(self) -> list[float]:
        from hydro_envs.laws.seal_friction import dissipative_fade_velocity

        return [
            self.piston_area,
            self.annulus_area,
            (self.piston_area - self.annulus_area) * self.ambient_pressure,
            edge_flow_coefficient(self.rated_flow, self.rated_pressure_drop),
            bandwidth_to_natural_frequency(self.valve_bandwidth, self.valve_damping),
            dissipative_fade_velocity(self.bristle_damping, self.stribeck_velocity, self.coulomb_friction),
        ]


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(DifferentialCylinderParams)
N_FIELDS = len(DifferentialCylinderParams.names())
N_PARAMS = len(_COL)
I_BORE = _COL["bore"]
I_ROD = _COL["rod"]
I_L = _COL["stroke"]
I_V1 = _COL["line_volume_1"]
I_V2 = _COL["line_volume_2"]
I_M = _COL["mass"]
I_PS = _COL["supply_pressure"]
I_PT = _COL["tank_pressure"]
I_PAMB = _COL["ambient_pressure"]
I_BETA = _COL["bulk_modulus"]
I_QN = _COL["rated_flow"]
I_DPN = _COL["rated_pressure_drop"]
I_FB = _COL["valve_bandwidth"]
I_ZV = _COL["valve_damping"]
I_LAP = _COL["valve_lap"]
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
I_A1 = _COL["piston_area_1"]
I_A2 = _COL["annulus_area_2"]
I_FAMB = _COL["ambient_rod_force"]
I_KQ = _COL["edge_flow_coefficient"]
I_WV = _COL["valve_natural_frequency"]
I_DFADE = _COL["micro_damping_velocity"]
