r"""Load-sensing circuit: variable pump with the seed-000 flow compensator, one actuator.

Source: ``000_d7d5fd9bd6b165a2.txt`` sec. 2 and Fig. 1 (scheme of a load-sensing control):
an axial piston pump whose displacement is set by two control pistons -- piston 2 (small,
always at the delivery pressure p_S) holds maximum displacement, piston 1 (large) is fed by
the flow compensator FC and destrokes the pump; the FC spool compares p_S with the load
pressure p_LS plus its spring, "typically around 20 bar"; the main control valve CV is a
variable restrictor, so the actuator flow depends only on the CV area. The FC spool is the
one of :mod:`hydro_envs.plants.ls_compensator` with its original spring (method 2: 294 Hz,
c = 3.5 N s/m at 40 C scaling with the oil viscosity, 000 Fig. 14); the LS pilot line is the
RLC pipe of 000 eqs (1)-(3), (5)-(6) between the load port and the spring chamber.
000 sec. 2: an LS system "features poor behavior in damping high inertial loads ... a
possible risk is the instability that is also influenced by the viscous friction force of
the FC" -- the control problem of ``hydro_envs/LoadSensing-v0``.

State (SI, absolute pressures)::

    index  name   unit    meaning
    0      x      m       FC spool travel from its seat towards the spring (P -> X opens at x_lap)
    1      v      m/s     FC spool velocity
    2      p_s    Pa      pump delivery pressure
    3      p_x    Pa      pressure behind control piston 1 (the large one)
    4      y      m       control-piston travel towards zero displacement (0 = full displacement)
    5      vy     m/s     control-piston velocity
    6      p_l    Pa      actuator (load) chamber pressure
    7      xa     m       actuator position
    8      va     m/s     actuator velocity
    9      q_ls   m^3/s   LS pilot-line flow, load port -> FC spring chamber
    10     p_ls   Pa      FC spring-chamber pressure (end of the LS line)
    11     f_sol  N       electro-proportional force on the FC spool (adds to the spring)

Inputs: ``u[0]`` solenoid force command [N] (first-order lag ``tau_sol``), ``u[1]`` CV
flow area [m^2] (clipped to ``[0, cv_area_max]``).

Equations::

    m x'' = A (p_s - p_ls) - F0 - k x - f_sol - c(T) x' + F_flow + F_stop            000 eq (4)
    q_PX = K w clip(x - x_lap, 0, l_p) rsqrt(p_s - p_x); q_XT = K w clip(x_lap - x, 0, l_p) rsqrt(p_x - p_T)
    V_x(y)/beta p_x' = q_PX - q_XT - A1 y' - G_x (p_x - p_T)
    m_y y'' = A1 p_x - A2 p_s - F_b0 - k_b y - b_y y' + F_stop(y)        (control pistons)
    V_s/beta p_s' = eps(y) D w_p - G_p (p_s - p_T) + A2 y' - q_PX - A x' - q_CV - q_RV
    q_CV = C_d a_CV sqrt(2/rho) max(rsqrt(p_s - p_l), 0)                  (meter-in CV + load check)
    V_l(xa)/beta p_l' = q_CV - A_c va - q_ls
    M va' = A_c (p_l - p_T) - F_L - b_a va - F_c tanh(va/v_eps) + F_stop(xa)
    L q_ls' + (R(T) + R_d) q_ls = p_l - p_ls                                000 eq (5) + damping restrictor
    (V_line + V_sc - A x)/beta p_ls' = q_ls + A x'                          000 eq (6)
    tau f_sol' = u0 - f_sol

with ``eps(y) = clip(1 - y/y_max, 0, 1)``; the steady margin is
``p_s - p_ls = (F0 + k x_lap + f_sol)/A`` (20 bar at f_sol = 0). Every number not in 000 is
an assumption stated in the field's ``source`` (pump and valve sizes of a 28 cm^3/rev
LS pump, a 63 mm cylinder, hoses).
"""

from __future__ import annotations

import dataclasses
import math

import numba as nb
import numpy as np

from hydro_envs.data.channels import Channel, register_plant_channels
from hydro_envs.laws.contact import end_stop_force
from hydro_envs.laws.friction import tanh_sign
from hydro_envs.laws.orifice import regularized_signed_sqrt
from hydro_envs.laws.pipe import pipe_inductance, pipe_laminar_resistance
from hydro_envs.laws.viscosity import iso_vg_kinematic_viscosity
from hydro_envs.params import ParameterError, PhysicalParams, physical
from hydro_envs.plants import ls_compensator as lc

