"""End-stop contact: a continuous penalty force for the mechanical stroke limits.

A rigid stop is an impulse; a fixed-step integrator needs a force instead. We use the
Hunt-Crossley form ``F = k * delta * (1 + alpha * delta_dot)`` with penetration ``delta`` and
penetration rate ``delta_dot``: it is zero at first contact (continuous in position *and*
velocity, so RK4 keeps its order better than with a spring-damper that jumps by ``c*v`` at
contact), its damping grows with penetration, and it is clipped at zero so the stop never
pulls the piston back (the same rule as Modelica's ``ElastoGap``).

Energy: the coefficient of restitution of this law is about ``1 - 2/3 * alpha * v_impact``
for small ``alpha * v_impact`` (Hunt & Crossley 1975, J. Appl. Mech. 42:440).
"""

from __future__ import annotations

import numba as nb

__all__ = ["end_stop_force", "hunt_crossley_force", "backlash_force", "CONTACT_DAMPING_RAMP"]

#: penetration [m] over which the damper of :func:`backlash_force` engages (assumed: 10 um, the
#: lubricant film squeezed out at first contact; a tenth of a 0.1 mm play). A shorter ramp is
#: a stiffer spring while it engages: ``c v / ramp`` at closing speed v.
CONTACT_DAMPING_RAMP = 1e-5


@nb.njit(cache=True, error_model="numpy")
def hunt_crossley_force(delta: float, delta_rate: float, k: float, alpha: float) -> float:
    """Compressive contact force [N] for penetration ``delta`` [m] >= 0 at rate [m/s].

    Returns 0 for ``delta <= 0`` and never a negative (pulling) force.
    """
    if delta <= 0.0:
        return 0.0
    f = k * delta * (1.0 + alpha * delta_rate)
    return f if f > 0.0 else 0.0


@nb.njit(cache=True, error_model="numpy")
def end_stop_force(x: float, v: float, x_min: float, x_max: float, k: float, alpha: float) -> float:
    """Net force [N] on a body at position ``x`` [m], velocity ``v`` from stops at x_min, x_max.

    Positive force pushes toward +x (out of the lower stop).
    """
    if x < x_min:
        return hunt_crossley_force(x_min - x, -v, k, alpha)
    if x > x_max:
        return -hunt_crossley_force(x - x_max, v, k, alpha)
    return 0.0


@nb.njit(cache=True, error_model="numpy")
def backlash_force(d: float, d_rate: float, gap: float, k: float, c: float) -> float:
    """Force [N] a drive exerts on its load across a play of ``+-gap`` [m].

    ``d = x_drive - x_load`` [m] and its rate [m/s]: no force while ``|d| <= gap`` (the drive
    crosses the play); beyond it a spring ``k`` [N/m] and a damper ``c`` [N s/m] on the
    penetration ``delta = |d| - gap``, the damper engaged over the first
    :data:`CONTACT_DAMPING_RAMP` of penetration so that the force is continuous at first
    contact, and clipped at zero so the drive never pulls the load across the play. Positive:
    towards +x (``d > gap``). The dead-zone model of gear and screw backlash (Nordin & Gutman
    2002, Automatica 38:1633, "Controlling mechanical systems with backlash -- a survey";
    Modelica's ``ElastoGap`` clips the same way).
    """
    if d > gap:
        delta = d - gap
        rate = d_rate
        s = 1.0
    elif d < -gap:
        delta = -gap - d
        rate = -d_rate
        s = -1.0
    else:
        return 0.0
    f = k * delta + c * rate * min(delta / CONTACT_DAMPING_RAMP, 1.0)
    return s * f if f > 0.0 else 0.0
