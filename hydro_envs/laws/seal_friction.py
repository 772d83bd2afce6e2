r"""Dynamic seal friction: one bristle-model family whose steady state is the seed's Stribeck curve.

Every plant with a sliding seal (servo cylinder 002, force actuator 001, shaking table 003,
rodless cylinder 004, load-sensing actuator) computes its friction with these functions. They
are pure numba scalar kernels in SI units (m, m/s, N, N/m, N s/m). Sign convention as in
:mod:`hydro_envs.laws.friction`: the force *opposes* motion, ``m a = F_drive - F``.

The family (bristle deflection ``z`` [m], velocity ``v`` [m/s])::

    u      = 1 - sigma0 z sgn(v) / g(v)
    dz/dt  = v u |u|^(n - 1)                                  (n = 1: LuGre; n = 2: 001 eq (1))
    F      = sigma0 z + sigma1(v) dz/dt + sigma2 v
    sigma1(v) = sigma1 exp(-(v / v_d)^2)

* ``g(v) > 0`` is the steady-state level: at constant ``v != 0`` the state settles at
  ``z = g(v) sgn(v) / sigma0`` and ``F = g(v) sgn(v) + sigma2 v``, i.e. exactly the seed's
  static law with the discontinuous sign: 002 eq (1) and 004 Table 2 with the exponential curve
  (:func:`stribeck_curve_exponential`), 003 eq (11) with the Gaussian one
  (:func:`stribeck_curve_gaussian`), 001 eq (1) with a constant level.
* ``n = 1`` is the LuGre model (Canudas de Wit, Olsson, Astrom, Lischinsky 1995, IEEE TAC 40(3);
  ref [30] of 003, ref [6] of 002). ``n = 2`` with ``sigma1 = sigma2 = 0`` and ``g = F_c`` is the
  modified Dahl model of 001 eq (1), ``dF/dt = gamma (F - F_c sgn v)^2 v`` with ``F = sigma0 z``
  and ``gamma = sigma0 / F_c^2`` (:func:`hydro_envs.laws.friction.dahl_friction_rate` is the
  same law written for the force).
* Stick: at ``v = 0`` the bristle rate is zero, so a body at rest under a net force ``f`` below
  the breakaway level ``g(0)`` deflects the bristles to ``z = f / sigma0`` and holds there (a
  spring of stiffness ``sigma0``); above it the bristles yield and the body slides. The
  deflection at breakaway, ``g(0) / sigma0``, is the pre-sliding displacement.
* Micro-damping ``sigma1`` damps the pre-sliding oscillation of the body on its bristles. It
  fades with speed (``v_d``, here the Stribeck velocity), as Canudas de Wit et al. (1995) propose
  so that the model stays dissipative: the power the friction takes, less the rate of the
  energy ``sigma0 z^2 / 2`` the bristles store, is

      D = F v - sigma0 z dz/dt = |v| (g w^2 + sigma1(v) |v| (1 - w)) + sigma2 v^2,   w = sigma0 z sgn(v) / g

  (n = 1), which is >= 0 for every ``w`` when ``sigma1(v) |v| <= 4 g(v)``; with the fading
  ``sigma1(v)`` that holds at every speed when ``sigma1 v_d / sqrt(2 e) <= 4 min g``
  (:func:`micro_damping_is_dissipative`). With a constant ``sigma1`` it fails above
  ``|v| = 4 g / sigma1``, right after a breakaway from ``F_s`` (``w = F_s/F_c > 1``). For n = 2
  (``sigma1 = 0``) ``D = |v| g w (1 - u|u|) + sigma2 v^2 >= 0`` for every ``w``.
* A seal without dry friction (``g <= 0``, e.g. the Coulomb and static levels set to zero to
  measure what dry friction costs) leaves the viscous term only: ``F = sigma2 v``, ``dz/dt = 0``.

Quasi-static limit at speed (``rate_cap``): the bristles relax towards their steady deflection
at ``a = sigma0 |v| |u|^(n-1) n / g`` -- 1/(20 us) for a hydraulic seal at 1 m/s -- far faster than
any fixed step a plant can afford, while the friction they produce is then the static curve. With
``rate_cap > 0`` the law takes relaxation faster than ``rate_cap`` as instantaneous, the singular-
perturbation limit of LuGre: with ``eps = min(1, rate_cap / a)``::

    dz/dt = eps v u |u|^(n-1)
    F     = eps sigma0 z + (1 - eps) g(v) sgn(v) + sigma1(v) dz/dt + sigma2 v

Below ``|v| = rate_cap g / sigma0`` (n = 1) ``eps = 1``: the law is LuGre exactly -- stick,
pre-sliding, breakaway, the Stribeck dip and every reversal. Above it the bristle force blends
into the static curve it relaxes to, with the relaxation slowed to ``rate_cap``. The steady state
is unchanged (``z = g sgn(v) / sigma0`` gives ``F = g sgn(v) + sigma2 v`` for every eps), and the
law stays dissipative for every ``eps`` in [0, 1]:

    D = |v| (g (eps w^2 + 1 - eps) + eps sigma1(v) |v| (1 - w)) + sigma2 v^2      (n = 1)

(>= 0 under the same micro-damping condition; n = 2: ``|v| g (eps w (1 - u|u|) + 1 - eps)``).
The stiffest rate the law then has is about ``rate_cap`` at speed and the body's pre-sliding
oscillation on its bristles at rest, ``sqrt(sigma0 / m)``; :func:`bristle_stiffness_bound` bounds
both over the state space, so a plant sizes its fixed sub-step for them and needs no local
refinement. ``rate_cap <= 0`` is LuGre without the limit (a plant must then resolve ``a`` itself,
as the rodless cylinder's refinement does).
"""

