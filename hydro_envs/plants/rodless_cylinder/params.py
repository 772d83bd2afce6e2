"""Parameters of the seed-004 rodless cylinder: value, unit, allowed range and source per field.

Defaults: ``004_f1423316a055addb.txt`` (Table 2 friction, sec. 2 hardware: SMC MYC25G-110L,
FESTO MPYE-5, 0.6 MPa) and the data sheets named in each field's source; pressures absolute.
The index constants ``I_*`` are the columns of the packed kernel parameter array; ``D_*`` the
derived columns :meth:`RodlessCylinderParams.to_array` appends.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar


from hydro_envs.jit import as_python
from hydro_envs.laws.nozzle_fast import nozzle_flow_constants, nozzle_mass_flow_fast
from hydro_envs.laws.orifice import circular_orifice_area, iso6358_mass_flow_laminar
from hydro_envs.laws.pneumatic_chamber import tube_convection_slope_bound
from hydro_envs.laws.seal_friction import dissipative_fade_velocity
from hydro_envs.plants.rodless_cylinder.bounds import local_mode_rates
from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical

__all__ = ["PLANT", "RodlessCylinderParams", "N_PARAMS", "N_FIELDS", "ATM", "T_REF_ISO", "RHO_REF_ISO"]

PLANT = "rodless_cylinder"
ATM = 101325.0  # Pa, standard atmosphere: gauge -> absolute, and the exhaust
T_REF_ISO = 293.15  # K, ISO 8778 / ISO 6358 reference temperature (ANR)
RHO_REF_ISO = 1.185  # kg/m^3, ISO 8778 reference density (ANR)


@dataclasses.dataclass(frozen=True)
class RodlessCylinderParams(PhysicalParams):
    """Parameters of the seed-004 rodless cylinder (SI; pressures absolute).

    Defaults are 004 Tables 1-2 unless the field's ``source`` says otherwise; everything the
    paper does not give is taken from the named parts' data sheets or physics, marked assumed.
    """

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ('bore', 'stroke', 'dead_volume_a', 'dead_volume_b')

    supply_pressure: float = physical(
        0.6e6 + ATM, "Pa", (1.5e5, 1.2e6),
        "004 sec. 3.2: 0.6 MPa supply (gauge, Table 1 compressor 0.4-0.7 MPa) + 101.325 kPa",
    )
    exhaust_pressure: float = physical(
        ATM, "Pa", (5e4, 2e5), "assumed: valve exhausts to the standard atmosphere",
    )
    supply_temperature: float = physical(
        293.15, "K", (200.0, 400.0),
        "assumed: 20 C, ISO 8778 reference; also the wall and ambient temperature",
    )
    gas_constant: float = physical(287.0, "J/(kg K)", (200.0, 500.0), "004 eq (3): R of air")
    heat_capacity_ratio: float = physical(
        1.4, "1", (1.01, 1.67), "004 eq (11): isentropic index kappa of air", open_low=True
    )
    mass: float = physical(
        0.5, "kg", (0.005, 1e4),
        "assumed: piston, yoke and slide table of an SMC MY1C25 (data sheet order 0.5 kg); 004 gives no M_L",
    )
    bore: float = physical(
        0.025, "m", (0.005, 0.04),
        "004 Table 1: SMC MYC25G, bore 25 mm (allowed from 5 mm: the walls' heat exchange, A_wall/V "
        "up to 4/D, would need more sub-steps below)",
    )
    stroke: float = physical(0.110, "m", (0.0, 10.0), "004 Table 1: stroke 110 mm", open_low=True)
    dead_volume_a: float = physical(
        5e-6, "m^3", (0.0, 1e-2),
        "assumed: end-cover/cushion volume (~2.5 cm^3) + 0.5 m of 2.5 mm-bore tube to the M5 valve "
        "(line_length, line_bore: 2.45 cm^3)",
        open_low=True,
    )
    dead_volume_b: float = physical(
        5e-6, "m^3", (0.0, 1e-2), "assumed: as dead_volume_a (symmetric piping)", open_low=True
    )
    port_radius: float = physical(
        1.23e-3, "m", (0.0, 0.02),
        "assumed: r of eq (2) such that a half-open port gives the MPYE-5-M5 standard nominal "
        "flow 100 L/min (6 -> 5 bar) at C = 0.7",
        open_low=True,
    )
    valve_underlap: float = physical(
        0.1e-3, "m", (-5e-3, 5e-3),
        "assumed: u = r - d of eq (2); 0.1 mm gives 6 L/min (ANR) mid-position leakage at 6 bar, "
        "the MPYE-5 data sheet order; < 0 is an overlap",
    )
    spool_stroke: float = physical(
        1.13e-3, "m", (0.0, 0.02),
        "assumed: eq (2) is printed up to x_v = d = r - u: full stroke uncovers half a port",
        open_low=True,
    )
    command_centre: float = physical(5.0, "V", (0.0, 100.0), "004 Table 1 / MPYE-5 data sheet: 5 V centre")
    command_max: float = physical(10.0, "V", (0.0, 100.0), "004 Table 1: 0-10 V driving voltage", open_low=True)
    discharge_coefficient: float = physical(
        0.7, "1", (0.0, 1.0), "assumed: C of eq (3), sharp-edged port (0.6-0.85)", open_low=True
    )
    laminar_pressure_ratio: float = physical(
        0.999, "1", (0.9, 0.99999),
        "assumed: Simscape default; linear flow above this p_down/p_up (docs/references.md, smooth transition)",
    )
    flow_model: float = physical(
        0.0, "1", (0.0, 1.0), "switch: 0 = nozzle law 004 eqs (3)-(4), 1 = ISO 6358 (C, b)"
    )
    sonic_conductance: float = physical(
        3.93e-9, "m^3/(s Pa)", (0.0, 1e-5),
        "assumed: ISO 6358 C of the full opening for 100 L/min (6 -> 5 bar) at b = 0.3 (0.39 L/(s bar))",
        open_low=True,
    )
    critical_pressure_ratio: float = physical(
        0.3, "1", (0.0, 0.9), "assumed: ISO 6358 b of a spool valve (0.2-0.45)"
    )
    valve_natural_frequency: float = physical(
        2.0 * math.pi * 100.0, "rad/s", (10.0, 2e4),
        "assumed: MPYE-5 spool bandwidth order 100 Hz (004 eq (28) takes it as a pure gain)",
    )
    valve_damping: float = physical(0.7, "1", (0.05, 5.0), "assumed: position-controlled spool, well damped")
    static_friction: float = physical(35.48, "N", (0.0, 1e4), "004 Table 2: F_s")
    coulomb_friction: float = physical(15.31, "N", (0.0, 1e4), "004 Table 2: F_c")
    stribeck_velocity: float = physical(3.27e-3, "m/s", (1e-5, 1.0), "004 Table 2: ydot_s = 3.27 mm/s")
    viscous_friction: float = physical(
        310.0, "N s/m", (0.0, 1e5),
        "004 Table 2: sigma = 0.31 N s/mm (the conclusions' 'sigma = 3.27 mm/s' is an extraction defect); "
        "randomised +-30 %, which covers the rig's residual closed-loop damping (eq (32), zeta 0.327 with "
        "the friction compensated by the Table 2 model = a viscous excess of 50 N s/m, +16 %; the "
        "randomisation file says how it was measured)",
    )
    bristle_stiffness: float = physical(
        1e5, "N/m", (0.0, 3e7),
        "assumed: LuGre sigma0; pre-sliding F_s/sigma0 = 0.35 mm (004 Fig. 4 'displacement before "
        "sliding'; soft lip seals and sealing band); 0 selects the static curve",
    )
    bristle_damping: float = physical(
        450.0, "N s/m", (0.0, 2e5),
        "assumed: LuGre sigma1 = 2 sqrt(sigma0 M), critically damped bristles; fades with speed as "
        "exp(-(v/v_d)^2), v_d = v_s or less (hydro_envs.laws.seal_friction: keeps the law dissipative)",
    )
    friction_sign_velocity: float = physical(
        1e-3, "m/s", (1e-7, 0.1), "assumed: tanh sign of the static curve (used only if bristle_stiffness = 0)"
    )
    load_force: float = physical(0.0, "N", (-2000.0, 2000.0), "004 eq (18): F_L, no external load on the rig")
    stop_stiffness: float = physical(
        1e6, "N/m", (1e5, 1e10), "assumed: elastomer end bumpers, 0.35 mm deflection at full thrust"
    )
    stop_damping: float = physical(
        2.0, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, restitution ~0.3 at 0.5 m/s"
    )
    wall_heat_transfer_coefficient: float = physical(
        50.0, "W/(m^2 K)", (0.0, 1e4),
        "assumed (004 eq (11) takes the chambers adiabatic, 0; the default differs because an adiabatic "
        "chamber vented by bang-bang commands cools far below any temperature measured in pneumatic "
        "cylinders, 004's eq (11) being its linearisation's assumption, not a measurement): convective "
        "coefficient h of the chamber gas to the cylinder wall at T_s, Q = h A_wall (T_s - T), A_wall = "
        "2 A + 4 (V - V_line) / D (the line's own wall: line_bore); 0 also switches the line's exchange "
        "off (the seed's adiabatic chamber); forced convection of "
        "gases is 25-250 W/(m^2 K) (Incropera and DeWitt, Fundamentals of Heat and Mass Transfer, "
        "Table 1.1), and values of this order are identified for industrial pneumatic cylinders "
        "(Carneiro and de Almeida 2006, Proc. IMechE I 221); the chambers then lie between isothermal "
        "and adiabatic (time constant m c_v / (h A_wall) of 0.1-0.5 s here)",
    )
    pressure_floor: float = physical(
        1.0, "Pa", (0.0, 1e4), "assumed: guard only, Hopsan's 1 Pa pneumatic volume floor (docs/references.md)",
        open_low=True,
    )
    min_gas_mass: float = physical(
        1e-12, "kg", (0.0, 1e-6), "assumed: guard only, keeps T = pV/(mR) finite and positive", open_low=True
    )
    min_chamber_volume: float = physical(
        1e-8, "m^3", (0.0, 1.0), "assumed: guard only; dead volumes keep chambers >= 5 cm^3", open_low=True
    )
    supply_line_resistance: float = physical(
        0.0, "Pa s/kg", (0.0, 1e10),
        "004 eqs (3)-(4): the valve's P port at the constant supply pressure (0); > 0: the port "
        "pressure falls by R mdot with the mass flow mdot the valve draws (regulator droop, supply "
        "hose; model.supply_port_pressure)",
    )

    line_length: float = physical(
        0.5, "m", (0.0, 20.0),
        "assumed: tube from the MPYE-5-M5 valve (004 Table 1: M5 ports) to each cylinder port, part "
        "of the dead volumes (dead_volume_a/_b); its inner wall pi d L exchanges heat with the gas "
        "flowing through it (the chamber's lumped wall, model.chamber_wall_heat_flow)",
    )
    line_bore: float = physical(
        2.5e-3, "m", (1e-4, 0.05),
        "assumed: inner diameter of the 4 mm OD polyurethane tube that push-in fittings on M5 ports "
        "take (2.5-2.6 mm bore); 4/d = 1600 m^2/m^3 of wall per volume against the chamber's 4/D = 160",
    )

    def _check_relations(self) -> None:
        name = type(self).__name__
        v_line = 0.25 * math.pi * self.line_bore**2 * self.line_length
        if v_line > min(self.dead_volume_a, self.dead_volume_b):
            raise ParameterError(
                f"{name}: the line volume pi/4 line_bore^2 line_length = {v_line} m^3 (line_bore = "
                f"{self.line_bore} m, line_length = {self.line_length} m) must fit in the dead volumes "
                f"dead_volume_a, dead_volume_b = ({self.dead_volume_a}, {self.dead_volume_b}) m^3"
            )
        if self.static_friction < self.coulomb_friction:
            raise ParameterError(
                f"{name}.static_friction = {self.static_friction} must be >= coulomb_friction = "
                f"{self.coulomb_friction} (Stribeck: F_s >= F_c)"
            )
        if self.static_friction > 0.0 and not self.coulomb_friction > 0.0:
            raise ParameterError(
                f"{name}.coulomb_friction = {self.coulomb_friction} must be > 0 when static_friction = "
                f"{self.static_friction} > 0 (the friction level must stay positive at speed); set both to 0 "
                "for a carriage without dry friction"
            )
        if not (self.pressure_floor < self.exhaust_pressure < self.supply_pressure):
            raise ParameterError(
                f"{name}: need pressure_floor < exhaust_pressure < supply_pressure, got "
                f"{self.pressure_floor}, {self.exhaust_pressure}, {self.supply_pressure} Pa"
            )
        if self.flow_model not in (0.0, 1.0):
            raise ParameterError(f"{name}.flow_model = {self.flow_model} must be 0 (nozzle, eqs (3)-(4)) or 1 (ISO 6358)")
        if not self.command_centre < self.command_max:
            raise ParameterError(
                f"{name}.command_centre = {self.command_centre} V must be below command_max = {self.command_max} V"
            )
        if abs(self.valve_underlap) >= self.port_radius:
            raise ParameterError(
                f"{name}.valve_underlap = {self.valve_underlap} m must satisfy |u| < port_radius = {self.port_radius} m"
            )
        if self.min_chamber_volume >= min(self.dead_volume_a, self.dead_volume_b):
            raise ParameterError(
                f"{name}.min_chamber_volume must be below the dead volumes dead_volume_a and "
                f"dead_volume_b ({self.min_chamber_volume} >= {min(self.dead_volume_a, self.dead_volume_b)} m^3)"
            )

    # kernel array: the fields, then derived columns computed once per parameter set so the
    # right-hand side needs no pow calls (see hydro_envs.laws.nozzle_fast). The two laws run as
    # plain Python here (``jit.as_python``: the same libm calls, bit-identical results): compiling
    # them would add about 0.8 s to an env's cold first step.
    derived_names: ClassVar[tuple[str, ...]] = (
        "piston_area", "crit", "psi_c", "psi_lam", "inv_k", "coef", "sqrt_rts", "k_v", "s_full", "orifice_rate",
        "local_rate", "micro_damping_velocity", "wall_area_per_volume", "line_volume", "line_wall_area")

    def derived_columns(self) -> list[float]:
        constants = as_python(nozzle_flow_constants)(self.heat_capacity_ratio, self.laminar_pressure_ratio)
        s_full = float(as_python(circular_orifice_area)(self.spool_stroke + self.valve_underlap, self.port_radius))
        orifice = self._orifice_rate_volume(s_full, constants) * (1.0 + self._line_heat_coupling())
        extra = [
            0.25 * math.pi * self.bore**2,  # piston area A
            *constants,  # crit, psi_c, psi_lam, inv_k, coef
            math.sqrt(self.gas_constant * self.supply_temperature),  # sqrt(R T_s)
            self.spool_stroke / (self.command_max - self.command_centre),  # K_v of eq (28)
            s_full,
            orifice,
            max(local_mode_rates(self, orifice).values()),
            dissipative_fade_velocity(self.bristle_damping, self.stribeck_velocity, self.coulomb_friction),
            4.0 / self.bore,  # lateral wall per chamber volume, 4/D (laws.pneumatic_chamber.cylinder_chamber_wall_area)
            0.25 * math.pi * self.line_bore**2 * self.line_length,  # the line's share of each dead volume
            math.pi * self.line_bore * self.line_length,  # the line's inner wall pi d L
        ]
        return extra

    def _line_heat_coupling(self) -> float:
        """The line's heat exchange stiffens the orifice's laminar tail: its coefficient follows the
        flow, which there follows the chamber pressure steeply; relative to the tail's own rate
        ``kappa R T_max slope / V`` it adds ``(kappa - 1) pi d L |T_s - T| max(dh/dmdot) slope / V``,
        with ``|T_s - T| <= T_s / 2`` (the orifice mode's T_max = 1.5 T_s) [-]."""
        if self.wall_heat_transfer_coefficient <= 0.0 or self.line_length <= 0.0:
            return 0.0
        slope = as_python(tube_convection_slope_bound)(self.line_bore)
        t_max = 1.5 * self.supply_temperature
        return ((self.heat_capacity_ratio - 1.0) * math.pi * self.line_bore * self.line_length
                * 0.5 * self.supply_temperature * slope / (self.heat_capacity_ratio * self.gas_constant * t_max))

    def _orifice_rate_volume(self, s_full: float, constants: tuple) -> float:
        """``kappa R T_max`` [J/kg] times the laminar-tail slope [kg/(s Pa)] of the fully open
        edge at supply pressure, T_max = 1.5 T_s: over a chamber volume, the largest rate [1/s]
        of a chamber pressure through the valve's flow law (the ``orifice`` mode)."""
        ps = self.supply_pressure
        rl = self.laminar_pressure_ratio
        t_max = 1.5 * self.supply_temperature
        if self.flow_model < 0.5:
            flow = as_python(nozzle_mass_flow_fast)(self.discharge_coefficient * s_full, ps, rl * ps,
                                                 math.sqrt(self.gas_constant * t_max), rl, *constants)
        else:
            flow = as_python(iso6358_mass_flow_laminar)(self.sonic_conductance, self.critical_pressure_ratio, ps,
                                                     rl * ps, t_max, T_REF_ISO, RHO_REF_ISO, rl)
        return self.heat_capacity_ratio * self.gas_constant * t_max * flow / (ps * (1.0 - rl))


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(RodlessCylinderParams)
N_FIELDS = len(RodlessCylinderParams.names())
N_PARAMS = len(_COL)
I_PS = _COL["supply_pressure"]
I_PE = _COL["exhaust_pressure"]
I_TS = _COL["supply_temperature"]
I_R = _COL["gas_constant"]
I_K = _COL["heat_capacity_ratio"]
I_M = _COL["mass"]
I_D = _COL["bore"]
I_L = _COL["stroke"]
I_VDA = _COL["dead_volume_a"]
I_VDB = _COL["dead_volume_b"]
I_RP = _COL["port_radius"]
I_ULAP = _COL["valve_underlap"]
I_XVM = _COL["spool_stroke"]
I_UC = _COL["command_centre"]
I_UMAX = _COL["command_max"]
I_CD = _COL["discharge_coefficient"]
I_RLAM = _COL["laminar_pressure_ratio"]
I_FLOW = _COL["flow_model"]
I_CISO = _COL["sonic_conductance"]
I_BISO = _COL["critical_pressure_ratio"]
I_WV = _COL["valve_natural_frequency"]
I_ZV = _COL["valve_damping"]
I_FS = _COL["static_friction"]
I_FC = _COL["coulomb_friction"]
I_VS = _COL["stribeck_velocity"]
I_SIG2 = _COL["viscous_friction"]
I_SIG0 = _COL["bristle_stiffness"]
I_SIG1 = _COL["bristle_damping"]
I_VEPS = _COL["friction_sign_velocity"]
I_FL = _COL["load_force"]
I_KSTOP = _COL["stop_stiffness"]
I_ASTOP = _COL["stop_damping"]
I_HW = _COL["wall_heat_transfer_coefficient"]
I_PFLOOR = _COL["pressure_floor"]
I_MFLOOR = _COL["min_gas_mass"]
I_VMIN = _COL["min_chamber_volume"]
I_RSUP = _COL["supply_line_resistance"]
D_AREA = _COL["piston_area"]
D_CRIT = _COL["crit"]
D_PSIC = _COL["psi_c"]
D_PSIL = _COL["psi_lam"]
D_INVK = _COL["inv_k"]
D_COEF = _COL["coef"]
D_SQRTRTS = _COL["sqrt_rts"]
D_KV = _COL["k_v"]
D_SFULL = _COL["s_full"]
D_ORIFICE = _COL["orifice_rate"]
D_LOCAL = _COL["local_rate"]
D_FADE = _COL["micro_damping_velocity"]
D_WALL = _COL["wall_area_per_volume"]
D_VLINE = _COL["line_volume"]
D_ALINE = _COL["line_wall_area"]
I_DLINE = _COL["line_bore"]
I_LLINE = _COL["line_length"]
