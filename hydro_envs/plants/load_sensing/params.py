"""Parameters of the load-sensing circuit of seed 000 Fig. 1: value, unit, range and source.

The flow compensator's spool, spring and damping are those of the seed-000 compensator
(:mod:`hydro_envs.plants.ls_compensator.params`, method-2 configuration); pressures absolute.
The index constants ``I_*`` are the columns of the packed kernel parameter array; ``D_*`` the
derived columns :func:`derived` computes and :meth:`LoadSensingParams.to_array` appends.
"""

from __future__ import annotations

import dataclasses
import math

from hydro_envs.jit import as_python
from hydro_envs.laws.seal_friction import dissipative_fade_velocity
from typing import ClassVar


from hydro_envs.laws.pipe import pipe_inductance, pipe_laminar_resistance
from hydro_envs.laws.relief import pressure_relief_conductance_bound
from hydro_envs.laws.viscosity import iso_vg_kinematic_viscosity
from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical
from hydro_envs.plants.load_sensing.bounds import local_mode_rates, orifice_rate_coefficients
from hydro_envs.plants.ls_compensator.params import ORIGINAL_SPRING_STIFFNESS, LSCompensatorParams

__all__ = ["PLANT", "LoadSensingParams", "N_PARAMS", "N_FIELDS", "derived"]

PLANT = "load_sensing"

_ATM = 1.0e5
_BAR = 1.0e5
_SPOOL_MASS = LSCompensatorParams().spool_mass
_SPOOL_D = LSCompensatorParams().spool_diameter
_A_SPOOL = 0.25 * math.pi * _SPOOL_D**2
_MARGIN = 20.0 * _BAR
_X_LAP = 0.5e-3
_PRELOAD = _MARGIN * _A_SPOOL - ORIGINAL_SPRING_STIFFNESS * _X_LAP  # 42.1 N