from __future__ import annotations

import math

import numba

from hydro_envs.jit import as_python
from hydro_envs.libm import exp

__all__ = [
    "stribeck_curve_exponential",
    "stribeck_curve_gaussian",
    "bristle_rate",
    "micro_damping",
    "quasi_static_weight",
    "seal_friction",
    "bristle_dissipation",
    "bristle_block_rate_bound",
    "bristle_stiffness_bound",
    "stribeck_slope_ratio_bound",
    "micro_damping_is_dissipative",
    "dissipative_fade_velocity",
    "presliding_displacement",
    "critical_micro_damping",
]


#: exponent beyond which a fading term ``exp(-x)`` of the law is left out (exp(-40) = 4e-18: the
#: term is then below the rounding of the level it is added to)
FADE_CUTOFF = 40.0


@numba.njit(cache=True, error_model="numpy")
def stribeck_curve_exponential(v, f_c, f_s, v_s):
    """Exponential Stribeck level ``g(v) = f_c + (f_s - f_c) exp(-|v| / v_s)`` [N].

    Units: v [m/s], f_c (Coulomb) [N], f_s (static) [N], v_s (Stribeck velocity, > 0) [m/s].
    Source: ``002_af30b681d6ccfd6c.txt`` eq (1) (sliding branch, without the sign);
    ``004_f1423316a055addb.txt`` sec. 3.1 / Table 2 (the tangent from F_s meets F_c at v_s).
    """
    return f_c + (f_s - f_c) * exp(-abs(v) / v_s)


@numba.njit(cache=True, error_model="numpy")
def stribeck_curve_gaussian(v, f_c, f_s, v_s):
    """Gaussian Stribeck level ``g(v) = f_c + (f_s - f_c) exp(-(v / v_s)^2)`` [N].

    Units: as :func:`stribeck_curve_exponential`.
    Source: ``003_54985feb8193da53.txt`` eq (11) (without the sign); the LuGre paper's curve.
    """
    r = v / v_s
    return f_c + (f_s - f_c) * exp(-r * r)


@numba.njit(cache=True, error_model="numpy", inline="always")
def bristle_rate(v, z, g, sigma0, exponent):
    """Bristle deflection rate ``dz/dt = v u |u|^(n-1)``, ``u = 1 - sigma0 z sgn(v) / g`` [m/s].

    ``exponent`` n is 1 (LuGre: ``v - sigma0 |v| z / g``) or 2 (001 eq (1)). Zero at ``v = 0``
    (the bristles hold) and for ``g <= 0`` (no dry friction).
    Units: v [m/s], z [m], g [N], sigma0 [N/m] -> [m/s].
    """
    if v == 0.0 or not g > 0.0:
        return 0.0
    s = 1.0 if v > 0.0 else -1.0
    u = 1.0 - sigma0 * z * s / g
    if exponent == 2:
        return v * u * abs(u)
    return v * u


