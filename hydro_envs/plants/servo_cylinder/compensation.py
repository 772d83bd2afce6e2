r"""Friction feedforward for the valve-controlled servo cylinder (seed 002): the steady-state
inversion of its orifice law and a compensator built on any identified friction model.

A compensator maps a velocity (the desired one, or a measured one) to the feedforward
friction force of an identified model -- a static fit (:mod:`identification.friction`) or a
neural net (:mod:`identification.neural`), anything callable as ``F = model(v)`` -- and then to
the valve command that delivers the desired velocity *against that force*.

Inversion of the orifice law (002 eqs (3)-(6), steady state)
------------------------------------------------------------
With the piston at constant velocity ``v`` the chambers are at constant pressure, so the
flows equal the swept flows, ``Q1 = A v`` and (out of chamber 2) ``A v``. For ``v > 0`` the
edges P->1 and 2->T are open, both with area ``w x_v`` (critically lapped, matched), so
``p_s - p1 = p2 - p_R``; with the load pressure ``p_L = p1 - p2 = F / A`` (``F`` the force the
piston must deliver: friction plus external load, 002 eq (7) at zero acceleration) each edge
sees ``(p_s - p_R - p_L) / 2``. For ``v < 0`` the mirror edges see ``(p_s - p_R + p_L) / 2``.
Hence

    A |v| = C_v w |x_v| sqrt((p_s - p_R - sgn(v) F / A) / rho)
    u     = x_v / k_v = v A / (k_v C_v w sqrt((p_s - p_R - sgn(v) F / A) / rho))

(``x_v = k_v u`` is the spool's static gain, 002 eq (2)). ``F = 0`` gives the nominal
velocity gain ``u_0 = v / K_q``, ``K_q = v_nl / u_max`` (:func:`no_load_velocity`). The
friction feedforward is the increment ``du = u(v, F_f(v)) - u(v, 0)``; it is proportional to
``v`` (zero at standstill, so the sign ambiguity of the friction at ``v = 0`` never reaches the
valve) and for ``|F| / A << p_s - p_R`` equals ``u_0 F / (2 A (p_s - p_R))``.

What it can and cannot do: the valve-controlled cylinder is nearly a flow source -- at the
seed's 13.8 MPa supply, 60 N of friction (90 kPa of load pressure) slows the piston by only
0.33 %, which the increment removes (tests: open-loop velocity error and closed-loop ramp
lag). It cannot remove the friction-induced limit cycle below about 20 mm/s
(:mod:`hydro_envs.plants.servo_cylinder.friction_test`): that is a dynamic instability of the oil spring against
the negative Stribeck slope, which a velocity feedforward does not damp. 
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams

__all__ = [
    "load_pressure",
    "edge_pressure_drop",
    "valve_command",
    "command_increment",
    "FrictionCompensator",
]


def load_pressure(force: Any, area: float) -> np.ndarray:
    """Load pressure ``p_L = F / A`` [Pa] the piston needs to deliver force ``F`` [N]."""
    if not (math.isfinite(area) and area > 0):
        raise ValueError(f"area must be > 0 m^2, got {area}")
    return np.asarray(force, dtype=float) / area


def edge_pressure_drop(v: Any, force: Any, params: ServoCylinderParams) -> np.ndarray:
    """Pressure drop [Pa] over each open metering edge at steady velocity ``v`` and force ``F``:
    ``(p_s - p_R - sgn(v) F / A) / 2``."""
    v = np.asarray(v, dtype=float)
    p_l = load_pressure(force, params.piston_area)
    return 0.5 * (params.supply_pressure - params.tank_pressure - np.sign(v) * p_l)


def valve_command(
    v: Any,
    force: Any = 0.0,
    params: ServoCylinderParams | None = None,
    *,
    saturate: bool = True,
) -> np.ndarray:
    """Valve command ``u`` [V] for steady velocity ``v`` [m/s] against force ``F`` [N].

    ``u = v A / (k_v C_v w sqrt((p_s - p_R - sgn(v) F / A) / rho))`` (module docstring; with
    the plant's regularised root).
    Raises ``ValueError`` if ``sgn(v) F`` reaches ``A (p_s - p_R)`` (the cylinder stalls at any
    opening). ``saturate`` clips to ``+-command_max``.
    """
    p = params if params is not None else ServoCylinderParams()
    v = np.asarray(v, dtype=float)
    drop2 = 2.0 * edge_pressure_drop(v, force, p)  # = p_s - p_R - sgn(v) F / A
    moving = v != 0.0
    if np.any(moving & ~(drop2 > 0)):
        f_max = p.piston_area * (p.supply_pressure - p.tank_pressure)
        raise ValueError(
            f"force exceeds the stall force A (p_s - p_R) = {f_max:.4g} N in the direction of "
            "motion: no valve opening gives that velocity"
        )
    gain = p.spool_gain * p.discharge_coefficient * p.area_gradient * math.sqrt(2.0 / p.oil_density)
    dp = 0.5 * np.where(moving, drop2, 1.0)  # drop over each edge
    root = dp / np.sqrt(np.sqrt(dp * dp + p.orifice_transition_pressure**2))  # plant's regRoot
    u = np.where(moving, v * p.piston_area / (gain * root), 0.0)
    if saturate:
        u = np.clip(u, -p.command_max, p.command_max)
    return u


def command_increment(v: Any, force: Any, params: ServoCylinderParams | None = None) -> np.ndarray:
    """Feedforward increment ``u(v, F) - u(v, 0)`` [V] (unsaturated)."""
    return valve_command(v, force, params, saturate=False) - valve_command(v, 0.0, params, saturate=False)


def _as_callable(model: Any) -> Callable[[np.ndarray], np.ndarray]:
    if hasattr(model, "predict"):
        return model.predict
    if callable(model):
        return model
    raise TypeError(f"model must be callable as F = model(v) or have .predict(v); got {type(model).__name__}")


class FrictionCompensator:
    """Friction feedforward for the servo cylinder: velocity -> force -> valve command.

    ``model``: a fitted static model (:class:`identification.friction.FrictionFit`, ...), a
    neural model (:mod:`identification.neural`) or any ``F = model(v)`` [N]. ``params``: the
    (nominal) plant parameters used for the inversion. ``load_force`` [N]: a known external
    load added to the friction (002 eq (7)'s ``F_L``).

    ``comp(v)`` returns the command increment [V]; :meth:`command` the total command for a
    desired velocity (nominal inversion plus increment); :meth:`action` the increment in env
    action units (fraction of ``command_max``). Pure functions of their arguments, vectorised.
    """

    def __init__(self, model: Any, params: ServoCylinderParams | None = None, *, load_force: float = 0.0) -> None:
        self.model = model
        self._f = _as_callable(model)
        self.params = params if params is not None else ServoCylinderParams()
        if not math.isfinite(load_force):
            raise ValueError(f"load_force must be finite, got {load_force}")
        self.load_force = float(load_force)

    def force(self, v: Any) -> np.ndarray:
        """Feedforward force [N]: model friction plus the known load."""
        v = np.asarray(v, dtype=float)
        return np.asarray(self._f(v), dtype=float) + self.load_force

    def increment(self, v: Any) -> np.ndarray:
        """Command increment [V] that compensates the force at velocity ``v``."""
        return command_increment(v, self.force(v), self.params)

    __call__ = increment

    def command(self, v_desired: Any) -> np.ndarray:
        """Total command [V] for a desired steady velocity (saturated at ``command_max``)."""
        return valve_command(v_desired, self.force(v_desired), self.params)

    def action(self, v: Any) -> np.ndarray:
        """:meth:`increment` as a fraction of ``command_max`` (the envs' action units)."""
        return self.increment(v) / self.params.command_max
