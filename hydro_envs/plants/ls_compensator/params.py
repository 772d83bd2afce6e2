"""Parameters of the seed-000 flow compensator and pilot pipe: value, unit, range and source.

Defaults: the method-1 configuration of ``000_d7d5fd9bd6b165a2.txt`` (Table 1, sec. 3.3) at
40 C, with the geometry backed out of Table 1 (module constants below say how). The index
constants ``I_*`` are the columns of the packed kernel parameter array; ``D_*`` the derived
columns :func:`derived` computes and :meth:`LSCompensatorParams.to_array` appends.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar


from hydro_envs.laws.pipe import pipe_inductance, pipe_laminar_resistance
from hydro_envs.laws.viscosity import iso_vg_kinematic_viscosity
from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical

__all__ = [
    "PLANT", "LSCompensatorParams", "N_PARAMS", "N_FIELDS", "N_SEG_MAX", "TABLE_1", "METHOD1_MEAN_GAUGE",
    "ORIGINAL_SPRING_STIFFNESS", "LVDT_MASS", "LVDT_FRICTION_40C", "derived",
]

PLANT = "ls_compensator"
#: most pipe segments of the distributed pilot line (state width 4 + 2 N_SEG_MAX)
N_SEG_MAX = 12

_ATM = 1.0e5  # Pa
_BAR = 1.0e5

#: 000 Table 1 (method-1 pipe, fluid and spool at 40 C), SI units: L kg/m^4, R Pa s/m^3,
#: C m^3/Pa, a0..a3 in the units of eq (12)'s denominator, frequencies Hz.
TABLE_1 = {
    "L": 2.182e7, "R": 1.935e9, "C": 5.660e-15,
    "a0": 3.731e12, "a1": 2.567e9, "a2": 2.140e7, "a3": 2.602e2,
    "omega_m": 108.0, "xi_m": 0.126, "omega_h": 453.0, "xi_h": 0.0155,
    "omega_1": 67.0, "omega_2": 733.0,
}
#: method-1 operating point: p1 "oscillate between 3 and 9 bar" around "about 6 bar" (sec. 3.3)
METHOD1_MEAN_GAUGE = 6.0 * _BAR

# Values backed out of 000 (see the module docstring); kept as named constants so tests and
# the validation report can show where each default comes from.
_PIPE_D = 4.074e-3  # m: L/R = d^2 / (32 nu_40), nu_40 = 46 mm^2/s
_PIPE_L = 0.3270  # m: L = rho l / a with rho = 870 kg/m^3
_M_TOTAL = 20.47e-3  # kg: c / (2 xi_m omega_m) with c = 3.5 N s/m, omega_m = 2 pi 108 Hz
_SPRING_MASS = 6.0e-3  # kg (assumed)
_K1 = 9425.0  # N/m: m omega_m^2
_SPOOL_D = 7.00e-3  # m: A^2/(mC) = a2 - omega_m^2 - omega_h^2 - 4 xi_m xi_h omega_m omega_h
#: original (method-2) spring: eq (19) 294 Hz with the same moving mass, k = m (2 pi 294)^2
ORIGINAL_SPRING_STIFFNESS = 6.984e4
#: LVDT core + rod: eq (19) 237 Hz with the original spring, m_LVDT = k / (2 pi 237)^2 - m
LVDT_MASS = 11.03e-3
#: LVDT friction at 40 C: c "equal to 7 N/(m/s)" with the LVDT (sec. 5) minus 3.5 without
LVDT_FRICTION_40C = 3.5


@dataclasses.dataclass(frozen=True)
class LSCompensatorParams(PhysicalParams):
    """Parameters of the seed-000 flow compensator and its pilot pipe (SI, absolute pressures).

    Defaults: the method-1 configuration of 000 (Table 1, sec. 3.3) at 40 C.
    """

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ('spool_diameter', 'pipe_length', 'pipe_diameter', 'chamber_volume')

    oil_grade: float = physical(
        46.0, "mm^2/s", (2.0, 1500.0), "000 sec. 3.3: ISO VG 46 oil (grade = nu at 40 C in mm^2/s)"
    )
    oil_temperature: float = physical(
        40.0, "degC", (-20.0, 120.0), "000 sec. 3.3: tests at 40 C (also 30 C and 22 C, sec. 3.4)"
    )
    oil_density: float = physical(
        870.0, "kg/m^3", (700.0, 1100.0),
        "assumed: ISO VG 46 mineral oil, 0.87 kg/L (000 gives no density; only nu = 46 mm^2/s "
        "enters L/R, so rho only splits L between length and density)",
    )
    bulk_modulus: float = physical(
        9.46e8, "Pa", (1e7, 3e9),
        "backed out of 000 Table 1: beta = V/C, V = pipe 4.26 cm^3 + assumed 1.0 cm^3 chamber + "
        "A x at 6 bar (eq (3)); 0.95 GPa, effective oil+air value at 6 bar (000 sec. 3.1 notes the "
        "dissolved-air uncertainty)",
    )
    pipe_length: float = physical(
        _PIPE_L, "m", (1e-3, 100.0), "backed out of 000 Table 1: L = rho l / a (eq (1)) with rho assumed",
    )
    pipe_diameter: float = physical(
        _PIPE_D, "m", (1e-4, 0.1),
        "backed out of 000 Table 1: L/R = d^2/(32 nu) with nu(40 C) = 46 mm^2/s (eqs (1)-(2))",
    )
    pipe_segments: float = physical(
        1.0, "1", (0.0, float(N_SEG_MAX)),
        "000 eqs (5)-(6): lumped RLC (1 segment); 2-12 = distributed line (000 sec. 3.4: 12 "
        "internal nodes); 0 = no pipe (p2 = p1, method 2)",
    )
    chamber_volume: float = physical(
        1.0e-6, "m^3", (1e-9, 1e-3),
        "assumed: pilot chamber + T-junction + transducer port at x = 0 (000 Fig. 10 fixed "
        "capacity); 1 cm^3 for a 7 mm spool valve",
        open_low=True,
    )
    spool_diameter: float = physical(
        _SPOOL_D, "m", (1e-4, 0.1), "backed out of 000 Table 1 a2 (eq (14)): A^2/(mC) -> 7.00 mm"
    )
    spool_mass: float = physical(
        _M_TOTAL - _SPRING_MASS / 3.0, "kg", (0.0, 10.0),
        "backed out of 000 Table 1 (omega_m, xi_m, eqs (7)-(8), c = 3.5): m = 20.47 g total, minus "
        "1/3 of the spring (sec. 3.1); spool + seat + annular oil (sec. 3.4)",
        open_low=True,
    )
    spring_mass: float = physical(
        _SPRING_MASS, "kg", (0.0, 1.0), "assumed: 6 g steel spring (only m = m_spool + m_spring/3 matters)"
    )
    spring_stiffness: float = physical(
        _K1, "N/m", (0.0, 1e8),
        "backed out of 000 Table 1: k = m omega_m^2, omega_m = 2 pi 108 Hz (method-1 test spring)",
        open_low=True,
    )
    spring_preload: float = physical(
        0.0, "N", (0.0, 1e4), "000 eq (4): no preload term (method-1 test spring)"
    )
    viscous_friction_40c: float = physical(
        3.5, "N s/m", (0.0, 1e4), "000 sec. 4 and 5: c = 3.5 N/(m/s) at 40 C (method 1: 3-4)"
    )
    lvdt_mass: float = physical(
        0.0, "kg", (0.0, 1.0), "000 sec. 5: no LVDT in methods 1-2 (LVDT_MASS = 11.03 g when fitted)"
    )
    lvdt_friction_40c: float = physical(
        0.0, "N s/m", (0.0, 1e4), "000 sec. 5: no LVDT (LVDT_FRICTION_40C = 3.5 when fitted)"
    )
    spring_chamber_pressure: float = physical(
        _ATM, "Pa", (0.0, 5e7), "000 sec. 3.1/3.3: spring chamber connected to atmosphere"
    )
    spool_stroke: float = physical(
        8.0e-3, "m", (0.0, 0.1), "assumed: 8 mm travel of a 7 mm LS spool", open_low=True
    )
    stop_stiffness: float = physical(
        2.0e6, "N/m", (1e4, 1e11),
        "assumed: seat plus spring-seat compliance, 40 um penetration at 80 N; stiffer seats only "
        "shorten the RK4 step (sqrt(k/m) = 9.9e3 1/s here)",
    )
    stop_damping: float = physical(
        0.5, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, restitution ~0.97 at 0.1 m/s"
    )
    metering_width: float = physical(
        0.0, "m", (0.0, 0.1),
        "000 sec. 3.3: ports closed in method 1 (0); method 2: 2 mm (assumed: two 1 mm radial holes)",
    )
    metering_lap: float = physical(
        0.0, "m", (-0.01, 0.01), "assumed: critically lapped P->X / X->T land at the seat"
    )
    port_length: float = physical(
        1.0e-3, "m", (1e-6, 0.05), "assumed: 1 mm port, the opening saturates beyond it", 
    )
    discharge_coefficient: float = physical(
        0.7, "1", (0.0, 1.0), "000 sec. 1: discharge coefficients 'typically between 0.6 and 0.9'",
        open_low=True,
    )
    jet_angle: float = physical(
        math.radians(69.0), "rad", (0.0, 0.5 * math.pi),
        "assumed: 69 deg jet angle of a sharp spool edge (von Mises); 000 sec. 4 lists the "
        "hydrodynamic force",
    )
    outlet_volume: float = physical(
        2.0e-6, "m^3", (1e-8, 1e-2),
        "assumed: 2 cm^3 port X + transducer + line to the orifice (000 sec. 4: 'layout compacted')",
    )
    outlet_orifice_diameter: float = physical(
        1.2e-3, "m", (0.0, 0.05), "000 sec. 4: calibrated orifice 1.2 mm (also 0.75 mm)"
    )
    outlet_orifice_cd: float = physical(
        0.65, "1", (0.0, 1.0), "assumed: sharp-edged calibrated orifice at high Reynolds number"
    )
    tank_pressure: float = physical(_ATM, "Pa", (0.0, 5e6), "assumed: return line at atmosphere")
    max_pressure: float = physical(
        1.0e7, "Pa", (1e5, 1e8),
        "assumed: 100 bar ceiling of the rigs' pressures (000: 9 bar method 1, 50 bar method 2); "
        "sizes the stop-force and flow-force terms of the stiffness bound",
    )
    orifice_transition_pressure: float = physical(
        1.0e4, "Pa", (1.0, 1e6),
        "assumed: Hopsan default 1e4 Pa (docs/references.md); the 1.2 mm orifice works at ~1.7 bar, where "
        "1e5 Pa would bias its flow by 9 %",
    )
    pressure_floor: float = physical(
        1e3, "Pa", (0.0, 1e5), "assumed: cavitation floor, about the oil's vapour/gas-release pressure"
    )

    def _check_relations(self) -> None:
        n = self.pipe_segments
        if n != int(n):
            raise ParameterError(
                f"LSCompensatorParams.pipe_segments = {n} must be a whole number in [0, {N_SEG_MAX}]"
            )
        if not (self.pressure_floor < self.tank_pressure):
            raise ParameterError(
                "LSCompensatorParams: need pressure_floor < tank_pressure, got "
                f"{self.pressure_floor} >= {self.tank_pressure} Pa"
            )
        if not (self.pressure_floor < self.spring_chamber_pressure or self.spring_chamber_pressure == 0.0):
            raise ParameterError(
                "LSCompensatorParams.spring_chamber_pressure must be above pressure_floor (or 0), got "
                f"{self.spring_chamber_pressure} <= {self.pressure_floor} Pa"
            )

    # kernel array: the fields, then derived columns (viscosity-dependent c and R, ...),
    # computed once per parameter set so the right-hand side needs no transcendental calls
    derived_names: ClassVar[tuple[str, ...]] = (
        "mass", "viscous", "area", "inductance", "resistance", "pipe_volume", "k_meter", "k_orifice", "k_flow_force")

    def derived_columns(self) -> list[float]:
        d = derived(self)
        return [d[name] for name in self.derived_names]


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(LSCompensatorParams)
N_FIELDS = len(LSCompensatorParams.names())
_DERIVED = LSCompensatorParams.derived_names
N_PARAMS = len(_COL)
I_VG = _COL["oil_grade"]
I_T = _COL["oil_temperature"]
I_RHO = _COL["oil_density"]
I_BETA = _COL["bulk_modulus"]
I_LP = _COL["pipe_length"]
I_DP = _COL["pipe_diameter"]
I_NSEG = _COL["pipe_segments"]
I_VCH = _COL["chamber_volume"]
I_DS = _COL["spool_diameter"]
I_MS = _COL["spool_mass"]
I_MSPR = _COL["spring_mass"]
I_K = _COL["spring_stiffness"]
I_F0 = _COL["spring_preload"]
I_C40 = _COL["viscous_friction_40c"]
I_MLVDT = _COL["lvdt_mass"]
I_CLVDT = _COL["lvdt_friction_40c"]
I_PSPR = _COL["spring_chamber_pressure"]
I_STROKE = _COL["spool_stroke"]
I_KSTOP = _COL["stop_stiffness"]
I_ASTOP = _COL["stop_damping"]
I_W = _COL["metering_width"]
I_XLAP = _COL["metering_lap"]
I_LPORT = _COL["port_length"]
I_CD = _COL["discharge_coefficient"]
I_THETA = _COL["jet_angle"]
I_VO = _COL["outlet_volume"]
I_DO = _COL["outlet_orifice_diameter"]
I_CDO = _COL["outlet_orifice_cd"]
I_PT = _COL["tank_pressure"]
I_PMAX = _COL["max_pressure"]
I_DPTR = _COL["orifice_transition_pressure"]
I_PFLOOR = _COL["pressure_floor"]
D_M = _COL["mass"]
D_C = _COL["viscous"]
D_A = _COL["area"]
D_L = _COL["inductance"]
D_R = _COL["resistance"]
D_VPIPE = _COL["pipe_volume"]
D_KM = _COL["k_meter"]
D_KO = _COL["k_orifice"]
D_KFF = _COL["k_flow_force"]


def derived(params: LSCompensatorParams) -> dict[str, float]:
    """Quantities the kernel needs, computed from the fields (SI).

    ``mass`` = spool + spring/3 + LVDT (000 sec. 3.1, 5); ``viscous`` = c(T) = (c_40 + c_LVDT)
    nu(T)/nu(40 C) (000 Fig. 14); ``inductance``/``resistance`` of the whole pipe (eqs (1)-(2),
    mu = rho nu(T)); ``k_meter`` = C_d sqrt(2/rho) [m^1.5/kg^0.5]; ``k_orifice`` = C_o a_o
    sqrt(2/rho); ``k_flow_force`` = 2 C_d cos(theta) w [m].
    """
    p = params
    nu = iso_vg_kinematic_viscosity(p.oil_grade, p.oil_temperature)
    nu40 = iso_vg_kinematic_viscosity(p.oil_grade, 40.0)
    mu = nu * p.oil_density
    a_pipe = 0.25 * math.pi * p.pipe_diameter**2
    return {
        "mass": p.spool_mass + p.spring_mass / 3.0 + p.lvdt_mass,
        "viscous": (p.viscous_friction_40c + p.lvdt_friction_40c) * nu / nu40,
        "area": 0.25 * math.pi * p.spool_diameter**2,
        "inductance": pipe_inductance(p.oil_density, p.pipe_length, p.pipe_diameter),
        "resistance": pipe_laminar_resistance(mu, p.pipe_length, p.pipe_diameter),
        "pipe_volume": a_pipe * p.pipe_length,
        "k_meter": p.discharge_coefficient * math.sqrt(2.0 / p.oil_density),
        "k_orifice": p.outlet_orifice_cd * 0.25 * math.pi * p.outlet_orifice_diameter**2
        * math.sqrt(2.0 / p.oil_density),
        "k_flow_force": 2.0 * p.discharge_coefficient * math.cos(p.jet_angle) * p.metering_width,
        "kinematic_viscosity": nu,
        "dynamic_viscosity": mu,
    }