__all__ = [
    "LSCircuitParams",
    "STATE_NAMES",
    "N_STATES",
    "ls_circuit_rhs",
    "ls_circuit_guard",
    "stiffness_modes",
    "derived",
    "margin",
    "standby_state",
    "cv_area_for_velocity",
]

PLANT = "ls_circuit"
STATE_NAMES = ("x", "v", "p_s", "p_x", "y", "vy", "p_l", "xa", "va", "q_ls", "p_ls", "f_sol")
STATE_UNITS = ("m", "m/s", "Pa", "Pa", "m", "m/s", "Pa", "m", "m/s", "m^3/s", "Pa", "N")
N_STATES = 12
X, V, PS, PX, Y, VY, PL, XA, VA, QLS, PLS, FSOL = range(N_STATES)

_ATM = 1.0e5
_BAR = 1.0e5
_SPOOL_MASS = lc.LSCompensatorParams().spool_mass
_SPOOL_D = lc.LSCompensatorParams().spool_diameter
_A_SPOOL = 0.25 * math.pi * _SPOOL_D**2
_MARGIN = 20.0 * _BAR
_X_LAP = 0.5e-3
_PRELOAD = _MARGIN * _A_SPOOL - lc.ORIGINAL_SPRING_STIFFNESS * _X_LAP  # 42.1 N


