"""Exponential Stribeck curve of 004 Table 2 and its dynamic (LuGre) form (numba, SI).

Source: ``004_f1423316a055addb.txt`` sec. 3.1 (Fig. 3 construction) and Table 2
(F_s = 35.48 N, F_c = 15.31 N, ydot_s = 3.27 mm/s, sigma = 0.31 N s/mm; the conclusions'
"sigma = 3.27 mm/s" is an extraction defect, ``docs/references.md``).

Which Stribeck form 004 uses: the text gives no formula, only the graphical construction of
sec. 3.1 -- a straight line from F_s at zero speed (the low-speed branch f_1) and a horizontal
line at F_c; the Stribeck velocity is where they meet. That is the defining property of the
*exponential* curve ``g(v) = F_c + (F_s - F_c) exp(-|v|/v_s)``: its tangent at v = 0+,
``F_s - (F_s - F_c) v / v_s``, reaches F_c exactly at v = v_s. (The Gaussian curve of 003
has a flat tangent at zero and no such intersection.) The viscous line of slope sigma through
F_c is the ``sigma v`` term. So the steady-state friction of the rodless cylinder is::

    F_ss(v) = (F_c + (F_s - F_c) exp(-|v| / v_s)) sign(v) + sigma v           (Table 2)

which is :func:`hydro_envs.laws.friction.stribeck_exponential` with ``v_eps = 0``.

Dynamic form: 004 Fig. 4 reports "a small displacement before the continuous sliding of the
cylinder" (pre-sliding displacement). The LuGre model (Canudas de Wit et al. 1995) reproduces
it with a bristle deflection z and has *exactly* the Table 2 curve as its steady state::

    dz/dt = v - sigma0 |v| z / g(v)
    F     = sigma0 z + sigma1 dz/dt + sigma v        ->  F_ss(v) at constant v

It is also far cheaper to integrate with fixed-step RK4 than a tanh-regularised static curve
with a regularisation velocity well below v_s (see ``hydro_envs.plants.rodless_cylinder``).
"""

from __future__ import annotations

import math

import numba

from hydro_envs.libm import exp

__all__ = ["stribeck_exponential_curve", "lugre_exponential_rate", "lugre_exponential_rate_bound"]


@numba.njit(cache=True, error_model="numpy")
def stribeck_exponential_curve(v, f_c, f_s, v_s):
    """Magnitude of the exponential Stribeck curve ``g(v) = f_c + (f_s - f_c) exp(-|v|/v_s)``.

    Units: v [m/s], f_c [N], f_s [N], v_s [m/s] (> 0) -> [N].
    Source: ``004_f1423316a055addb.txt`` sec. 3.1, Table 2 (g(0) = F_s, g -> F_c, and the
    tangent at 0+ meets F_c at v = v_s, the Fig. 3 construction).
    """
    return f_c + (f_s - f_c) * exp(-abs(v) / v_s)


@numba.njit(cache=True, error_model="numpy")
def lugre_exponential_rate(v, z, f_c, f_s, v_s, sigma0):
    """LuGre bristle rate ``dz/dt = v - sigma0 |v| z / g(v)`` with the 004 exponential g.

    Steady state at constant v != 0: ``z = g(v) sign(v) / sigma0``, so the friction force
    ``sigma0 z + sigma1 dz/dt + sigma2 v`` equals the Table 2 curve. Requires g > 0
    (f_c > 0). Stiffness: the rate is linear in z with coefficient ``sigma0 |v| / g(v)``.
    Units: v [m/s], z [m], f_c, f_s [N], v_s [m/s], sigma0 [N/m] -> [m/s].
    Source: LuGre (Canudas de Wit et al. 1995; 003 ref [30], 002 ref [6]) with the 004
    Table 2 curve; pre-sliding displacement of 004 Fig. 4.
    """
    return v - sigma0 * abs(v) * z / stribeck_exponential_curve(v, f_c, f_s, v_s)


@numba.njit(cache=True, error_model="numpy", inline="always")
def lugre_exponential_rate_bound(v, z, f_c, f_s, sigma0, sigma1, damping, mass):
    """Upper bound [1/s] of the eigenvalue magnitudes of the (velocity, bristle) block of a
    mass ``mass`` [kg] with LuGre friction (:func:`lugre_exponential_rate`), at velocity ``v``
    and bristle deflection ``z``, whatever the Stribeck velocity.

    The block is ``[[-(sigma1 e + c)/M, -(sigma0 - sigma1 a)/M], [e, -a]]`` with
    ``a = sigma0 |v| / g`` and ``e = d(dz/dt)/dv``; ``c`` [N s/m] is ``damping``, every other
    damping on the mass (viscous sigma, a stop). Its trace is ``T = a + (sigma1 e + c)/M`` and
    its determinant ``D = (a c + e sigma0)/M`` (the sigma1 a e terms cancel), so every eigenvalue
    has ``|lambda| <= |T|/2 + sqrt(T^2/4 + |D|)``. With ``g >= F_c``: ``a <= sigma0 |v| / F_c``
    and ``|e| <= 1 + sigma0 |z| / F_c (1 + (F_s - F_c) / (e F_c))`` (the last term bounds
    ``|v| |g'| / g`` by its maximum over v, ``(F_s - F_c) / (e F_c)``, e = Euler's number).
    Units: v [m/s], z [m], forces [N], sigma0 [N/m], sigma1 and damping [N s/m], mass [kg].
    """
    a = sigma0 * abs(v) / f_c
    e = 1.0 + sigma0 * abs(z) / f_c * (1.0 + (f_s - f_c) / (math.e * f_c))
    t = abs(a + (sigma1 * e + damping) / mass)
    d = abs(a * damping + e * sigma0) / mass
    return 0.5 * t + math.sqrt(0.25 * t * t + d)
