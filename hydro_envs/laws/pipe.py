"""Lumped and segmented pipe (hydraulic line) laws (pure numba scalar kernels, SI units).

Source: ``000_d7d5fd9bd6b165a2.txt`` sec. 3.1, the RLC (resistive-inductive-capacitive) pipe:

* eq (1)  inductance   ``L = rho l / a``                 (a = pi d^2 / 4, the bore area)
* eq (2)  resistance   ``R = 128 mu l / (pi d^4)``       (Hagen-Poiseuille, laminar)
* eq (3)  capacitance  ``C = V / beta``
* eq (5)  momentum     ``L dQ/dt + R Q = p_up - p_down``
* eq (6)  continuity   ``C dp/dt = Q_in - Q_out``

Extraction defect (``docs/references.md``): eq (2) is printed ``128 mu L / (pi d^4)``
where ``L`` is the pipe *length* ``l`` of eq (1), not the inductance; we use ``l`` (the
printed form is dimensionally wrong: it would give Pa s^2/m^4 * ... instead of Pa s/m^3).
Table 1 of 000 confirms it: with ISO VG 46 at 40 C (nu = 46 mm^2/s) its L and R imply
``L / R = d^2 / (32 nu) = 11.3 ms``, i.e. a 4.07 mm bore of 0.327 m length.

Distributed line: ``N`` such RLC segments in series (each ``l/N`` long) form a ladder; with
the capacitance lumped at the segment joints (pi sections) it converges to the
transmission line with laminar friction at O(1/N^2) in the modal frequencies. Hopsan uses a
method-of-characteristics line instead (wave speed ``sqrt(beta/rho)``, delay ``l/c``
rounded to the step, docs/references.md); a segmented ladder fits the fixed-step RK4 kernels without a
delay buffer, and Amesim's distributed RLC pipe (000 sec. 3.4: "12 internal nodes") is the
same construction. :func:`line_transfer_function` is the exact distributed solution used to
check the ladder.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "pipe_bore_area",
    "pipe_inductance",
    "pipe_laminar_resistance",
    "hydraulic_capacitance",
    "rlc_flow_derivative",
    "line_transfer_function",
]


@numba.njit(cache=True, error_model="numpy")
def pipe_bore_area(d):
    """Bore cross-section ``a = pi d^2 / 4``. Units: d [m] -> [m^2]. Source: 000 eq (1)."""
    return 0.25 * math.pi * d * d


@numba.njit(cache=True, error_model="numpy")
def pipe_inductance(rho, l, d):
    """Hydraulic inductance (fluid inertance) ``L = rho l / a``, 000 eq (1).

    Units: rho [kg/m^3], l [m], d [m] -> [kg/m^4] (= Pa s^2/m^3).
    000 Table 1: L = 2.182e7 kg/m^4 for the method-1 pilot pipe.
    """
    return rho * l / (0.25 * math.pi * d * d)


@numba.njit(cache=True, error_model="numpy")
def pipe_laminar_resistance(mu, l, d):
    """Laminar (Hagen-Poiseuille) resistance ``R = 128 mu l / (pi d^4)``, 000 eq (2).

    ``l`` is the pipe length (000 prints ``L`` here: an extraction defect, see module
    docstring). Units: mu [Pa s], l [m], d [m] -> [Pa s/m^3].
    000 Table 1: R = 1.935e9 Pa s/m^3. Valid for laminar flow (Re = 4 rho |Q| / (pi mu d)
    < ~2300; the pilot lines of 000 carry only the spool's displacement flow).
    """
    return 128.0 * mu * l / (math.pi * d * d * d * d)


@numba.njit(cache=True, error_model="numpy")
def hydraulic_capacitance(volume, beta):
    """Hydraulic capacitance ``C = V / beta``, 000 eq (3).

    Units: volume [m^3], beta [Pa] -> [m^3/Pa]. 000 Table 1: C = 5.660e-15 m^3/Pa (pipe plus
    pilot chamber).
    """
    return volume / beta


@numba.njit(cache=True, error_model="numpy")
def rlc_flow_derivative(q, p_up, p_down, inductance, resistance):
    """``dQ/dt = (p_up - p_down - R Q) / L`` -- the momentum balance of 000 eq (5).

    Units: q [m^3/s], p_up, p_down [Pa], inductance [kg/m^4], resistance [Pa s/m^3]
    -> [m^3/s^2]. Positive Q flows from the ``up`` to the ``down`` node.
    """
    return (p_up - p_down - resistance * q) / inductance


def line_transfer_function(
    s: np.ndarray,
    inductance: float,
    resistance: float,
    capacitance: float,
    load_admittance: np.ndarray,
) -> np.ndarray:
    """Exact ``p_end / p_inlet`` of a uniform line with laminar friction and a load.

    Per unit length the series impedance is ``(R + s L)/l`` and the shunt admittance
    ``s C/l`` (total L, R, C of the line), so with ``Gamma = sqrt((R + sL) sC)`` (the
    propagation constant times l) and ``Z_c = sqrt((R + sL)/(sC))``::

        p_end / p_in = 1 / (cosh(Gamma) + Z_c Y_load sinh(Gamma))

    where ``Y_load(s) = Q_end / p_end`` is the admittance of whatever closes the line (the
    pilot chamber plus the spool: ``s C_ch + A^2 s / (m s^2 + c s + k)``). Steady laminar
    friction only (no frequency-dependent friction). Source: telegraph equations of the
    distributed line whose lumped limit is 000 eqs (1)-(3), (5)-(6).
    """
    s = np.asarray(s, dtype=complex)
    z = resistance + s * inductance
    y = s * capacitance
    gamma = np.sqrt(z * y)
    zc = np.sqrt(z / y)
    return 1.0 / (np.cosh(gamma) + zc * np.asarray(load_admittance) * np.sinh(gamma))