@dataclasses.dataclass(frozen=True)
class LSCircuitParams(PhysicalParams):
    """Parameters of the load-sensing circuit of 000 Fig. 1 (SI, absolute pressures)."""

    plant = PLANT

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
        _SPOOL_MASS + lc.LSCompensatorParams().spring_mass / 3.0, "kg", (0.0, 10.0),
        "000 Table 1: m = 20.47 g incl. 1/3 of the spring (ls_compensator)", open_low=True,
    )
    spring_stiffness: float = physical(
        lc.ORIGINAL_SPRING_STIFFNESS, "N/m", (0.0, 1e8), "000 eq (19): original spring, 294 Hz",
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
        1.0e6, "N/m", (1e4, 1e11),
        "assumed: seat + spring-seat compliance, 0.1 mm at 100 N (softer than ls_compensator's "
        "2e6: the seat is touched only in transients, and it sets the RK4 step)",
    )
    spool_stop_damping: float = physical(
        0.05, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, restitution ~0.99 at 0.1 m/s"
    )
    metering_width: float = physical(
        1.0e-3, "m", (0.0, 0.1),
        "assumed: one 1 mm port (pump-control FC metering; half the method-2 test configuration)",
        open_low=True,
    )
    metering_lap: float = physical(
        _X_LAP, "m", (0.0, 0.01), "assumed: P -> X opens 0.5 mm from the seat (X -> T open below)"
    )
    port_length: float = physical(1.0e-3, "m", (1e-6, 0.05), "assumed: 1 mm ports")
    discharge_coefficient: float = physical(
        0.7, "1", (0.0, 1.0), "000 sec. 1: discharge coefficients 0.6-0.9", open_low=True
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
        3.0e11, "Pa s/m^3", (0.0, 1e15),
        "assumed: damping restrictor at the pump end of the LS line (standard in LS controllers); "
        "with the line + chamber capacitance a 6.5 ms low-pass on p_LS. Without it (R of the hose "
        "alone) the hydro-mechanical loop limit-cycles with 4 t / 40 kN loads; 1e11 still does",
    )
    spring_chamber_volume: float = physical(
        1.0e-6, "m^3", (1e-8, 1e-3), "assumed: 1 cm^3 FC spring chamber at the spool's seat", open_low=True,
    )
    # ---- pump and its control pistons
    pump_displacement: float = physical(
        28.0e-6 / (2.0 * math.pi), "m^3/rad", (0.0, 1e-2),
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
        2.0e-5, "m^3", (1e-8, 1e-2),
        "assumed: 20 cm^3 behind piston 1 at full displacement (chamber + drilled control line)",
        open_low=True,
    )
    control_leakage: float = physical(
        2.0e-13, "m^3/(s Pa)", (0.0, 1e-8), "assumed: piston-1 clearance leak, 0.12 L/min at 100 bar"
    )
    control_stop_stiffness: float = physical(
        1.0e7, "N/m", (1e4, 1e11), "assumed: swash-plate stop, 0.1 mm at 1 kN (reflected compliance)"
    )
    delivery_volume: float = physical(3.0e-4, "m^3", (1e-6, 1.0), "assumed: pump outlet + 1 m hose, 0.3 L")
    relief_pressure: float = physical(250.0e5 + _ATM, "Pa", (1e6, 1e8), "assumed: 250 bar relief")
    relief_gradient: float = physical(1.0e-10, "m^3/(s Pa)", (0.0, 1e-6), "assumed: 42 L/min at 7 bar override")
    # ---- main control valve and actuator
    cv_area_max: float = physical(
        1.5e-5, "m^2", (1e-8, 1e-2),
        "assumed: CV passes ~42 L/min (the pump's full flow) at the 20 bar margin",
    )
    piston_area: float = physical(0.25 * math.pi * 0.063**2, "m^2", (1e-5, 1.0), "assumed: 63 mm single-acting cylinder")
    stroke: float = physical(0.6, "m", (0.01, 10.0), "assumed: 600 mm stroke")
    line_volume: float = physical(5.0e-4, "m^3", (1e-6, 1.0), "assumed: 0.5 L hose CV -> cylinder + dead volume")
    load_mass: float = physical(1000.0, "kg", (1.0, 1e5), "assumed: 1 t inertial load (randomised)")
    load_force: float = physical(2.0e4, "N", (0.0, 1e6), "assumed: 20 kN load, 64 bar (randomised)")
    actuator_viscous: float = physical(3000.0, "N s/m", (0.0, 1e6), "assumed: seal + guide viscous friction")
    actuator_coulomb: float = physical(300.0, "N", (0.0, 1e5), "assumed: seal Coulomb friction")
    friction_sign_velocity: float = physical(1e-3, "m/s", (1e-6, 0.1), "assumed: tanh sign, NOTES.md 1 mm/s")
    actuator_stop_stiffness: float = physical(1.0e8, "N/m", (1e4, 1e11), "assumed: steel stop")
    tank_pressure: float = physical(_ATM, "Pa", (0.0, 1e6), "assumed: tank at atmosphere")
    orifice_transition_pressure: float = physical(
        1.0e5, "Pa", (1.0, 1e6), "assumed: repo default 1 bar; every working drop here is >= 20 bar"
    )
    pressure_floor: float = physical(1e3, "Pa", (0.0, 1e5), "assumed: cavitation floor")

    def _check_relations(self) -> None:
        if not (self.pressure_floor < self.tank_pressure < self.relief_pressure):
            raise ParameterError(
                "LSCircuitParams: need pressure_floor < tank_pressure < relief_pressure, got "
                f"{self.pressure_floor}, {self.tank_pressure}, {self.relief_pressure} Pa"
            )
        if self.control_area_small >= self.control_area_large:
            raise ParameterError(
                "LSCircuitParams.control_area_small must be below control_area_large (000 sec. 2: "
                f"piston 2 is the smaller), got {self.control_area_small} >= {self.control_area_large}"
            )
        a = 0.25 * math.pi * self.spool_diameter**2
        if self.spring_chamber_volume <= a * (self.spool_stroke + 1e-4):
            raise ParameterError(
                "LSCircuitParams.spring_chamber_volume must exceed the spool's swept volume "
                f"A * stroke + 0.1 mm of travel (A from spool_diameter, stroke = spool_stroke) = "
                f"{a * (self.spool_stroke + 1e-4)} m^3, got {self.spring_chamber_volume} m^3"
            )

    def to_array(self) -> np.ndarray:
        d = derived(self)
        return np.concatenate([super().to_array(), np.array([d[k] for k in _DERIVED], dtype=np.float64)])

    @classmethod
    def from_array(cls, values: np.ndarray) -> "LSCircuitParams":
        values = np.asarray(values, dtype=np.float64)
        n = len(cls.names())
        if values.shape not in ((n,), (n + len(_DERIVED),)):
            raise ParameterError(f"{cls.__name__}: expected {n} (or {n + len(_DERIVED)}) values, got {values.shape}")
        return cls(**{k: float(v) for k, v in zip(cls.names(), values[:n])})