@numba.njit(cache=True, error_model="numpy", inline="always")
def micro_damping(v, sigma1, v_d):
    """Velocity-dependent micro-damping ``sigma1 exp(-(v / v_d)^2)`` [N s/m] (Canudas de Wit et
    al. 1995; keeps the law dissipative, see the module docstring). ``v_d <= 0``: constant."""
    if not v_d > 0.0:
        return sigma1
    r = v / v_d
    return sigma1 * exp(-r * r)


@numba.njit(cache=True, error_model="numpy", inline="always")
def quasi_static_weight(v, z, g, sigma0, exponent, rate_cap):
    """``eps = min(1, rate_cap / a)`` with the bristle relaxation rate ``a`` (n = 1:
    ``sigma0 |v| / g``; n = 2: ``2 sigma0 |v| |u| / g``): 1 where the law is LuGre (or Dahl),
    below 1 where the relaxation is taken as instantaneous (module docstring). 1 for
    ``rate_cap <= 0``, ``v = 0`` or ``g <= 0``."""
    if not rate_cap > 0.0 or v == 0.0 or not g > 0.0:
        return 1.0
    a = sigma0 * abs(v) / g
    if exponent == 2:
        s = 1.0 if v > 0.0 else -1.0
        a *= 2.0 * abs(1.0 - sigma0 * z * s / g)
    return 1.0 if a <= rate_cap else rate_cap / a


@numba.njit(cache=True, error_model="numpy", inline="always")
def seal_friction(v, z, g, sigma0, sigma1, v_d, sigma2, exponent, rate_cap):
    """``(F, dz/dt)``: friction force [N] and bristle rate [m/s] of the family.

    ``F = eps sigma0 z + (1 - eps) g sgn(v) + sigma1(v) dz/dt + sigma2 v``, ``dz/dt = eps``
    :func:`bristle_rate`, with :func:`micro_damping` and the quasi-static weight ``eps``
    (:func:`quasi_static_weight`; 1, i.e. plain LuGre or Dahl, for ``rate_cap <= 0``); for
    ``g <= 0`` (no dry friction) ``(sigma2 v, 0)``. Written out once: those functions composed,
    the fading factor ``exp(-(v/v_d)^2)`` left out beyond :data:`FADE_CUTOFF` (below 4e-18,
    under the rounding of ``F``).
    Units: v [m/s], z [m], g [N], sigma0 [N/m], sigma1 and sigma2 [N s/m], v_d [m/s],
    rate_cap [1/s].
    """
    if not g > 0.0:
        return sigma2 * v, 0.0
    f = sigma0 * z
    if v == 0.0:  # the bristles hold: a spring, eps = 1, dz/dt = 0
        return f, 0.0
    s = 1.0 if v > 0.0 else -1.0
    k = sigma0 / g  # the one division
    u = 1.0 - k * z * s
    av = abs(v)
    if exponent == 2:
        dz = v * u * abs(u)
        a = 2.0 * (k * av) * abs(u)
    else:
        dz = v * u
        a = k * av
    if rate_cap > 0.0 and a > rate_cap:
        eps = rate_cap / a
        dz *= eps
        f = eps * f + (1.0 - eps) * g * s
    if sigma1 != 0.0:
        if v_d > 0.0:
            r = v / v_d
            r2 = r * r
            if r2 < FADE_CUTOFF:
                f += sigma1 * exp(-r2) * dz
        else:
            f += sigma1 * dz
    return f + sigma2 * v, dz


@numba.njit(cache=True, error_model="numpy", inline="always")
def bristle_dissipation(v, z, force, dz, sigma0):
    """Power the friction dissipates [W]: ``F v`` less the rate ``sigma0 z dz/dt`` of the energy
    ``sigma0 z^2 / 2`` the bristles store (>= 0 for the family, module docstring)."""
    return force * v - sigma0 * z * dz


