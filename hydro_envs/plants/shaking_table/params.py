"""Parameters of the seed-003 shaking table: value, unit, allowed range and source per field.

Defaults: ``003_54985feb8193da53.txt`` Table 1, Table 2 "modified IFAS" column (with the valid
lambda_2), specimen 200 kg; named variants in :data:`PRESETS` and :data:`SPECIMENS`. The index
constants ``I_*`` are the columns of the packed kernel parameter array.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

from hydro_envs.jit import as_python
from hydro_envs.laws.bulk_modulus import modified_ifas_shape_is_valid
from hydro_envs.laws.bulk_modulus_fast import ifas_constants, modified_ifas_shape_constants
from hydro_envs.contract import param_columns
from hydro_envs.params import ParameterError, PhysicalParams, physical
from hydro_envs.plants.shaking_table.bounds import (
    air_release_pressure, local_mode_rates, modulus_upper_bound, relief_conductance,
)

__all__ = ["PLANT", "ShakingTableParams", "PRESETS", "SPECIMENS", "BULK_MODULUS_MODELS", "N_PARAMS"]

PLANT = "shaking_table"

#: bulk_modulus_model values
BULK_MODULUS_MODELS = {"constant": 0, "ifas": 1, "modified_ifas": 2}

_ATM = 1.0e5  # Pa: the seed's gauge supply pressure + atmosphere = absolute
_BAR = 1.0e5


@dataclasses.dataclass(frozen=True)
class ShakingTableParams(PhysicalParams):
    """Parameters of the seed-003 shaking table (SI; pressures absolute).

    Defaults: Table 1, Table 2 "modified IFAS" column (with the valid lambda_2), specimen
    200 kg. Named variants: :data:`PRESETS` / :meth:`preset`.

    **Friction** (``003_54985feb8193da53.txt`` eqs (10)-(12), Table 2). Eq (11) is the steady
    Stribeck law with ``sign(v)``; eq (12) replaces the sign by ``tanh(beta v)`` "for avoiding
    discontinuity", as ``beta -> infinity``. Table 2 prints beta = 7.33 (5.8 for the IFAS
    column) without a unit. *beta is read per mm/s* (7.33 s/mm = 7330 s/m):

    * Physics and the paper's own intent: eq (12) is meant to be the sign. Read in s/m, tanh
      reaches 0.76 only at 1/beta = 0.136 m/s -- ten times the fitted Stribeck velocity
      v_s = 0.014 m/s and about the table's working speeds (003 sec. 1: LuGre is said valid
      "under 0.15 m/s"). The Stribeck dip would then sit where tanh is still ~0.1: at 10 mm/s
      it gives 76 N where eq (11) gives 987 N, and F_s, v_s would hardly enter the force.
    * The fit: NLSM (eqs (20)-(22)) could not identify F_s = 1254 N and v_s = 0.014 m/s (nor
      tell them from F_c and F_v) if the sign were smeared over 0.136 m/s: the exponential
      term would be multiplied by tanh(7.33 v) <= 0.25 wherever it is non-negligible. Figure 6
      (bottom) shows the fitted eq (11) as a Stribeck curve with a distinct static peak, which
      needs 1/beta << v_s. Per mm/s, 1/beta = 0.136 mm/s = v_s / 100: a near-sign law, and
      the fitted F_s, v_s act as printed (the IFAS column: 1/beta = 0.17 mm/s vs v_s = 80 mm/s).

    The plant uses the family's stick-capable dynamic law
    (:mod:`hydro_envs.laws.seal_friction`, LuGre n = 1) whose steady state is eq (11) with the
    sign exactly, so beta enters no kernel; it stays a field for the static reference law and
    the identification's sign width ``1/beta``. Bristle stiffness and micro-damping are not in
    003 (it uses the static law, sec. 1): assumed from the literature (fields' sources).
    """

    plant = PLANT
    #: the rig's dimensions (see PhysicalParams.geometry)
    geometry = ('piston_area', 'stroke', 'dead_volume')

    supply_pressure: float = physical(
        206 * _BAR + _ATM, "Pa", (2e5, 35e6), "003 Table 1: P_s = 206 bar (gauge) + 1 bar atmosphere"
    )
    tank_pressure: float = physical(_ATM, "Pa", (0.0, 5e6), "assumed: tank at atmosphere (P_T not given)")
    platform_mass: float = physical(
        650.0, "kg", (0.0, 1e5), "003 Table 1: M_b = 650 kg (mobile base + piston)", open_low=True
    )
    specimen_mass: float = physical(
        200.0, "kg", (0.0, 1e5), "003 sec. 4: M_s = 200 kg (Figs 5-8, 10-11); 500 kg in Fig 9"
    )
    piston_area: float = physical(
        9.4562e-4, "m^2", (0.0, 1.0), "003 Table 1: A (= pi/4 (50^2 - 36^2) mm^2, double rod, sec. 2)",
        open_low=True,
    )
    stroke: float = physical(0.26, "m", (0.0, 10.0), "003 sec. 2: CGH2 stroke 260 mm", open_low=True)
    dead_volume: float = physical(
        40e-6, "m^3", (0.0, 1.0),
        "assumed: hose (about 0.5 m of 10 mm bore) + valve/cylinder ports per side; V_t/2 = V_0 + A L/2",
        open_low=True,
    )
    flow_coefficient: float = physical(
        1.28e-7, "m^3/(s Pa^0.5)", (0.0, 2e-5),
        "003 Table 1: R = C_d w / sqrt(rho) per unit normalised opening (20.3 l/min at 70 bar/edge)",
    )
    underlap: float = physical(0.005, "1", (0.0, 0.5), "003 Table 1: U = 0.005 (normalised spool underlap)")
    spool_gain: float = physical(
        0.1, "1/V", (0.0, 10.0),
        "assumed: +-10 V = full stroke; reconciles 003 text (u = 0.3) with Table 3 (3 V)",
        open_low=True,
    )
    command_max: float = physical(10.0, "V", (0.0, 100.0), "assumed: +-10 V valve command range", open_low=True)
    valve_natural_frequency: float = physical(625.0, "rad/s", (10.0, 2e4), "003 Table 1: w_0 = 625 rad/s")
    valve_damping: float = physical(0.73, "1", (0.05, 5.0), "003 Table 1: zeta = 0.73")
    internal_leakage: float = physical(
        4.343e-13, "m^3/(s Pa)", (0.0, 1e-9), "003 Table 2: C_il (both columns)"
    )
    external_leakage: float = physical(
        4.05e-14, "m^3/(s Pa)", (0.0, 1e-9), "003 Table 2: C_el (both columns)"
    )
    coulomb_friction: float = physical(573.72, "N", (0.0, 2e4), "003 Table 2 (modified IFAS): F_c")
    static_friction: float = physical(1254.16, "N", (0.0, 2e4), "003 Table 2 (modified IFAS): F_s")
    viscous_friction: float = physical(429.4, "N s/m", (0.0, 1e6), "003 Table 2 (modified IFAS): F_v")
    stribeck_velocity: float = physical(
        0.014, "m/s", (1e-5, 10.0), "003 Table 2 (modified IFAS): v_s"
    )
    tanh_gain: float = physical(
        7330.0, "s/m", (0.0, 1e7),
        "003 Table 2 (modified IFAS): beta = 7.33 of tanh(beta v), eq (12), read per mm/s (7.33 s/mm = "
        "7330 s/m; ShakingTableParams docstring); the dynamic law does not use it (its steady state is "
        "eq (11) with the sign itself); kept as the sign width 1/beta of the static fit",
        open_low=True,
    )
    bristle_stiffness: float = physical(
        4e7, "N/m", (1e4, 1e10),
        "assumed: LuGre sigma0 of the CGH2 piston and rod seals (003 uses the static law eq (11)); "
        "pre-sliding displacement F_s/sigma0 = 31 um, inside the 10-100 um of elastomer hydraulic "
        "seals (the force actuator's 001 seals: 26 um; servo cylinder 30 um)",
    )
    bristle_damping: float = physical(
        3.7e5, "N s/m", (0.0, 1e8),
        "assumed: LuGre sigma1 = 2 sqrt(sigma0 M), critically damped pre-sliding oscillation of the "
        "850 kg table (200 kg specimen) on its seals (Astrom and Canudas de Wit 2008); fades with "
        "speed as exp(-(v/v_d)^2), v_d = v_s or less (hydro_envs.laws.seal_friction), which keeps "
        "the law dissipative",
    )
    bristle_relaxation_cap: float = physical(
        2000.0, "1/s", (0.0, 1e7),
        "assumed (numerics): bristle relaxation faster than this is taken as instantaneous, the "
        "quasi-static limit of LuGre (hydro_envs.laws.seal_friction): 1/(0.5 ms), one 0.5 ms sub-step "
        "(h a <= 1: RK4 follows the relaxation within 2 %); LuGre exactly below |v| = cap F_c / sigma0 = "
        "29 mm/s (2 v_s); 0 = none",
    )
    bulk_modulus_model: float = physical(
        2.0, "1", (0.0, 2.0), "003 sec. 3.3: 0 constant E_0, 1 IFAS eq (13), 2 modified IFAS eqs (15)-(19)"
    )
    e0: float = physical(4.73e8, "Pa", (1e7, 3e9), "003 Table 2 (modified IFAS): E_0")
    p0: float = physical(
        36.85 * _BAR, "Pa", (1e3, 1e8), "003 Table 2 (modified IFAS): P_0 = 36.85, read as bar (unit not printed)"
    )
    oil_exponent: float = physical(9.02, "1", (0.1, 50.0), "003 Table 2 (modified IFAS): m")
    air_content: float = physical(7.9e-7, "1", (0.0, 0.5), "003 Table 2 (modified IFAS): alpha")
    polytropic_exponent: float = physical(0.49, "1", (0.1, 2.0), "003 Table 2 (modified IFAS): kappa")
    lambda_1: float = physical(1.08, "1", (0.0, 10.0), "003 Table 2: lambda_1", open_low=True)
    lambda_2: float = physical(
        0.32, "1", (-10.0, 10.0),
        "003 Table 2 prints 0.64 (h(0) = -0.20 < 0); 0.32 keeps the notch depth 0.64, hydro_envs.laws.bulk_modulus",
    )
    mu: float = physical(8.80e-6, "1/Pa", (0.0, 1.0), "003 Table 2: mu (read as 1/Pa)")
    threshold_pressure: float = physical(9.177e5, "Pa", (0.0, 1e8), "003 Table 2: P_Lt (read as Pa)")
    stop_stiffness: float = physical(
        1e8, "N/m", (1e5, 1e11), "assumed: steel end-stroke (H), 0.2 mm penetration at full thrust A P_s"
    )
    stop_damping: float = physical(
        2.0, "s/m", (0.0, 100.0), "assumed: Hunt-Crossley alpha, restitution about 0.3 at 0.5 m/s"
    )
    orifice_transition_pressure: float = physical(
        1e5, "Pa", (1.0, 1e7), "assumed: laminar core of the regularised root (0.5 % of P_s; docs/references.md)"
    )
    pressure_floor: float = physical(
        1e3, "Pa", (1.0, 1e5), "assumed: cavitation floor; IFAS evaluated at max(P, floor)"
    )
    min_chamber_volume: float = physical(
        1e-7, "m^3", (0.0, 1.0), "assumed: guard only; V_0 keeps chambers >= 25 cm^3", open_low=True
    )
    # ---- port relief valves, one per chamber to tank (hydro_envs.laws.relief); 003 prints none
    relief_pressure: float = physical(
        230 * _BAR + _ATM, "Pa", (2e5, 1e8),
        "assumed: cracking pressure of the chambers' port reliefs to tank, 230 bar gauge = 12 % above "
        "the 206 bar supply (003 Table 1), usual practice (10-15 % above the system pressure, below the "
        "CGH2 cylinder's 250 bar rating); 003 prints no relief",
    )
    relief_override: float = physical(
        28 * _BAR, "Pa", (1e4, 5e7),
        "assumed: pressure rise from cracking to the rated flow, 12 % of the setting (direct-acting "
        "relief valves' p-Q curves rise 10-20 % over their flow range)", open_low=True,
    )
    relief_flow: float = physical(
        8.3e-4, "m^3/s", (0.0, 1e-1),
        "assumed: rated flow 50 L/min at full opening, 2.5 x the 4WS.2E's 20 L/min (003 sec. 2): the "
        "displacement flow A v of the table braking from 2 x its 0.43 m/s no-load speed; 0 = no relief",
    )

    # ------------------------------------------------------------------ checks
    def _check_relations(self) -> None:
        name = type(self).__name__
        if self.static_friction < self.coulomb_friction:
            raise ParameterError(
                f"{name}.static_friction = {self.static_friction} must be >= coulomb_friction = "
                f"{self.coulomb_friction} (Stribeck: F_s >= F_c)"
            )
        if self.static_friction > 0.0 and not self.coulomb_friction > 0.0:
            raise ParameterError(
                f"{name}.coulomb_friction = {self.coulomb_friction} must be > 0 when static_friction = "
                f"{self.static_friction} > 0 (the LuGre level must stay positive at speed); set both to 0 "
                "for seals without dry friction"
            )
        if not (self.pressure_floor < self.tank_pressure < self.supply_pressure):
            raise ParameterError(
                f"{name}: need pressure_floor < tank_pressure < supply_pressure, got "
                f"{self.pressure_floor}, {self.tank_pressure}, {self.supply_pressure} Pa"
            )
        if self.bulk_modulus_model not in (0.0, 1.0, 2.0):
            raise ParameterError(
                f"{name}.bulk_modulus_model = {self.bulk_modulus_model} must be 0 (constant), "
                "1 (IFAS) or 2 (modified IFAS)"
            )
        # the law's Python body: checking a parameter set compiles nothing
        if not as_python(modified_ifas_shape_is_valid)(self.lambda_1, self.lambda_2, self.mu, self.threshold_pressure):
            h0 = self.lambda_1 - 2.0 * self.lambda_2 * math.tanh(self.mu * self.threshold_pressure)
            raise ParameterError(
                f"{name}: modified-IFAS shape (lambda_1, lambda_2, mu, threshold_pressure) = "
                f"({self.lambda_1}, {self.lambda_2}, {self.mu}, {self.threshold_pressure}) gives "
                f"inf h = {min(h0, self.lambda_1):.4g} <= 0: a negative bulk modulus near P_a = P_b "
                "(003 eq (19); need lambda_1 - 2 lambda_2 tanh(mu P_Lt) > 0)"
            )
        if 1.0 + self.oil_exponent * (self.pressure_floor - self.p0) / self.e0 <= 0.0:
            raise ParameterError(
                f"{name}: 1 + m (p_floor - P_0) / E_0 <= 0: the IFAS oil term of eq (13) is undefined "
                f"(m = oil_exponent = {self.oil_exponent}, p_floor = pressure_floor = {self.pressure_floor}, "
                f"P_0 = p0 = {self.p0}, E_0 = e0 = {self.e0})"
            )
        if not self.relief_pressure > self.tank_pressure:
            raise ParameterError(
                f"{name}.relief_pressure = {self.relief_pressure} Pa must be above tank_pressure = "
                f"{self.tank_pressure} Pa (the port reliefs crack at relief_pressure - tank_pressure > 0)"
            )
        if self.min_chamber_volume >= self.dead_volume:
            raise ParameterError(
                f"{name}.min_chamber_volume = {self.min_chamber_volume} must be below dead_volume = "
                f"{self.dead_volume} m^3"
            )

    derived_names: ClassVar[tuple[str, ...]] = (
        "modulus_max", "local_rate", "air_release_pressure", "inv_mass",
        "ifas_m_over_e0", "ifas_inv_m", "ifas_inv_kappa", "ifas_ln_p0", "ifas_oil_over_e0", "ifas_alpha_over_kappa",
        "notch_amplitude", "notch_c2", "notch_one_plus_c2", "notch_far", "micro_damping_velocity",
        "relief_conductance",
    )

    def derived_columns(self) -> list[float]:
        """Kernel quantities computed once per parameter set: the largest chamber modulus, the
        worst-case rate of the locally refined orifice modes and the air-release pressure
        (:mod:`.bounds`), ``1/M``, and the parameter-only terms of the IFAS law (eq (13),
        :func:`~hydro_envs.laws.bulk_modulus_fast.ifas_constants`) and of the notch's shape (eq
        (19), :func:`~hydro_envs.laws.bulk_modulus_fast.modified_ifas_shape_constants`), and the
        speed [m/s] over which the seals' micro-damping fades (the Stribeck velocity or less where
        that keeps the friction dissipative,
        :func:`~hydro_envs.laws.seal_friction.dissipative_fade_velocity` at the Coulomb level) and
        the port reliefs' largest slope [m^3/(s Pa)]
        (:func:`~hydro_envs.laws.relief.pressure_relief_conductance_bound`); the laws' Python
        bodies, so that making a parameter set compiles nothing."""
        from hydro_envs.laws.seal_friction import dissipative_fade_velocity

        ifas = as_python(ifas_constants)(self.e0, self.p0, self.oil_exponent, self.air_content, self.polytropic_exponent)
        notch = as_python(modified_ifas_shape_constants)(self.lambda_1, self.lambda_2, self.mu, self.threshold_pressure)
        return [modulus_upper_bound(self), max(local_mode_rates(self).values()), air_release_pressure(self),
                1.0 / self.mass, *ifas, *notch,
                dissipative_fade_velocity(self.bristle_damping, self.stribeck_velocity, self.coulomb_friction),
                relief_conductance(self)]

    # ------------------------------------------------------------------ presets
    @property
    def mass(self) -> float:
        """Moving mass M = M_b + M_s [kg] (003 eq (10))."""
        return self.platform_mass + self.specimen_mass

    @classmethod
    def preset(cls, name: str = "modified_ifas", specimen: str | float = "200kg", **overrides: Any) -> "ShakingTableParams":
        """A named parameter set: ``name`` in :data:`PRESETS`, ``specimen`` in :data:`SPECIMENS`
        (or a mass in kg); ``overrides`` replace single fields afterwards."""
        if name not in PRESETS:
            raise ParameterError(f"unknown shaking-table preset {name!r}; known: {sorted(PRESETS)}")
        if isinstance(specimen, str):
            if specimen not in SPECIMENS:
                raise ParameterError(f"unknown specimen {specimen!r}; known: {sorted(SPECIMENS)} or a mass in kg")
            ms = SPECIMENS[specimen]
        else:
            ms = float(specimen)
        values = {**PRESETS[name], "specimen_mass": ms, **overrides}
        return cls.from_mapping(values)


#: Named parameter sets (fields that differ from the dataclass defaults).
PRESETS: dict[str, dict[str, float]] = {
    # 003 Table 2, first column, with the valid lambda_2 (= the defaults)
    "modified_ifas": {"bulk_modulus_model": 2.0},
    # 003 Table 2, second column (IFAS E-modulus eq (13), its own friction fit)
    "ifas": {
        "bulk_modulus_model": 1.0,
        "coulomb_friction": 531.85,
        "static_friction": 952.6,
        "viscous_friction": 153.4,
        "stribeck_velocity": 0.08,
        "tanh_gain": 5800.0,
        "e0": 4.7e8,
        "p0": 8.7 * _BAR,
        "oil_exponent": 7.88,
        "air_content": 6.8e-7,
        "polytropic_exponent": 0.7224,
    },
    # constant modulus E = E_0 (modified-IFAS column's E_0 and friction), for comparison
    "constant": {"bulk_modulus_model": 0.0},
}

#: Specimen masses of 003 sec. 4 [kg].
SPECIMENS: dict[str, float] = {"none": 0.0, "200kg": 200.0, "500kg": 500.0}


# Column indices of the packed parameter row (``to_array()``), generated from the dataclass'
# fields and derived names (:func:`hydro_envs.contract.param_columns`), each looked up by name.
_COL = param_columns(ShakingTableParams)
N_FIELDS = len(ShakingTableParams.names())
N_PARAMS = len(_COL)
I_PS = _COL["supply_pressure"]
I_PT = _COL["tank_pressure"]
I_MB = _COL["platform_mass"]
I_MS = _COL["specimen_mass"]
I_A = _COL["piston_area"]
I_L = _COL["stroke"]
I_V0 = _COL["dead_volume"]
I_R = _COL["flow_coefficient"]
I_U = _COL["underlap"]
I_KU = _COL["spool_gain"]
I_UMAX = _COL["command_max"]
I_W0 = _COL["valve_natural_frequency"]
I_ZETA = _COL["valve_damping"]
I_CIL = _COL["internal_leakage"]
I_CEL = _COL["external_leakage"]
I_FC = _COL["coulomb_friction"]
I_FS = _COL["static_friction"]
I_FV = _COL["viscous_friction"]
I_VS = _COL["stribeck_velocity"]
I_BETA = _COL["tanh_gain"]
I_SIG0 = _COL["bristle_stiffness"]
I_SIG1 = _COL["bristle_damping"]
I_ZCAP = _COL["bristle_relaxation_cap"]
I_MODEL = _COL["bulk_modulus_model"]
I_E0 = _COL["e0"]
I_P0 = _COL["p0"]
I_M = _COL["oil_exponent"]
I_ALPHA = _COL["air_content"]
I_KAPPA = _COL["polytropic_exponent"]
I_L1 = _COL["lambda_1"]
I_L2 = _COL["lambda_2"]
I_MU = _COL["mu"]
I_PLT = _COL["threshold_pressure"]
I_KSTOP = _COL["stop_stiffness"]
I_ASTOP = _COL["stop_damping"]
I_DPTR = _COL["orifice_transition_pressure"]
I_PFLOOR = _COL["pressure_floor"]
I_VMIN = _COL["min_chamber_volume"]
I_PRV = _COL["relief_pressure"]
I_POV = _COL["relief_override"]
I_QRV = _COL["relief_flow"]
#: derived columns (:meth:`ShakingTableParams.derived_columns`)
D_EMAX = _COL["modulus_max"]
D_LOCAL = _COL["local_rate"]
D_PAIR = _COL["air_release_pressure"]
D_INV_M = _COL["inv_mass"]
D_IFAS_M_E0 = _COL["ifas_m_over_e0"]
D_IFAS_INV_M = _COL["ifas_inv_m"]
D_IFAS_INV_KAPPA = _COL["ifas_inv_kappa"]
D_IFAS_LN_P0 = _COL["ifas_ln_p0"]
D_IFAS_OIL_E0 = _COL["ifas_oil_over_e0"]
D_IFAS_ALPHA_KAPPA = _COL["ifas_alpha_over_kappa"]
D_NOTCH_AMP = _COL["notch_amplitude"]
D_NOTCH_C2 = _COL["notch_c2"]
D_NOTCH_ONE_C2 = _COL["notch_one_plus_c2"]
D_NOTCH_FAR = _COL["notch_far"]
D_DFADE = _COL["micro_damping_velocity"]
D_GRV = _COL["relief_conductance"]