_FIELDS = LSCircuitParams.names()
N_FIELDS = len(_FIELDS)
(
    I_VG, I_T, I_RHO, I_BETA, I_DS, I_MS, I_K, I_F0, I_C40, I_XMAX, I_KSS, I_ASS, I_W, I_XLAP,
    I_LPORT, I_CD, I_THETA, I_FSMAX, I_TSOL, I_LLS, I_DLS, I_RD, I_VSC, I_DP, I_WP, I_GP, I_A1, I_A2,
    I_YMAX, I_MY, I_BY, I_FB0, I_KB, I_VX0, I_GX, I_KYS, I_VS, I_PRV, I_GRV, I_ACVMAX, I_AC,
    I_STROKE, I_VL0, I_M, I_FL, I_BA, I_FCA, I_VEPS, I_KAS, I_PT, I_DPTR, I_PFLOOR,
) = range(52)
assert N_FIELDS == 52 and _FIELDS[I_PFLOOR] == "pressure_floor" and _FIELDS[I_FL] == "load_force"
_DERIVED = ("spool_area", "viscous", "ls_inductance", "ls_resistance", "ls_line_volume", "k_meter", "k_flow_force")
(D_A, D_C, D_LLS, D_RLS, D_VLINE, D_KM, D_KFF) = range(N_FIELDS, N_FIELDS + len(_DERIVED))
N_PARAMS = N_FIELDS + len(_DERIVED)


def derived(params: LSCircuitParams) -> dict[str, float]:
    """Kernel quantities computed once per parameter set (viscosity-dependent c and R)."""
    p = params
    nu = iso_vg_kinematic_viscosity(p.oil_grade, p.oil_temperature)
    nu40 = iso_vg_kinematic_viscosity(p.oil_grade, 40.0)
    return {
        "spool_area": 0.25 * math.pi * p.spool_diameter**2,
        "viscous": p.viscous_friction_40c * nu / nu40,
        "ls_inductance": pipe_inductance(p.oil_density, p.ls_line_length, p.ls_line_diameter),
        "ls_resistance": pipe_laminar_resistance(nu * p.oil_density, p.ls_line_length, p.ls_line_diameter),
        "ls_line_volume": 0.25 * math.pi * p.ls_line_diameter**2 * p.ls_line_length,
        "k_meter": p.discharge_coefficient * math.sqrt(2.0 / p.oil_density),
        "k_flow_force": 2.0 * p.discharge_coefficient * math.cos(p.jet_angle) * p.metering_width,
    }