@dataclasses.dataclass(frozen=True)
class LoadSensingParams(PhysicalParams):
    """Parameters of the load-sensing circuit of 000 Fig. 1 (SI, absolute pressures)."""

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ('piston_area', 'stroke', 'line_volume', 'pump_displacement', 'spool_diameter')

    # ---- oil
    oil_grade: float = physical(46.0, "mm^2/s", (2.0, 1500.0), "000 sec. 3.3: ISO VG 46")
    oil_temperature: float = physical(
        40.0, "degC", (-20.0, 120.0), "000 sec. 3.4: c measured at 40, 30, 22 C"
    )
    oil_density: float = physical(870.0, "kg/m^3", (700.0, 1100.0), "assumed: ISO VG 46 mineral oil")
    bulk_modulus: float = physical(
        1.2e9, "Pa", (1e8, 3e9), "assumed: effective oil + hose modulus at 20-250 bar"
    )
    # ---- flow compensator (000, method-2 configuration)
    spool_diameter: float = physical(_SPOOL_D, "m", (1e-4, 0.1), "000 Table 1 a2 -> 7.00 mm (ls_compensator)")
    spool_mass: float = physical(
        _SPOOL_MASS + LSCompensatorParams().spring_mass / 3.0, "kg", (1e-4, 10.0),
        "000 Table 1: m = 20.47 g incl. 1/3 of the spring (ls_compensator)",
    )
    spring_stiffness: float = physical(
        ORIGINAL_SPRING_STIFFNESS, "N/m", (0.0, 1e8), "000 eq (19): original spring, 294 Hz",
        open_low=True,
    )
    spring_preload: float = physical(
        _PRELOAD, "N", (0.0, 1e4),
        "000 sec. 2: margin 'typically around 20 bar' = (F0 + k x_lap)/A at x_lap = 0.5 mm",
    )
    viscous_friction_40c: float = physical(
        3.5, "N s/m", (0.0, 1e4), "000 sec. 4-5: c = 3.5 N/(m/s) at 40 C, proportional to viscosity"
    )
    spool_stroke: float = physical(3.0e-3, "m", (0.0, 0.1), "assumed: 3 mm FC spool travel", open_low=True)
    spool_stop_stiffness: float = physical(
        1.0e6, "N/m", (1e4, 2e7),
        "assumed: seat + spring-seat compliance, 0.1 mm at 100 N (softer than ls_compensator's "
        "2e6: the seat is touched only in transients, and it sets the RK4 step)",
    )
    spool_stop_damping: float = physical(
        0.05, "s/m", (0.0, 20.0), "assumed: Hunt-Crossley alpha, restitution ~0.99 at 0.1 m/s"
    )
    metering_width: float = physical(
        1.0e-3, "m", (2e-6, 0.1),
        "assumed: one 1 mm port (pump-control FC metering; half the method-2 test configuration)",
    )
    metering_lap: float = physical(
        _X_LAP, "m", (0.0, 0.01), "assumed: P -> X opens 0.5 mm from the seat (X -> T open below)"
    )
    port_length: float = physical(1.0e-3, "m", (1e-6, 0.05), "assumed: 1 mm ports")
    discharge_coefficient: float = physical(
        0.7, "1", (0.05, 1.0), "000 sec. 1: discharge coefficients 0.6-0.9"
    )
    jet_angle: float = physical(math.radians(69.0), "rad", (0.0, 0.5 * math.pi), "assumed: 69 deg jet angle")
    solenoid_force_max: float = physical(
        20.0, "N", (0.0, 1e3),
        "assumed: +-20 N electro-proportional force = +-5.2 bar of margin on the 7 mm spool",
    )
    solenoid_time_constant: float = physical(
        0.01, "s", (1e-4, 1.0), "assumed: 10 ms proportional solenoid + current driver"
    )
    # ---- LS pilot line (000 eqs (1)-(3), (5)-(6))
    ls_line_length: float = physical(2.0, "m", (0.01, 50.0), "assumed: 2 m LS hose from valve block to pump")
    ls_line_diameter: float = physical(4.0e-3, "m", (1e-4, 0.05), "assumed: 4 mm bore LS hose")
    ls_damping_resistance: float = physical(
        3.0e11, "Pa s/m^3", (0.0, 1e14),
        "assumed: damping restrictor at the pump end of the LS line (standard in LS controllers); "
        "with the line + chamber capacitance a 6.5 ms low-pass on p_LS. Without it (R of the hose "
        "alone) the hydro-mechanical loop limit-cycles with 4 t / 40 kN loads; 1e11 still does",
    )
    spring_chamber_volume: float = physical(
        1.0e-6, "m^3", (1e-8, 1e-3), "assumed: 1 cm^3 FC spring chamber at the spool's seat", open_low=True,
    )
    # ---- pump and its control pistons
    pump_displacement: float = physical(
        28.0e-6 / (2.0 * math.pi), "m^3/rad", (0.0, 3e-4),
        "assumed: 28 cm^3/rev axial piston LS pump", open_low=True,
    )
    pump_speed: float = physical(
        1500.0 * 2.0 * math.pi / 60.0, "rad/s", (0.0, 1e3), "assumed: 1500 rpm drive", open_low=True
    )
    pump_leakage: float = physical(
        5.0e-13, "m^3/(s Pa)", (0.0, 1e-8), "assumed: 0.6 L/min at 200 bar (2 % of full flow)"
    )
    control_area_large: float = physical(
        0.25 * math.pi * 0.020**2, "m^2", (1e-6, 0.1), "assumed: piston 1, 20 mm (000 Fig. 1 'actuator 1')"
    )
    control_area_small: float = physical(
        0.25 * math.pi * 0.014**2, "m^2", (1e-6, 0.1), "assumed: piston 2, 14 mm (000 Fig. 1 'actuator 2')"
    )
    control_stroke: float = physical(8.0e-3, "m", (1e-4, 0.1), "assumed: 8 mm piston travel, full to zero displacement")
    control_mass: float = physical(
        1.0, "kg", (1e-3, 100.0), "assumed: swash plate inertia and pistons reflected to the control piston"
    )
    control_damping: float = physical(
        2000.0, "N s/m", (0.0, 1e6), "assumed: swash-plate bearing friction, damping ratio ~0.3 on the oil spring"
    )
    bias_spring_preload: float = physical(150.0, "N", (0.0, 1e5), "assumed: return spring holding full displacement")
    bias_spring_stiffness: float = physical(1.0e4, "N/m", (0.0, 1e7), "assumed")
    control_volume: float = physical(
        2.0e-5, "m^3", (2e-7, 1e-2),
        "assumed: 20 cm^3 behind piston 1 at full displacement (chamber + drilled control line)",
    )
    control_leakage: float = physical(
        2.0e-13, "m^3/(s Pa)", (0.0, 1e-9), "assumed: piston-1 clearance leak, 0.12 L/min at 100 bar"
    )
    control_stop_stiffness: float = physical(
        1.0e7, "N/m", (1e4, 1e11), "assumed: swash-plate stop, 0.1 mm at 1 kN (reflected compliance)"
    )
    delivery_volume: float = physical(
        3.0e-4, "m^3", (2e-6, 1.0),
        "assumed: pump outlet + 1 m hose, 0.3 L (allowed from 2 cm^3: the CV, FC port and relief into a "
        "smaller node need more than the sub-step cap)",
    )
    relief_pressure: float = physical(250.0e5 + _ATM, "Pa", (1e6, 1e8), "assumed: 250 bar relief")
    relief_gradient: float = physical(
        1.0e-9, "m^3/(s Pa)", (0.0, 2e-7),
        "assumed: 42 L/min (the pump's full flow, 28 cm^3/rev at 1500 rpm) at 7 bar override: "
        "7.0e-4 m^3/s / 7e5 Pa = 1.0e-9 (hydro_envs.laws.relief.linear_relief_flow)",
    )
    # ---- main control valve and actuator
    cv_area_max: float = physical(
        1.5e-5, "m^2", (1e-8, 2e-3),
        "assumed: CV passes ~42 L/min (the pump's full flow) at the 20 bar margin",
    )
    piston_area: float = physical(0.25 * math.pi * 0.063**2, "m^2", (1e-4, 1.0), "assumed: 63 mm single-acting cylinder")
    stroke: float = physical(0.6, "m", (0.01, 10.0), "assumed: 600 mm stroke")
    line_volume: float = physical(
        5.0e-4, "m^3", (2e-6, 1.0),
        "assumed: 0.5 L hose CV -> cylinder + dead volume (allowed from 2 cm^3: the CV and the port "
        "relief into a smaller line need more than the sub-step cap)",
    )
    load_mass: float = physical(1000.0, "kg", (1.0, 1e5), "assumed: 1 t inertial load (randomised)")
    load_force: float = physical(2.0e4, "N", (0.0, 1e6), "assumed: 20 kN load, 64 bar (randomised)")
    actuator_viscous: float = physical(3000.0, "N s/m", (0.0, 1e6), "assumed: seal + guide viscous friction")
    actuator_coulomb: float = physical(300.0, "N", (0.0, 1e5), "assumed: seal Coulomb friction")
    actuator_bristle_stiffness: float = physical(
        6e6, "N/m", (1e4, 1e10),
        "assumed: LuGre sigma0 of the actuator's seals; pre-sliding displacement F_c/sigma0 = 50 um, "
        "within the 10-100 um of elastomer hydraulic seals",
    )
    actuator_bristle_damping: float = physical(
        1.5e5, "N s/m", (0.0, 1e8),
        "assumed: LuGre sigma1 = 2 sqrt(sigma0 M), critically damped pre-sliding oscillation of the 1 t "
        "load on the seals; fades with speed (hydro_envs.laws.seal_friction, fading velocity 1 mm/s or "
        "less where that keeps the law dissipative)",
    )
    actuator_bristle_relaxation_cap: float = physical(
        4000.0, "1/s", (0.0, 1e7),
        "assumed (numerics): bristle relaxation faster than this is instantaneous, the quasi-static limit "
        "of LuGre (hydro_envs.laws.seal_friction); LuGre exactly below |v| = cap F_c / sigma0 = 0.2 m/s",
    )
    actuator_stop_stiffness: float = physical(1.0e8, "N/m", (1e4, 1e11), "assumed: steel stop")
    tank_pressure: float = physical(_ATM, "Pa", (0.0, 1e6), "assumed: tank at atmosphere")
    orifice_transition_pressure: float = physical(
        1.0e5, "Pa", (1.0, 1e6), "assumed: repo default 1 bar; every working drop here is >= 20 bar"
    )
    pressure_floor: float = physical(1e3, "Pa", (0.0, 1e5), "assumed: cavitation floor")
    # ---- port relief on the actuator line (hydro_envs.laws.relief); 000 Fig. 1 draws none
    load_relief_pressure: float = physical(
        280.0e5 + _ATM, "Pa", (1e6, 1e8),
        "assumed: cracking pressure of the actuator line's port (shock) relief to tank, 280 bar gauge, "
        "12 % above the 250 bar main relief (usual practice: port reliefs of an LS valve section sit "
        "above the main relief, so they open only on load-induced pressure)",
    )
    load_relief_override: float = physical(
        28.0e5, "Pa", (1e4, 5e7),
        "assumed: cracking to rated flow in 10 % of the setting (direct-acting relief valves' p-Q "
        "curves rise 10-20 % over their flow range)", open_low=True,
    )
    load_relief_flow: float = physical(
        1.0e-3, "m^3/s", (0.0, 1e-1),
        "assumed: rated flow 60 L/min at full opening, the 63 mm cylinder falling at 0.32 m/s; 0 = no relief",
    )

    def _check_relations(self) -> None:
        if not (self.pressure_floor < self.tank_pressure < self.relief_pressure):
            raise ParameterError(
                "LoadSensingParams: need pressure_floor < tank_pressure < relief_pressure, got "
                f"{self.pressure_floor}, {self.tank_pressure}, {self.relief_pressure} Pa"
            )
        if not self.load_relief_pressure > self.tank_pressure:
            raise ParameterError(
                f"LoadSensingParams.load_relief_pressure = {self.load_relief_pressure} Pa must be above "
                f"tank_pressure = {self.tank_pressure} Pa (the port relief cracks at the difference)"
            )
        if self.control_area_small >= self.control_area_large:
            raise ParameterError(
                "LoadSensingParams.control_area_small must be below control_area_large (000 sec. 2: "
                f"piston 2 is the smaller), got {self.control_area_small} >= {self.control_area_large}"
            )
        a = 0.25 * math.pi * self.spool_diameter**2
        if self.spring_chamber_volume <= a * (self.spool_stroke + 1e-4):
            raise ParameterError(
                "LoadSensingParams.spring_chamber_volume must exceed the spool's swept volume "
                f"A * stroke + 0.1 mm of travel (A from spool_diameter, stroke = spool_stroke) = "
                f"{a * (self.spool_stroke + 1e-4)} m^3, got {self.spring_chamber_volume} m^3"
            )

    derived_names: ClassVar[tuple[str, ...]] = (
        "spool_area", "viscous", "ls_inductance", "ls_resistance", "ls_line_volume", "k_meter", "k_flow_force",
        "local_rate", "drop_rate", "leak_rate", "inv_spool_mass", "inv_control_mass", "inv_control_stroke",
        "delivery_stiffness", "inv_load_mass", "inv_ls_inductance", "inv_solenoid_time_constant",
        "micro_damping_velocity", "load_relief_conductance")

    def derived_columns(self) -> list[float]:
        d = derived(self)
        return [d[k] for k in self.derived_names]


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(LoadSensingParams)
N_FIELDS = len(LoadSensingParams.names())
_DERIVED = LoadSensingParams.derived_names
N_PARAMS = len(_COL)
I_VG = _COL["oil_grade"]
I_T = _COL["oil_temperature"]
I_RHO = _COL["oil_density"]
I_BETA = _COL["bulk_modulus"]
I_DS = _COL["spool_diameter"]
I_MS = _COL["spool_mass"]
I_K = _COL["spring_stiffness"]
I_F0 = _COL["spring_preload"]
I_C40 = _COL["viscous_friction_40c"]
I_XMAX = _COL["spool_stroke"]
I_KSS = _COL["spool_stop_stiffness"]
I_ASS = _COL["spool_stop_damping"]
I_W = _COL["metering_width"]
I_XLAP = _COL["metering_lap"]
I_LPORT = _COL["port_length"]
I_CD = _COL["discharge_coefficient"]
I_THETA = _COL["jet_angle"]
I_FSMAX = _COL["solenoid_force_max"]
I_TSOL = _COL["solenoid_time_constant"]
I_LLS = _COL["ls_line_length"]
I_DLS = _COL["ls_line_diameter"]
I_RD = _COL["ls_damping_resistance"]
I_VSC = _COL["spring_chamber_volume"]
I_DP = _COL["pump_displacement"]
I_WP = _COL["pump_speed"]
I_GP = _COL["pump_leakage"]
I_A1 = _COL["control_area_large"]
I_A2 = _COL["control_area_small"]
I_YMAX = _COL["control_stroke"]
I_MY = _COL["control_mass"]
I_BY = _COL["control_damping"]
I_FB0 = _COL["bias_spring_preload"]
I_KB = _COL["bias_spring_stiffness"]
I_VX0 = _COL["control_volume"]
I_GX = _COL["control_leakage"]
I_KYS = _COL["control_stop_stiffness"]
I_VS = _COL["delivery_volume"]
I_PRV = _COL["relief_pressure"]
I_GRV = _COL["relief_gradient"]
I_ACVMAX = _COL["cv_area_max"]
I_AC = _COL["piston_area"]
I_STROKE = _COL["stroke"]
I_VL0 = _COL["line_volume"]
I_M = _COL["load_mass"]
I_FL = _COL["load_force"]
I_BA = _COL["actuator_viscous"]
I_FCA = _COL["actuator_coulomb"]
I_SIG0 = _COL["actuator_bristle_stiffness"]
I_SIG1 = _COL["actuator_bristle_damping"]
I_ZCAP = _COL["actuator_bristle_relaxation_cap"]
I_KAS = _COL["actuator_stop_stiffness"]
I_PT = _COL["tank_pressure"]
I_DPTR = _COL["orifice_transition_pressure"]
I_PFLOOR = _COL["pressure_floor"]
I_PRVL = _COL["load_relief_pressure"]
I_POVL = _COL["load_relief_override"]
I_QRVL = _COL["load_relief_flow"]
D_A = _COL["spool_area"]
D_C = _COL["viscous"]
D_LLS = _COL["ls_inductance"]
D_RLS = _COL["ls_resistance"]
D_VLINE = _COL["ls_line_volume"]
D_KM = _COL["k_meter"]
D_KFF = _COL["k_flow_force"]
D_LOCAL = _COL["local_rate"]
D_DROPRATE = _COL["drop_rate"]
D_LEAKRATE = _COL["leak_rate"]
D_INV_MS = _COL["inv_spool_mass"]
D_INV_MY = _COL["inv_control_mass"]
D_INV_YMAX = _COL["inv_control_stroke"]
D_BETA_VS = _COL["delivery_stiffness"]
D_INV_M = _COL["inv_load_mass"]
D_INV_LLS = _COL["inv_ls_inductance"]
D_INV_TSOL = _COL["inv_solenoid_time_constant"]
D_FADE = _COL["micro_damping_velocity"]
D_GRVL = _COL["load_relief_conductance"]


