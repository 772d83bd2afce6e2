"""Worst-case rates [1/s] of the load-sensing circuit's fast modes, split by where they are stiff.

:func:`stiffness_modes` are stiff everywhere (oscillators and dampers whose rate does not depend
on the state): they set the RK4 sub-step. :func:`local_mode_rates` are stiff only in a small
part of the state space, and the kernels take a sub-step there as finer ones
(:func:`hydro_envs.sim.rk4.rk4_advance_lookahead`, :func:`.model.local_mode_substeps`):

* ``spool_stop``: the FC spool on its seat or its spring-side stop (Hunt-Crossley contact);
* ``control_chamber``, ``delivery``, ``load_line``: the laminar core of the regularised orifice
  law (``dp / (dp^2 + dp_tr^2)^(1/4)``, slope ``1/sqrt(dp_tr)`` at zero drop, falling like
  ``|dp|^(-1/2)`` away from it) of the FC metering edges, the CV and the leaks into the
  control chamber ``V_x``, the delivery volume ``V_s`` and the load line ``V_l``: stiff only
  while the drop across an open edge is within a few ``dp_tr`` of zero. Working drops are
  20 bar and more (the LS margin), where the slope is about a tenth of its zero-drop value.

Each is a worst case over the state space (relief pressure on the spool, full openings, the
smallest volumes); the largest local one sets the most fine sub-steps a sub-step is taken as.
Functions of a :class:`~hydro_envs.plants.load_sensing.params.LoadSensingParams` and its
:func:`~hydro_envs.plants.load_sensing.params.derived` quantities ``d``, plain Python.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from hydro_envs.laws.seal_friction import bristle_stiffness_bound, dissipative_fade_velocity

__all__ = ["stiffness_modes", "local_mode_rates", "orifice_rate_coefficients"]


def stiffness_modes(p: Any, d: Mapping[str, float]) -> dict[str, float]:
    """Upper estimates [1/s] of the modes that are stiff everywhere:

    * ``spool``: FC spool on spring + flow-force stiffness at the relief pressure, plus c/m;
    * ``control_piston``: oil spring ``beta A1^2 / V_x0`` on ``m_y`` with the stop spring, plus
      ``b_y / m_y``;
    * ``delivery_piston``: the oil spring of the delivery volume on piston 2,
      ``sqrt(beta A2^2 / (V_s m_y))``;
    * ``load``: oil spring of the load line on the load with the actuator stop, plus viscous
      friction over M;
    * ``friction``: the load on its seals' bristles (LuGre with the Coulomb level, relaxation
      capped, :func:`~hydro_envs.laws.seal_friction.bristle_stiffness_bound`);
    * ``ls_line``: RLC line with the spool's displacement (eq (17)-type bound) + R/L;
    * ``solenoid``: 1/tau.
    """
    A, m = d["spool_area"], p.spool_mass
    beta = p.bulk_modulus
    k_spool = p.spring_stiffness + d["k_flow_force"] * p.relief_pressure
    c_ls_min = (d["ls_line_volume"] + p.spring_chamber_volume - A * p.spool_stroke) / beta
    omega_ls2 = 1.0 / (d["ls_inductance"] * c_ls_min) + A * A / (m * c_ls_min) + k_spool / m
    return {
        "spool": math.sqrt(k_spool / m) + d["viscous"] / m,
        "control_piston": math.sqrt(beta * p.control_area_large**2 / (p.control_volume * p.control_mass)
                                    + p.control_stop_stiffness / p.control_mass)
        + p.control_damping / p.control_mass,
        "delivery_piston": math.sqrt(beta * p.control_area_small**2 / (p.delivery_volume * p.control_mass)),
        "load": math.sqrt(beta * p.piston_area**2 / (p.line_volume * p.load_mass)
                          + p.actuator_stop_stiffness / p.load_mass)
        + p.actuator_viscous / p.load_mass,
        "friction": bristle_stiffness_bound(
            p.actuator_coulomb, p.actuator_coulomb, 0.0, p.actuator_bristle_stiffness, p.actuator_bristle_damping,
            dissipative_fade_velocity(p.actuator_bristle_damping, 1e-3, p.actuator_coulomb), p.actuator_viscous,
            p.load_mass, 1, p.actuator_bristle_relaxation_cap, 2.0),
        "ls_line": math.sqrt(omega_ls2) + (d["ls_resistance"] + p.ls_damping_resistance) / d["ls_inductance"],
        "solenoid": 1.0 / p.solenoid_time_constant,
    }


def local_mode_rates(p: Any, d: Mapping[str, float]) -> dict[str, float]:
    """Worst cases [1/s] of the modes the kernels refine locally (module docstring):

    * ``spool_stop``: seat contact ``sqrt(k/m)`` plus the Hunt-Crossley damping
      ``alpha F_max / m`` with ``F_max = A p_relief + k x_max``;
    * ``control_chamber``: zero-drop slope of the fully open FC port and the leak into ``V_x0``;
    * ``delivery``: zero-drop slopes of the open CV and FC port, pump leak and relief into ``V_s``;
    * ``load_line``: zero-drop slope of the open CV and the open port relief at its steepest
      (``d["load_relief_conductance"]``, :mod:`hydro_envs.laws.relief`) into ``V_l0``.
    """
    A, m = d["spool_area"], p.spool_mass
    beta = p.bulk_modulus
    g_lam = 1.0 / math.sqrt(p.orifice_transition_pressure)
    f_max = A * p.relief_pressure + p.spring_stiffness * p.spool_stroke
    g_port = d["k_meter"] * p.metering_width * p.port_length * g_lam
    g_cv = d["k_meter"] * p.cv_area_max * g_lam
    return {
        "spool_stop": math.sqrt(p.spool_stop_stiffness / m) + p.spool_stop_damping * f_max / m,
        "control_chamber": beta / p.control_volume * (g_port + p.control_leakage),
        "delivery": beta / p.delivery_volume * (g_cv + g_port + p.pump_leakage + p.relief_gradient),
        "load_line": beta / p.line_volume * (g_cv + d["load_relief_conductance"]),
    }


def orifice_rate_coefficients(p: Any, d: Mapping[str, float]) -> tuple[float, float]:
    """``(C, G)`` such that the orifice modes' local rate is at most ``C / sqrt(dp_min) + G``
    [1/s] at any state whose drops across the FC metering edges and the CV are all at least
    ``dp_min`` [Pa]: the slope of the regularised root is below ``|dp|^(-1/2)``, at most one FC
    edge is open (by at most the port length), the CV at most at full area, the volumes at
    their smallest (the load line's taken as half its dead volume, as
    :func:`.model.local_mode_rate` floors it). ``C`` [Pa^(1/2)/s] is the largest drop
    coefficient of the three nodes, ``G`` the largest leak term. The kernels' short cut: drops
    above ``(C / (stable / h - G))^2`` need no refinement."""
    beta = p.bulk_modulus
    g_port = d["k_meter"] * p.metering_width * p.port_length
    g_cv = d["k_meter"] * p.cv_area_max
    drop = max(beta / p.control_volume * g_port, beta / p.delivery_volume * (g_cv + g_port),
               beta / (0.5 * p.line_volume) * g_cv)
    leak = max(beta / p.control_volume * p.control_leakage,
               beta / p.delivery_volume * (p.pump_leakage + p.relief_gradient))
    return drop, leak