@nb.njit(cache=True, error_model="numpy")
def ls_circuit_rhs(y, u, p, dy):
    """Time derivative of the LS circuit state (module docstring equations)."""
    x = y[X]
    v = y[V]
    ps = y[PS]
    px = y[PX]
    yc = y[Y]
    vy = y[VY]
    pl = y[PL]
    xa = y[XA]
    va = y[VA]
    qls = y[QLS]
    pls = y[PLS]
    fsol = y[FSOL]
    beta = p[I_BETA]
    pt = p[I_PT]
    dptr = p[I_DPTR]
    floor = p[I_PFLOOR]
    area = p[D_A]
    km = p[D_KM]

    # ---- flow compensator metering (P -> X, X -> T) and flow force
    lport = p[I_LPORT]
    o_px = min(max(x - p[I_XLAP], 0.0), lport)
    o_xt = min(max(p[I_XLAP] - x, 0.0), lport)
    q_px = km * p[I_W] * o_px * regularized_signed_sqrt(ps - px, dptr)
    q_xt = km * p[I_W] * o_xt * regularized_signed_sqrt(px - pt, dptr)
    f_flow = p[D_KFF] * (-o_px * (ps - px) + o_xt * (px - pt))
    f_stop = end_stop_force(x, v, 0.0, p[I_XMAX], p[I_KSS], p[I_ASS])
    dy[X] = v
    dy[V] = (area * (ps - pls) - p[I_F0] - p[I_K] * x - fsol - p[D_C] * v + f_flow + f_stop) / p[I_MS]  # 000 (4)

    # ---- control pistons and swash plate
    vx = p[I_VX0] + p[I_A1] * yc
    dpx = beta / vx * (q_px - q_xt - p[I_A1] * vy - p[I_GX] * (px - pt))
    if px <= floor and dpx < 0.0:
        dpx = 0.0
    dy[PX] = dpx
    f_ystop = end_stop_force(yc, vy, 0.0, p[I_YMAX], p[I_KYS], 0.0)
    dy[Y] = vy
    dy[VY] = (p[I_A1] * px - p[I_A2] * ps - p[I_FB0] - p[I_KB] * yc - p[I_BY] * vy + f_ystop) / p[I_MY]

    # ---- pump delivery node
    eps = 1.0 - yc / p[I_YMAX]
    eps = min(max(eps, 0.0), 1.0)
    q_pump = eps * p[I_DP] * p[I_WP]
    a_cv = min(max(u[1], 0.0), p[I_ACVMAX])
    q_cv = km * a_cv * regularized_signed_sqrt(ps - pl, dptr)
    if q_cv < 0.0:
        q_cv = 0.0  # load-holding check valve
    q_rv = p[I_GRV] * max(ps - p[I_PRV], 0.0)
    dps = beta / p[I_VS] * (q_pump - p[I_GP] * (ps - pt) + p[I_A2] * vy - q_px - area * v - q_cv - q_rv)
    if ps <= floor and dps < 0.0:
        dps = 0.0
    dy[PS] = dps

    # ---- actuator and load
    vl = p[I_VL0] + p[I_AC] * xa
    dpl = beta / vl * (q_cv - p[I_AC] * va - qls)
    if pl <= floor and dpl < 0.0:
        dpl = 0.0
    dy[PL] = dpl
    f_fric = p[I_BA] * va + p[I_FCA] * tanh_sign(va, p[I_VEPS])
    f_astop = end_stop_force(xa, va, 0.0, p[I_STROKE], p[I_KAS], 0.0)
    dy[XA] = va
    dy[VA] = (p[I_AC] * (pl - pt) - p[I_FL] - f_fric + f_astop) / p[I_M]

    # ---- LS pilot line, 000 eqs (5)-(6)
    dy[QLS] = (pl - pls - (p[D_RLS] + p[I_RD]) * qls) / p[D_LLS]
    vls = p[D_VLINE] + p[I_VSC] - area * x
    dpls = beta / vls * (qls + area * v)
    if pls <= floor and dpls < 0.0:
        dpls = 0.0
    dy[PLS] = dpls

    # ---- solenoid
    dy[FSOL] = (u[0] - fsol) / p[I_TSOL]


@nb.njit(cache=True, error_model="numpy")
def ls_circuit_guard(y, p):
    """Clamp the four pressures at the cavitation floor; return the number of clamps."""
    n = 0
    floor = p[I_PFLOOR]
    for i in (PS, PX, PL, PLS):
        if y[i] < floor:
            y[i] = floor
            n += 1
    return n


# ---------------------------------------------------------------------------- analysis
def margin(params: LSCircuitParams, f_sol: float = 0.0) -> float:
    """Steady LS margin ``p_s - p_ls = (F0 + k x_lap + f_sol)/A`` [Pa] (000 sec. 2: ~20 bar),
    neglecting the flow force of the tiny steady opening."""
    return (params.spring_preload + params.spring_stiffness * params.metering_lap + f_sol) / derived(params)["spool_area"]


def cv_area_for_velocity(params: LSCircuitParams, velocity: float, dp: float | None = None) -> float:
    """CV area that passes ``A_c * velocity`` at the drop ``dp`` (default: the nominal margin),
    the operator's lever of a load-sensing valve (orifice law)."""
    dp = margin(params) if dp is None else dp
    q = params.piston_area * max(velocity, 0.0)
    return min(q / (params.discharge_coefficient * math.sqrt(2.0 * dp / params.oil_density)), params.cv_area_max)


def standby_state(params: LSCircuitParams, xa: float) -> np.ndarray:
    """Approximate rest state with the CV closed: load held at ``F_L / A_c``, the LS line at the
    load pressure, delivery at load + margin, the pump destroked to its leakage flow."""
    p = params
    y = np.zeros(N_STATES)
    pl = p.tank_pressure + p.load_force / p.piston_area
    dpm = margin(p)
    ps = pl + dpm
    eps = min(max(p.pump_leakage * (ps - p.tank_pressure) / (p.pump_displacement * p.pump_speed), 0.0), 1.0)
    yc = (1.0 - eps) * p.control_stroke
    px = (p.control_area_small * ps + p.bias_spring_preload + p.bias_spring_stiffness * yc) / p.control_area_large
    # the FC stays open by the amount that feeds piston 1's leak (a fraction of a bar of margin)
    d = derived(p)
    for _ in range(3):
        q_leak = p.control_leakage * (px - p.tank_pressure)
        opening = q_leak / (d["k_meter"] * p.metering_width * math.sqrt(max(ps - px, 1e3)))
        ps = pl + (p.spring_preload + p.spring_stiffness * (p.metering_lap + opening)) / d["spool_area"]
        px = (p.control_area_small * ps + p.bias_spring_preload + p.bias_spring_stiffness * yc) / p.control_area_large
    y[X] = p.metering_lap + opening
    y[PS] = ps
    y[PX] = px
    y[Y] = yc
    y[PL] = pl
    y[XA] = xa
    y[PLS] = pl
    return y


