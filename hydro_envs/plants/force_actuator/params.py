"""Parameters of the seed-001 force actuator: value, unit, allowed range and source per field.

Defaults: ``001_3253c61f41166c3e.txt`` (sec. 2-4, Table 1) and the assumptions each field's
source names; pressures gauge. The index constants ``I_*`` are the columns of the packed
kernel parameter array; ``D_*`` the derived columns :meth:`ForceActuatorParams.to_array`
appends (parameter-only terms of the right-hand side, computed once per parameter set by the
same arithmetic the kernels used).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar


from hydro_envs.jit import as_python
from hydro_envs.laws.elementary import tanh_one_exp
from hydro_envs.laws.hysteresis import pi_threshold_scale
from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical

__all__ = ["PLANT", "ForceActuatorParams", "N_PARAMS", "N_FIELDS", "N_PLAY", "null_valve_offset"]

PLANT = "force_actuator"
#: plays of the valve's Prandtl-Ishlinskii hysteresis (001 sec. 3.3)
N_PLAY = 6


# ----------------------------------------------------------------------------- geometry
_PS = 345.0e4  # 001 sec. 2-3: 345 N/cm^2 (500 psi) supply, gauge
_FMAX = 1340.0  # 001 sec. 2: maximum thrust at 345 N/cm^2
_A1 = _FMAX / _PS  # bore area: 3.884 cm^2 (a 7/8 in bore gives 3.879 cm^2)
_ROD = 0.375 * 0.0254  # assumed 3/8 in rod


def null_valve_offset(bore_area: float, rod_area: float) -> float:
    """Valve position ``xi0`` with zero blocked force: ``A1 (1 + xi0)^2 = A2 (1 - xi0)^2``."""
    a2 = bore_area - rod_area
    s1, s2 = math.sqrt(bore_area), math.sqrt(a2)
    return (s2 - s1) / (s1 + s2)


_ROD_AREA = math.pi * _ROD**2 / 4.0
_XI0 = null_valve_offset(_A1, _ROD_AREA)


@dataclasses.dataclass(frozen=True)
class ForceActuatorParams(PhysicalParams):
    """Parameters of the seed-001 force actuator (SI; pressures gauge).

    Valve positions are normalised: ``xi = 1`` is full jet deflection (force saturation), and
    valve currents enter as fractions of ``rated_current`` (the current for ``xi = 1``).
    """

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ('bore_area', 'rod_area', 'stroke')

    supply_pressure: float = physical(
        _PS, "Pa", (1e5, 35e6), "001 sec. 2-3: 345 N/cm^2 (500 psi), gauge; return at atmosphere"
    )
    bore_area: float = physical(
        _A1, "m^2", (1e-6, 0.01), "001 sec. 2: max thrust 1340 N at 345 N/cm^2 -> A1 = 3.884 cm^2 (7/8 in bore)",
        open_low=True,
    )
    rod_area: float = physical(
        _ROD_AREA, "m^2", (0.0, 0.1),
        "assumed: 3/8 in rod (0.713 cm^2); 001 gives only the positive bias of fig. 3 and the "
        "asymmetric stiction (Table 2) of a single-rod piston",
    )
    stroke: float = physical(0.076, "m", (1e-3, 1.0), "001 sec. 2: 76 mm stroke", open_low=True)
    rated_current: float = physical(
        0.0375, "A", (1e-4, 1.0),
        "assumed: 37.5 mA for full jet deflection (jet-pipe torque motors 8-50 mA); with the "
        "hysteresis reversal slope it gives 58.4 N/mA small-signal gain at null vs the 52.6 of "
        "eq (6) read in mA -> N",
        open_low=True,
    )
    current_max: float = physical(
        0.045, "A", (1e-4, 1.0),
        "assumed: driver range +-45 mA = 120 % of rated, so saturation is reachable past the "
        "valve offset and the hysteresis (001 sec. 4.2: 0.488 mA driver increments)",
        open_low=True,
    )
    valve_offset: float = physical(
        _XI0, "1", (-0.5, 0.5),
        "001 sec. 3.1: negative offset added to x_v that nulls the force bias at zero current "
        "(default: exact null of the orifice law for the nominal areas)",
    )
    hysteresis_width: float = physical(
        0.05, "1", (0.0, 0.5),
        "assumed: full major-loop width as a fraction of rated current (001 fig. 5 missing; "
        "'significant', above the <= 3 % of catalogue servo-valves)",
    )
    hysteresis_reversal_slope: float = physical(
        0.9, "1", (0.0, 0.95),
        "branch slope right after a current reversal, relative to the major-loop slope. Fig. 5 "
        "(the measured loop) is missing; 001 sec. 4.7 measures the highest closed-loop bandwidth "
        "at the lowest amplitude (-6 dB up to 196 Hz) and sec. 5 finds its own model's 50 N "
        "response overdamped, 'the hysteresis model can't easily reproduce the small minor "
        "loops': small minor loops keep most of the major-loop gain. 0.9 is the largest slope "
        "whose 5 % major loop closes within +-0.86 rated current (the plays' thresholds grow as "
        "1/(1 - slope)); a slope of 0.6 would lower the loop gain 40 % at small amplitudes and "
        "make the bandwidth rise with amplitude",
    )
    sensor_mass: float = physical(
        0.560, "kg", (1e-3, 100.0), "001 Table 1 / eq (2): m = actuator mass minus piston mass", open_low=True
    )
    sensor_stiffness: float = physical(
        3.7592e6, "N/m", (1e4, 1e9), "001 Table 1: k_s = 37 592 N/cm (impulse test, used in the model)"
    )
    sensor_damping: float = physical(
        425.0, "N s/m", (0.0, 1e5), "001 Table 1: b_s = 4.25 N/cm/s"
    )
    piston_mass: float = physical(
        0.052, "kg", (3e-4, 100.0), "001 Table 1: m_a - m = 0.612 - 0.560 kg"
    )
    load_mass: float = physical(
        0.0, "kg", (0.0, 1e3), "assumed: no payload on the rod (free piston only)"
    )
    load_stiffness: float = physical(
        0.0, "N/m", (0.0, 1e9), "assumed: no environment spring on the rod (free piston only)"
    )
    piston_locked: float = physical(
        1.0, "1", (0.0, 1.0),
        "001 sec. 4.1-4.7: piston locked to the mount (blocked force); 0 = free piston",
    )
    coulomb_friction: float = physical(26.0, "N", (0.0, 5000.0), "001 eq (1) and Table 2: F_c = 26 N")
    stiction_retract: float = physical(
        107.0, "N", (0.0, 4000.0),
        "001 Table 2: stiction pushing on the piston 99 N (v_p < 0), measured as the force at the "
        "breaking point; the Dahl seals (n = 2) creep before they break, so the static level g(0) is "
        "set where a 5 N/s ramp of the push on the free piston breaks it away at a peak friction of "
        "99.0 N (experiments.breakaway_force; tested)",
    )
    stiction_extend: float = physical(
        57.6, "N", (0.0, 4000.0),
        "001 Table 2: stiction pulling on the piston -54 N (v_p > 0); static level g(0) set where a "
        "5 N/s pull on the free piston breaks it away at a peak friction of 54.0 N (experiments.breakaway_force; tested)",
    )
    stribeck_velocity: float = physical(
        5e-3, "m/s", (1e-5, 1.0), "assumed: 5 mm/s, typical of lubricated hydraulic seals"
    )
    friction_stiffness: float = physical(
        1.0e6, "N/m", (1e3, 1e7),
        "assumed: bristle stiffness sigma0 of the seal-friction family (hydro_envs.laws.seal_friction, "
        "n = 2: 001 eq (1) with gamma = sigma0 / F_c^2); 1e6 N/m = 26 um pre-sliding at F_c, 99 um at "
        "the 99 N breakaway (seals 10-100 um); eq (1)'s gamma = 100 1/(N cm) gives 6.76e6 (needs ~10 us steps)",
    )
    damping_gain: float = physical(
        0.4, "1", (0.0, 2.0), "001 sec. 4.4: gain of .4 at the output of the hydraulic damping block"
    )
    damping_linear: float = physical(
        4000.0, "N s/m", (0.0, 1e5), "001 eq (5): 40 v_p with v_p in cm/s (the simulator's N-cm units)"
    )
    damping_filter_frequency: float = physical(
        2.0 * math.pi * 40.0, "rad/s", (1.0, 1e5), "001 sec. 4.4: band-limited differentiation, pole at 40 Hz"
    )
    damping_force_scale: float = physical(
        1700.0, "N", (0.0, 1e5),
        "assumed (fig. 6 missing): A(x_v) at full opening; 0.4 A (1 + tanh kappa) = 1360 N >= max thrust",
    )
    damping_knee_velocity: float = physical(
        0.08, "m/s", (1e-3, 10.0),
        "assumed, chosen to meet a row: -d(x_v) at full opening = the fully opened valve's "
        "flow-limited speed (001 sec. 2: 'when the fully opened valve forces maximum flow in and out "
        "the chambers, velocity saturates'; sec. 4.4 fits the knees, fig. 6 missing). 001 prints no "
        "valve flow rating, pump flow or piston speed. 0.08 m/s = 1.86 L/min into 3.88 cm^2 (one "
        "0.745 mm jet at 345 N/cm^2, Cd 0.8, 870 kg/m^3: a small single-stage jet-pipe valve). Chosen "
        "from 0.08, 0.1, 0.12, 0.15, 0.25 m/s as the largest at which the P loop's -3 dB bandwidth "
        "does not rise with amplitude over 10-800 N (001 sec. 4.7; validation row 'falls with amplitude'): 0.1 m/s leaves a 1.5 % rise "
        "at 200 N, 0.25 m/s (5.8 L/min) puts every speed the blocked loop reaches below the knee "
        "and the bandwidth rises 131 -> 140 Hz up to 400 N",
    )
    damping_sharpness: float = physical(
        3.0, "1", (0.1, 20.0), "assumed (fig. 6 missing): kappa = s(x_v) |d(x_v)| of eq (5)"
    )
    stop_stiffness: float = physical(
        1e8, "N/m", (1e5, 1e11), "assumed: built-in stops, 13 um penetration at max thrust"
    )
    stop_damping: float = physical(
        2.0, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha (as the servo cylinder)"
    )
    friction_model: float = physical(
        0.0, "1", (0.0, 1.0),
        "0 = eq (1) as the seal-friction family's Dahl case with a bristle state z (default); 1 = the static curve "
        "g(v) tanh(v / friction_sign_velocity) without a pre-sliding state (smooth Coulomb-"
        "Stribeck, as the other cylinders' static friction; used by the moving-piston "
        "diagnosis rig, identification.diagnosis.plants, where the bristle state's relaxation "
        "4 sigma0 v / F_c at the free piston's speed bound would need ~15 RK4 sub-steps per 0.2 ms)",
    )
    friction_sign_velocity: float = physical(
        5e-3, "m/s", (1e-5, 1.0),
        "assumed: tanh regularisation velocity of the static curve (friction_model = 1); 5 mm/s "
        "= the Stribeck velocity, so the curve's slope g/v_eps stays below the sensor's k_s / b_s",
        open_low=True,
    )
    load_force: float = physical(
        0.0, "N", (-1e5, 1e5),
        "001 sec. 4.4: a constant external force on the free piston, + pushes it out (the hanging "
        "mass m g of the damping test); 0 for the blocked-piston rig of the seed's model",
    )
    feedback_filter_frequency: float = physical(
        175.0, "Hz", (0.0, 1e4),
        "force-signal conditioning of the controller's feedback path (Hall-effect deflection "
        "sensor, 001 sec. 2, through the controller card): a second-order Butterworth low-pass on "
        "F_s = k_s x_s; 0 = none. Not printed in 001: the cutoff is calibrated so that the "
        "proportional loop's limit cycle sits at the observed 95 Hz (001 sec. 4.7); the smallest "
        "limit-cycle gain and the -3 dB bandwidth are then predictions (validation rows)",
    )
    control_delay: float = physical(
        2e-4, "s", (0.0, 0.01),
        "computation delay of the digital force controller: a command computed from the force "
        "sampled at t_k is applied from t_k + control_delay; one control period of the 5 kHz "
        "loop (001 sec. 4.5 sampling rate; 'digital control is also possible', sec. 2)",
    )

    def _check_relations(self) -> None:
        if self.rod_area >= self.bore_area:
            raise ParameterError(
                f"ForceActuatorParams.rod_area = {self.rod_area} must be below bore_area = {self.bore_area}"
            )
        lo = min(self.stiction_retract, self.stiction_extend)
        if lo < self.coulomb_friction:
            raise ParameterError(
                f"ForceActuatorParams: stiction levels (stiction_retract, stiction_extend) = "
                f"({self.stiction_retract}, {self.stiction_extend} N) must be >= coulomb_friction = "
                f"{self.coulomb_friction} N"
            )
        if self.coulomb_friction == 0.0 and max(self.stiction_retract, self.stiction_extend) > 0.0:
            raise ParameterError(
                "ForceActuatorParams: coulomb_friction = 0 needs zero stiction_retract and stiction_extend "
                "too (a frictionless set); "
                "the bristles relax at 2 sigma0 |v| |u| / g(v), unbounded where the level fades to 0 at speed"
            )
        if self.current_max < self.rated_current:
            raise ParameterError(
                f"ForceActuatorParams.current_max = {self.current_max} A must be >= rated_current = "
                f"{self.rated_current} A"
            )
        if self.piston_locked not in (0.0, 1.0):
            raise ParameterError(f"ForceActuatorParams.piston_locked must be 0 or 1, got {self.piston_locked}")
        if self.friction_model not in (0.0, 1.0):
            raise ParameterError(f"ForceActuatorParams.friction_model must be 0 or 1, got {self.friction_model}")

    derived_names: ClassVar[tuple[str, ...]] = (
        ("tanh_damping_sharpness", "play_weight") + tuple(f"play_threshold_{k + 1}" for k in range(N_PLAY)))

    def derived_columns(self) -> list[float]:
        """The ``D_*`` columns, by the kernels' own arithmetic (bit-identical to computing them
        in every right-hand side)."""
        big_r = as_python(pi_threshold_scale)(self.hysteresis_width, self.hysteresis_reversal_slope, N_PLAY)
        derived = [as_python(tanh_one_exp)(self.damping_sharpness), (1.0 - self.hysteresis_reversal_slope) / N_PLAY]
        return derived + [big_r * (k + 1) / N_PLAY for k in range(N_PLAY)]

    # convenience
    @property
    def max_thrust(self) -> float:
        """Blocked-force saturation ``A1 p_s`` [N] (positive direction)."""
        return self.bore_area * self.supply_pressure

    @property
    def min_thrust(self) -> float:
        """Blocked-force saturation ``-A2 p_s`` [N] (negative direction)."""
        return -(self.bore_area - self.rod_area) * self.supply_pressure


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(ForceActuatorParams)
N_FIELDS = len(ForceActuatorParams.names())
N_PARAMS = len(_COL)
I_PS = _COL["supply_pressure"]
I_A1 = _COL["bore_area"]
I_AR = _COL["rod_area"]
I_L = _COL["stroke"]
I_IR = _COL["rated_current"]
I_IMAX = _COL["current_max"]
I_XOFF = _COL["valve_offset"]
I_HW = _COL["hysteresis_width"]
I_HR = _COL["hysteresis_reversal_slope"]
I_M = _COL["sensor_mass"]
I_KS = _COL["sensor_stiffness"]
I_BS = _COL["sensor_damping"]
I_MP = _COL["piston_mass"]
I_ML = _COL["load_mass"]
I_KL = _COL["load_stiffness"]
I_LOCK = _COL["piston_locked"]
I_FC = _COL["coulomb_friction"]
I_FSR = _COL["stiction_retract"]
I_FSE = _COL["stiction_extend"]
I_VS = _COL["stribeck_velocity"]
I_SIG = _COL["friction_stiffness"]
I_DG = _COL["damping_gain"]
I_DLIN = _COL["damping_linear"]
I_WC = _COL["damping_filter_frequency"]
I_DA = _COL["damping_force_scale"]
I_DV = _COL["damping_knee_velocity"]
I_DK = _COL["damping_sharpness"]
I_KSTOP = _COL["stop_stiffness"]
I_ASTOP = _COL["stop_damping"]
I_FMOD = _COL["friction_model"]
I_VEPS = _COL["friction_sign_velocity"]
I_FLOAD = _COL["load_force"]
I_FFILT = _COL["feedback_filter_frequency"]
I_TDEL = _COL["control_delay"]
#: derived columns: tanh(kappa) of the damping law (eq (5)), the plays' weight
#: (1 - w0)/n and their thresholds R k/n (sec. 3.3), k = 1..N_PLAY
D_TANHK = _COL["tanh_damping_sharpness"]
D_PLAYW = _COL["play_weight"]
D_PLAY0 = _COL["play_threshold_1"]
