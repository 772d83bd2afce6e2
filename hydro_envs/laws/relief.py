"""Pressure-relief valve laws (pure numba scalar kernels, SI units).

A direct-acting relief valve is a spring-loaded poppet or spool that starts to open when the
pressure drop across it reaches the cracking pressure ``p_crack`` and is fully open at
``p_crack + p_override`` (the override: the pressure rise that compresses the spring over the
poppet's stroke); through the opening the oil passes a turbulent orifice. This is the steady
characteristic of Hopsan's ``HydraulicPressureReliefValve`` (opening linear in the pressure
above the reference pressure through the spring's steady-state characteristic, limited to
``0 <= x <= 1``, times a turbulent flow function) and of OpenHydraulics' (Modelica)
``ReliefValve`` (an opening characteristic in the drop above ``p_crack`` times the
regularised root ``regRoot``); the simulator conventions of ``docs/references.md`` ("regularised orifice root, the same
function in Modelica (regRoot), Hopsan (signedSquareL)"). Neither seed (000-004) prints a
relief valve: the settings of the plants that use these laws are assumptions stated in their
parameters' sources. The first-order spool dynamics and hysteresis of Hopsan's component are
left out: the valve is taken at its steady opening (a poppet's time constant of about a
millisecond is below the plants' control periods).

Because the valve is closed below ``p_crack`` (a drop of many bar), the root never needs its
laminar regularisation here; the opening starts from zero so the flow is continuous (C0, a kink
at cracking and at full opening).
"""

from __future__ import annotations

import math

import numba

__all__ = [
    "relief_valve_opening",
    "pressure_relief_flow",
    "pressure_relief_conductance_bound",
    "linear_relief_flow",
]


@numba.njit(cache=True, error_model="numpy", inline="always")
def relief_valve_opening(dp, p_crack, p_override):
    """Normalised opening ``clip((dp - p_crack) / p_override, 0, 1)`` of a relief valve.

    Units: dp (drop across the valve, upstream minus downstream), p_crack, p_override [Pa]
    -> [-]. Source: Hopsan ``HydraulicPressureReliefValve`` steady state (spring characteristic
    linear in the pressure above the reference, opening limited to [0, 1]); module docstring.
    """
    s = (dp - p_crack) / p_override
    if s <= 0.0:
        return 0.0
    if s >= 1.0:
        return 1.0
    return s


@numba.njit(cache=True, error_model="numpy")
def pressure_relief_flow(dp, p_crack, p_override, q_rated):
    """Flow [m^3/s] through a pressure-relief valve at the drop ``dp`` across it.

        q = s(dp) q_rated sqrt(dp / (p_crack + p_override)),
        s = clip((dp - p_crack) / p_override, 0, 1)            (relief_valve_opening)

    0 below cracking, ``q_rated`` at ``dp = p_crack + p_override`` (fully open), then the
    turbulent root of the full opening. Continuous and non-negative (the valve is a check in
    the reverse direction).

    Units: dp, p_crack, p_override [Pa] (p_crack > 0, p_override > 0), q_rated [m^3/s] -> [m^3/s].
    Source: Hopsan ``HydraulicPressureReliefValve`` / OpenHydraulics ``ReliefValve`` steady
    characteristic (module docstring, NOTES.md).
    """
    if dp <= p_crack:
        return 0.0
    s = relief_valve_opening(dp, p_crack, p_override)
    return s * q_rated * math.sqrt(dp / (p_crack + p_override))


@numba.njit(cache=True, error_model="numpy")
def pressure_relief_conductance_bound(p_crack, p_override, q_rated):
    """Largest slope ``dq/d(dp)`` [m^3/(s Pa)] of :func:`pressure_relief_flow` over all drops.

    Between cracking and full opening ``dq/d(dp) = K/p_ov (sqrt(dp) + (dp - p_c)/(2 sqrt(dp)))``
    with ``K = q_rated / sqrt(p_c + p_ov)``, increasing in dp; beyond full opening it is
    ``K / (2 sqrt(dp))``, falling. The maximum, at full opening, is
    ``q_rated (1/p_override + 1/(2 (p_crack + p_override)))``: a chamber of volume V and
    modulus E sees the relief as a mode of at most ``E/V`` times this (sub-step control).
    Units: [Pa], [Pa], [m^3/s] -> [m^3/(s Pa)].
    """
    return q_rated * (1.0 / p_override + 0.5 / (p_crack + p_override))


@numba.njit(cache=True, error_model="numpy", inline="always")
def linear_relief_flow(dp, p_crack, gradient):
    """Flow ``gradient * max(dp - p_crack, 0)`` [m^3/s] of a relief valve with a linear
    pressure-flow characteristic above cracking (the small-override limit of
    :func:`pressure_relief_flow`, where the root of the drop hardly changes over the override:
    ``gradient = q_rated / p_override``).

    Units: dp, p_crack [Pa], gradient [m^3/(s Pa)] -> [m^3/s]. Source: as
    :func:`pressure_relief_flow` (module docstring).
    """
    if dp <= p_crack:
        return 0.0
    return gradient * (dp - p_crack)