def stiffness_modes(params: LSCircuitParams) -> dict[str, float]:
    """Upper estimates of the Jacobian eigenvalue magnitudes [1/s] (worst case over states).

    * ``spool``: FC spool on spring + flow-force stiffness at the relief pressure, plus c/m;
      ``spool_stop``: seat contact sqrt(k/m) + alpha F_max/m with F_max = A p_relief + k x_max.
    * ``control_chamber``: laminar slopes of the fully open FC port and the leak into V_x0;
      ``control_piston``: oil spring beta A1^2/V_x0 on m_y, plus b_y/m_y and the stop spring.
    * ``delivery``: laminar slopes of the open CV and FC port, leak and relief into V_s.
    * ``load``: laminar CV slope into V_l0, oil spring of the load, friction slope on M.
    * ``ls_line``: RLC line with the spool's displacement (eq (17)-type bound) + R/L.
    * ``solenoid``: 1/tau.
    """
    p = params
    d = derived(p)
    A, m = d["spool_area"], p.spool_mass
    beta = p.bulk_modulus
    g_lam = 1.0 / math.sqrt(p.orifice_transition_pressure)
    dp_max = p.relief_pressure
    k_spool = p.spring_stiffness + d["k_flow_force"] * dp_max
    f_max = A * dp_max + p.spring_stiffness * p.spool_stroke
    g_port = d["k_meter"] * p.metering_width * p.port_length * g_lam
    g_cv = d["k_meter"] * p.cv_area_max * g_lam
    c_ls_min = (d["ls_line_volume"] + p.spring_chamber_volume - A * p.spool_stroke) / beta
    omega_ls2 = 1.0 / (d["ls_inductance"] * c_ls_min) + A * A / (m * c_ls_min) + k_spool / m
    return {
        "spool": math.sqrt(k_spool / m) + d["viscous"] / m,
        "spool_stop": math.sqrt(p.spool_stop_stiffness / m) + p.spool_stop_damping * f_max / m,
        "control_chamber": beta / p.control_volume * (g_port + p.control_leakage),
        "control_piston": math.sqrt(beta * p.control_area_large**2 / (p.control_volume * p.control_mass)
                                    + p.control_stop_stiffness / p.control_mass)
        + p.control_damping / p.control_mass,
        "delivery": beta / p.delivery_volume * (g_cv + g_port + p.pump_leakage + p.relief_gradient)
        + math.sqrt(beta * p.control_area_small**2 / (p.delivery_volume * p.control_mass)),
        "load": beta / p.line_volume * g_cv
        + math.sqrt(beta * p.piston_area**2 / (p.line_volume * p.load_mass) + p.actuator_stop_stiffness / p.load_mass)
        + (p.actuator_coulomb / p.friction_sign_velocity + p.actuator_viscous) / p.load_mass,
        "ls_line": math.sqrt(omega_ls2) + (d["ls_resistance"] + p.ls_damping_resistance) / d["ls_inductance"],
        "solenoid": 1.0 / p.solenoid_time_constant,
    }


register_plant_channels(
    PLANT,
    (
        Channel("f_sol", "N", "electro-proportional force command on the FC spool (adds to the spring)"),
        Channel("a_cv", "m^2", "main control valve (CV) flow area"),
        Channel("p_s", "Pa", "absolute pump delivery pressure"),
        Channel("p_l", "Pa", "absolute actuator (load) pressure"),
        Channel("p_ls", "Pa", "absolute LS pressure at the FC spring chamber"),
        Channel("xa", "m", "actuator position"),
        Channel("va", "m/s", "actuator velocity"),
    ),
)