@numba.njit(cache=True, error_model="numpy", inline="always")
def bristle_block_rate_bound(v, z, g, slope_ratio, sigma0, sigma1, v_d, damping, mass, exponent, rate_cap):
    """Upper bound [1/s] of the eigenvalue magnitudes of the (velocity, bristle) block of a body
    of ``mass`` [kg] with this friction, at velocity ``v`` and deflection ``z``.

    ``g`` [N] is a lower bound of the level near ``v`` (``g <= 0``: no bristle block; the
    viscous and other damping ``damping / mass`` alone), ``slope_ratio`` an upper bound of
    ``|v g'(v)| / g`` (:func:`stribeck_slope_ratio_bound`), ``damping`` [N s/m] every other damping
    on the body (viscous sigma2, a stop). With ``a = -d(dz/dt)/dz``, ``e = d(dz/dt)/dv``, the block
    ``[[-(sigma1' dz/dt + sigma1(v) e + c)/M, -(sigma0 - sigma1(v) a)/M], [e, -a]]`` has trace
    ``-T`` with ``T = a + (|sigma1' dz/dt| + sigma1(v)|e| + c)/M`` and determinant of magnitude at
    most ``D = (a (|sigma1' dz/dt| + c) + |e| sigma0) / M``, so every eigenvalue has
    ``|lambda| <= T/2 + sqrt(T^2/4 + D)``. For n = 1: ``a = sigma0 |v| / g``,
    ``|e| <= |u| + sigma0 |z| slope_ratio / g``; for n = 2: ``a = 2 sigma0 |v| |u| / g``,
    ``|e| <= u^2 + 2 |u| sigma0 |z| slope_ratio / g``, with ``|u| <= 1 + sigma0 |z| / g``. Where the
    quasi-static weight ``eps = rate_cap / a < 1`` acts, ``a`` and the bristle force's stiffness
    scale by eps, ``e`` becomes at most ``eps (|e| + n |u|)`` and ``d eps / dv`` adds at most
    ``n eps g |u| (1 + slope_ratio) / |v|`` to the velocity damping.
    Units: v [m/s], z [m], g [N], sigma0 [N/m], sigma1 and damping [N s/m], v_d [m/s], mass [kg],
    rate_cap [1/s].
    """
    if not g > 0.0:
        return damping / mass
    q = sigma0 * abs(z) / g
    u = 1.0 + q
    av = abs(v)
    s1 = micro_damping(v, sigma1, v_d)
    if exponent == 2:
        a = 2.0 * sigma0 * av * u / g
        e = u * u + 2.0 * u * q * slope_ratio
        zd = av * u * u
    else:
        a = sigma0 * av / g
        e = u + q * slope_ratio
        zd = av * u
    k = sigma0
    c = damping
    if rate_cap > 0.0 and a > rate_cap:
        eps = rate_cap / a
        a *= eps
        e = eps * (e + u * (2.0 if exponent == 2 else 1.0))
        zd *= eps
        k *= eps
        c += eps * g * u / av * (1.0 + slope_ratio) * (2.0 if exponent == 2 else 1.0)
    s1p = 0.0
    if v_d > 0.0:
        r = v / v_d
        s1p = 2.0 * sigma1 * abs(r) / v_d * exp(-r * r) * zd
    t = a + (s1p + s1 * e + c) / mass
    d = (a * (s1p + c) + e * k) / mass
    return 0.5 * t + math.sqrt(0.25 * t * t + d)


def bristle_stiffness_bound(g_min: float, g_max: float, slope_ratio: float, sigma0: float, sigma1: float,
                            v_d: float, damping: float, mass: float, exponent: int, rate_cap: float,
                            v_max: float) -> float:
    """Largest :func:`bristle_block_rate_bound` [1/s] over speeds 0..``v_max`` (a grid of 0 and 400
    log-spaced speeds from 1e-6 ``v_max``) at the deflection bound ``g_max / sigma0`` and the lowest
    level ``g_min``: the friction's stiffness mode over the whole state space, for a plant's
    ``stiffness_modes``. Without a ``rate_cap`` it grows with ``v_max`` like ``sigma0 v_max / g_min``.
    ``g_max <= 0`` (no dry friction): ``damping / mass``. Python (parameter analysis)."""
    if not g_max > 0.0:
        return damping / mass
    return float(_bristle_bound_over_speeds(g_min, g_max / sigma0, slope_ratio, sigma0, sigma1, v_d, damping, mass,
                                            int(exponent), rate_cap, v_max))