def derived(params: LoadSensingParams) -> dict[str, float]:
    """Kernel quantities computed once per parameter set (viscosity-dependent c and R; the
    reciprocals of the masses, the LS line's inductance, the solenoid's time constant and the
    control stroke, and the delivery volume's stiffness beta/V_s; the largest worst-case rate of
    the locally refined modes, :func:`.bounds.local_mode_rates`, and the coefficients of their
    bound in the smallest drop, :func:`.bounds.orifice_rate_coefficients`)."""
    p = params
    # the laws' Python bodies (the same libm calls, bit-identical): making a parameter set compiles nothing
    nu = as_python(iso_vg_kinematic_viscosity)(p.oil_grade, p.oil_temperature)
    nu40 = as_python(iso_vg_kinematic_viscosity)(p.oil_grade, 40.0)
    d = {
        "spool_area": 0.25 * math.pi * p.spool_diameter**2,
        "viscous": p.viscous_friction_40c * nu / nu40,
        "ls_inductance": as_python(pipe_inductance)(p.oil_density, p.ls_line_length, p.ls_line_diameter),
        "ls_resistance": as_python(pipe_laminar_resistance)(nu * p.oil_density, p.ls_line_length, p.ls_line_diameter),
        "ls_line_volume": 0.25 * math.pi * p.ls_line_diameter**2 * p.ls_line_length,
        "k_meter": p.discharge_coefficient * math.sqrt(2.0 / p.oil_density),
        "k_flow_force": 2.0 * p.discharge_coefficient * math.cos(p.jet_angle) * p.metering_width,
    }
    #: the load line's port relief at its steepest (hydro_envs.laws.relief, the law's Python body)
    d["load_relief_conductance"] = as_python(pressure_relief_conductance_bound)(
        p.load_relief_pressure - p.tank_pressure, p.load_relief_override, p.load_relief_flow)
    d["local_rate"] = max(local_mode_rates(p, d).values())
    d["drop_rate"], d["leak_rate"] = orifice_rate_coefficients(p, d)
    # the right-hand side's parameter-only divisions as factors (a multiplication is off the
    # critical path of an RK4 stage where a division is not)
    d["inv_spool_mass"] = 1.0 / p.spool_mass
    d["inv_control_mass"] = 1.0 / p.control_mass
    d["inv_control_stroke"] = 1.0 / p.control_stroke
    d["delivery_stiffness"] = p.bulk_modulus / p.delivery_volume
    d["inv_load_mass"] = 1.0 / p.load_mass
    d["inv_ls_inductance"] = 1.0 / d["ls_inductance"]
    d["inv_solenoid_time_constant"] = 1.0 / p.solenoid_time_constant
    #: micro-damping fading velocity: 1 mm/s (a Coulomb-only seal has no Stribeck velocity; assumed)
    d["micro_damping_velocity"] = dissipative_fade_velocity(p.actuator_bristle_damping, 1e-3, p.actuator_coulomb)
    return d