def _bristle_bound_over_speeds(g_min, z, slope_ratio, sigma0, sigma1, v_d, damping, mass, exponent, rate_cap, v_max):
    """:func:`bristle_block_rate_bound` at 0 and 400 log-spaced speeds from 1e-6 ``v_max``: the largest.
    Python (once per parameter set; compiled, it cost a cold env's make 0.9 s)."""
    bound = as_python(bristle_block_rate_bound)
    out = bound(0.0, z, g_min, slope_ratio, sigma0, sigma1, v_d, damping, mass, exponent, rate_cap)
    for i in range(400):
        v = v_max * 10.0 ** (-6.0 + 6.0 * i / 399.0)
        out = max(out, bound(v, z, g_min, slope_ratio, sigma0, sigma1, v_d, damping, mass, exponent, rate_cap))
    return out


def stribeck_slope_ratio_bound(f_c: float, f_s: float, shape: str) -> float:
    """Upper bound of ``|v g'(v)| / g(v)`` over all v for a Stribeck level with ``f_s >= f_c > 0``:
    ``(f_s - f_c) / (e f_c)`` for the exponential curve, ``2 (f_s - f_c) / (e f_c)`` for the
    Gaussian one, 0 for a constant level (``shape`` in ``exponential``, ``gaussian``,
    ``constant``); for ``f_c <= 0`` with ``f_s > 0``, the bound at the level's floor ``f_s``
    times ``exp(-|v|/v_s)`` is unbounded in ratio, so ``inf`` is returned (size such a plant by
    its worst case). Python (parameter analysis)."""
    if shape == "constant" or f_s <= f_c:
        return 0.0
    if not f_c > 0.0:
        return math.inf
    k = {"exponential": 1.0, "gaussian": 2.0}[shape]
    return k * (f_s - f_c) / (math.e * f_c)


def micro_damping_is_dissipative(sigma1: float, v_d: float, g_min: float) -> bool:
    """Whether ``sigma1(v) |v| <= 4 g_min`` at every speed (module docstring): ``sigma1 v_d /
    sqrt(2 e) <= 4 g_min`` for a fading micro-damping (``v_d > 0``); a constant one (``v_d <= 0``)
    is dissipative at all speeds only when ``sigma1 = 0``."""
    if sigma1 <= 0.0:
        return True
    if not v_d > 0.0:
        return False
    return sigma1 * v_d / math.sqrt(2.0 * math.e) <= 4.0 * g_min


def dissipative_fade_velocity(sigma1: float, v_s: float, g_min: float, margin: float = 0.9) -> float:
    """Fading velocity ``v_d`` [m/s] of the micro-damping: the Stribeck velocity ``v_s``, or less
    where that would break dissipativity, ``margin * 4 sqrt(2 e) g_min / sigma1`` (module
    docstring: ``sigma1 v_d / sqrt(2 e) <= 4 g_min``). ``sigma1 <= 0``: ``v_s``; ``g_min <= 0``
    with ``sigma1 > 0``: 0 (a constant 0 damping at speed). Python (parameter analysis)."""
    if sigma1 <= 0.0:
        return v_s
    return max(0.0, min(v_s, margin * 4.0 * math.sqrt(2.0 * math.e) * g_min / sigma1))


def presliding_displacement(f_breakaway: float, sigma0: float) -> float:
    """Bristle deflection at breakaway ``f_breakaway / sigma0`` [m] (the pre-sliding displacement)."""
    return f_breakaway / sigma0


def critical_micro_damping(sigma0: float, mass: float) -> float:
    """``2 sqrt(sigma0 m)`` [N s/m]: the micro-damping that damps the body's pre-sliding
    oscillation on its bristles critically (cf. Astrom and Canudas de Wit 2008, IEEE CSM 28(6),
    on choosing sigma1 from the modal damping of that oscillation)."""
    return 2.0 * math.sqrt(sigma0 * mass)
