"""Friction laws for hydraulic and pneumatic pistons (pure numba scalar kernels).

Every function here is a small pure ``@numba.njit(cache=True, error_model="numpy")`` function of float64
scalars, in SI units (m, m/s, N, N s/m, N/m, s).  Sign convention: the returned
friction force *opposes* motion, i.e. a plant writes ``m a = F_drive - F_friction``.

Sources (the seed papers, ``docs/references.md``):

* ``001_3253c61f41166c3e.txt`` eq (1): modified Dahl model (numerical smoothing of Coulomb).
* ``002_af30b681d6ccfd6c.txt`` eq (1): exponential Stribeck model with a stick branch.
* ``003_54985feb8193da53.txt`` eqs (11)-(12): Gaussian Stribeck model with ``tanh(beta v)``.
* LuGre (Canudas de Wit et al., 1995), cited as ref [30] of 003 and ref [6] of 002;
  numerics notes in ``docs/references.md`` (bristle stiffness 1e7 N/m needs RK4 steps
  <= 10 us, the exact frozen-velocity update is stable at any step).
* Karnopp stick/slip: the ``v_p = 0`` branch of 002 eq (1), widened to a velocity band
  as in Hopsan (docs/references.md, "Simulator conventions followed").

Why regularise: an exact ``sign(v)`` makes the right-hand side discontinuous, so fixed-step
RK4 drops to first order and chatters at zero velocity (docs/references.md measured chatter at
about 30x the threshold velocity for too-large steps).  ``tanh(v / v_eps)`` is smooth with
slope ``f_c / v_eps`` at zero, which sets the stiffness (docs/references.md: 1 mm/s -> |lambda| 4.4e3
1/s, 0.1 mm/s -> 4.5e4 1/s for the 002 cylinder).
"""

from __future__ import annotations

import math

import numba

from hydro_envs.laws.elementary import tanh_one_exp
from hydro_envs.libm import exp


@numba.njit(cache=True, error_model="numpy")
def tanh_sign(v, v_eps):
    """Smooth sign function ``tanh(v / v_eps)``; exact sign when ``v_eps <= 0``.

    sgn_eps(v) = tanh(v / v_eps)            if v_eps > 0
               = sign(v)  (with sign(0)=0)  otherwise

    Units: v [m/s], v_eps [m/s] -> [-].
    Source: 003 eq (12) (``tanh(beta v) -> sign(v)`` as ``beta -> inf``; here
    ``v_eps = 1 / beta``).  Regularisation: removes the discontinuity of sign(v) at
    v = 0 so that explicit integrators keep their order; the slope at 0 is 1/v_eps.
    """
    if v_eps > 0.0:
        return tanh_one_exp(v / v_eps)  # one exp instead of libm's tanh (absolute error <= 2e-16)
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return 0.0


@numba.njit(cache=True, error_model="numpy")
def coulomb_friction(v, f_c, v_eps):
    """Coulomb friction ``F = f_c * tanh_sign(v, v_eps)``.

    Units: v [m/s], f_c [N], v_eps [m/s] -> [N].
    Source: the Coulomb term of 002 eq (1) / 003 eq (11); 001 eq (1) relaxes towards it.
    Regularisation: see :func:`tanh_sign` (``v_eps <= 0`` gives the exact, discontinuous law).
    """
    return f_c * tanh_sign(v, v_eps)


@numba.njit(cache=True, error_model="numpy")
def viscous_friction(v, b):
    """Viscous friction ``F = b v``.

    Units: v [m/s], b [N s/m] -> [N].
    Source: ``F_V v_p`` of 002 eq (1), ``F_v xdot`` of 003 eq (11), ``d xdot`` of 002 eq (7).
    No regularisation needed (linear).
    """
    return b * v


@numba.njit(cache=True, error_model="numpy")
def stribeck_exponential(v, f_c, f_s, v_s, b, v_eps):
    """Exponential Stribeck friction, sliding branch of 002 eq (1).

    F = (f_c + (f_s - f_c) exp(-|v| / v_s)) * tanh_sign(v, v_eps) + b v

    Units: v [m/s], f_c (Coulomb) [N], f_s (static/breakaway) [N], v_s (Stribeck
    velocity) [m/s], b (viscous, F_V in 002) [N s/m], v_eps [m/s] -> [N].
    Source: ``002_af30b681d6ccfd6c.txt`` eq (1), "otherwise" branch (the ``v_p = 0``
    stick branch is :func:`karnopp_friction`).
    Regularisation: the paper's sign(v_p) is replaced by ``tanh(v / v_eps)`` so the
    law is continuous through v = 0 (pass ``v_eps = 0`` for the literal paper form).
    With v_eps << v_s the force rises to ~f_s within a few v_eps of zero velocity.
    """
    mag = f_c + (f_s - f_c) * exp(-abs(v) / v_s)
    return mag * tanh_sign(v, v_eps) + b * v


@numba.njit(cache=True, error_model="numpy")
def stribeck_exponential_slope_bound(v, f_c, f_s, v_s, b, v_eps):
    """Upper bound of ``|dF/dv|`` of :func:`stribeck_exponential` at velocity ``v``.

    dF/dv = b + g(v) sech^2(v / v_eps) / v_eps - (f_s - f_c) / v_s exp(-|v| / v_s) |tanh(v / v_eps)|

    (the sign's regularisation, steepest at v = 0 with ``f_s / v_eps``; the Stribeck dip,
    a negative slope of at most ``(f_s - f_c) / v_s``); the bound adds the magnitudes.
    Over all v it is at most ``b + f_s / v_eps + (f_s - f_c) / v_s``.
    Units: as :func:`stribeck_exponential` -> [N s/m]. Source: the derivative of that law.
    """
    e = exp(-abs(v) / v_s)
    g = f_c + (f_s - f_c) * e
    if v_eps > 0.0:
        x = min(abs(v) / v_eps, 350.0)
        c = math.cosh(x)
        sign_slope = g / (v_eps * c * c)
        t = math.tanh(x)
    else:
        sign_slope = 0.0
        t = 1.0
    return b + sign_slope + abs(f_s - f_c) / v_s * e * t


@numba.njit(cache=True, error_model="numpy")
def stribeck_gaussian(v, f_c, f_s, v_s, b, v_eps):
    """Gaussian Stribeck friction with tanh sign, 003 eqs (11)-(12).

    F = (f_c + (f_s - f_c) exp(-(v / v_s)^2)) * tanh(v / v_eps) + b v

    003 eq (11) reads ``(F_C + (F_s - F_C) e^{-(xdot/v_s)^2}) sign(xdot) + F_v xdot`` and
    eq (12) replaces ``sign(xdot)`` by ``tanh(beta xdot)``.  The tanh *gain* beta [s/m]
    maps onto ``v_eps = 1 / beta`` [m/s].  003 Table 2 fits beta = 7.33 s/m
    (v_eps = 0.136 m/s, a very soft sign that hides most of the v_s = 0.014 m/s Stribeck
    dip) with F_c = 573.72 N, F_s = 1254.16 N, F_v = 429.4 N s/m.

    Units: v [m/s], f_c [N], f_s [N], v_s [m/s], b [N s/m], v_eps [m/s] -> [N].
    Source: ``003_54985feb8193da53.txt`` eqs (11)-(12).
    Regularisation: the paper's own tanh; ``v_eps = 0`` gives the sign(v) form of eq (11).
    Compared with :func:`stribeck_exponential` the Gaussian dip is flat at v = 0
    (zero slope of the exponential factor) and decays faster for |v| > v_s.
    """
    r = v / v_s
    mag = f_c + (f_s - f_c) * exp(-r * r)
    return mag * tanh_sign(v, v_eps) + b * v


@numba.njit(cache=True, error_model="numpy")
def dahl_friction_rate(v, f, f_c, sigma0):
    """Time derivative of the modified Dahl friction force, 001 eq (1).

    001 eq (1):  dF/dt = gamma (F - F_c sgn(v))^2 v,  gamma = 100, F_c = 26 N.

    Written in the standard Dahl form with exponent 2 (fixed by 001, so there is no
    ``alpha`` argument):

        u     = 1 - F sgn(v) / f_c
        dF/dt = sigma0 * v * u * |u|

    For |F| <= f_c we have u in [0, 2] and u|u| = u^2, so this equals 001 eq (1)
    exactly with ``gamma = sigma0 / f_c^2`` (001: sigma0 = 100 * 26^2 = 67 600 N/m;
    gamma in 1/(N m)).  Outside the band the literal eq (1) would push F *further away*
    (its square loses the sign); ``u|u|`` instead pulls an overshoot back to +-f_c, so a
    slightly overshot numerical state is restored rather than diverging.

    Steady state at constant v != 0: F -> f_c sgn(v) (pure Coulomb, as 001 states).
    At v = 0 the rate is 0 (the force is held).

    Boundedness: the exact flow keeps |F| <= f_c for any step (see
    :func:`dahl_friction_step_exact`).  Classical RK4 with this rate keeps |F| <= f_c
    when ``dt <= f_c / (sigma0 |v|)`` (i.e. ``k |u0| dt <= 2`` with k = sigma0 |v| / f_c;
    checked numerically in tests; at 001's values that is dt <= 0.385 mm / |v|).

    Units: v [m/s], f [N], f_c [N], sigma0 [N/m] -> [N/s].
    Source: ``001_3253c61f41166c3e.txt`` eq (1) (001 ref [10] for the modified Dahl model).
    """
    if v > 0.0:
        s = 1.0
    elif v < 0.0:
        s = -1.0
    else:
        return 0.0
    u = 1.0 - f * s / f_c
    return sigma0 * v * u * abs(u)


@numba.njit(cache=True, error_model="numpy")
def dahl_friction_step_exact(f, v, f_c, sigma0, dt):
    """Exact update of the 001 eq (1) Dahl force over ``dt`` at frozen velocity ``v``.

    With u = 1 - F sgn(v)/f_c and k = sigma0 |v| / f_c, :func:`dahl_friction_rate`
    becomes du/dt = -k u|u|, whose exact solution is

        u(dt) = u0 / (1 + k |u0| dt),   F(dt) = sgn(v) f_c (1 - u(dt)).

    |u| only shrinks and never changes sign, so |F0| <= f_c implies |F| <= f_c for any
    dt >= 0 (unconditionally stable), and F -> f_c sgn(v) as dt -> inf.

    Units: f [N], v [m/s], f_c [N], sigma0 [N/m], dt [s] -> new F [N].
    Source: ``001_3253c61f41166c3e.txt`` eq (1), integrated in closed form.
    """
    if v > 0.0:
        s = 1.0
    elif v < 0.0:
        s = -1.0
    else:
        return f
    k = sigma0 * abs(v) / f_c
    u0 = 1.0 - f * s / f_c
    u = u0 / (1.0 + k * abs(u0) * dt)
    return s * f_c * (1.0 - u)


@numba.njit(cache=True, error_model="numpy")
def lugre_g(v, f_c, f_s, v_s):
    """LuGre Stribeck curve ``g(v) = f_c + (f_s - f_c) exp(-(v / v_s)^2)``.

    Units: v [m/s], f_c [N], f_s [N], v_s [m/s] -> [N]. Must stay > 0 (f_c, f_s > 0).
    Source: Canudas de Wit et al. (1995) LuGre model, cited as ref [30] in 003 (the
    AMESim friction model) and ref [6] in 002; same Gaussian shape as 003 eq (11).
    """
    r = v / v_s
    return f_c + (f_s - f_c) * exp(-r * r)


@numba.njit(cache=True, error_model="numpy")
def lugre_bristle_rate(v, z, f_c, f_s, v_s, sigma0):
    """LuGre bristle deflection rate ``dz/dt = v - sigma0 |v| z / g(v)``.

    Units: v [m/s], z [m], f_c [N], f_s [N], v_s [m/s], sigma0 [N/m] -> [m/s].
    Steady state at constant v: z = g(v) sgn(v) / sigma0.
    Stiffness: the ODE is linear in z with rate sigma0 |v| / g(v); at sigma0 = 1e7 N/m
    explicit RK4 needs steps <= ~10 us (docs/references.md) -- use
    :func:`lugre_bristle_step_exact` for fixed-step plants.
    Source: LuGre model (003 ref [30], 002 ref [6]).
    """
    return v - sigma0 * abs(v) * z / lugre_g(v, f_c, f_s, v_s)


@numba.njit(cache=True, error_model="numpy")
def lugre_friction(v, z, zdot, sigma0, sigma1, sigma2):
    """LuGre friction force ``F = sigma0 z + sigma1 zdot + sigma2 v``.

    Units: v [m/s], z [m], zdot [m/s], sigma0 [N/m], sigma1 [N s/m], sigma2 [N s/m] -> [N].
    In steady sliding zdot = 0 and F = g(v) sgn(v) + sigma2 v.
    Source: LuGre model (003 ref [30], 002 ref [6]).
    """
    return sigma0 * z + sigma1 * zdot + sigma2 * v


@numba.njit(cache=True, error_model="numpy")
def lugre_bristle_step_exact(z, v, f_c, f_s, v_s, sigma0, dt):
    """Exact LuGre bristle update over ``dt`` at frozen velocity ``v``.

    With a = sigma0 |v| / g(v) the bristle ODE dz/dt = v - a z is linear, so

        z(dt) = z_ss + (z - z_ss) exp(-a dt),   z_ss = v / a = g(v) sgn(v) / sigma0

    written as ``z exp(-a dt) + v dt * (1 - exp(-a dt)) / (a dt)`` (via expm1) so that
    it stays exact and finite as v -> 0 (then z is unchanged).  Stable and
    non-oscillating at any dt, unlike explicit RK4 which needs dt <= ~10 us at
    sigma0 = 1e7 N/m (docs/references.md).  It is exact only while v is constant over the step
    (first-order splitting error in v, no stability limit).

    Units: z [m], v [m/s], f_c [N], f_s [N], v_s [m/s], sigma0 [N/m], dt [s] -> z [m].
    Source: LuGre model (003 ref [30], 002 ref [6]); docs/references.md numerics.
    """
    a = sigma0 * abs(v) / lugre_g(v, f_c, f_s, v_s)
    x = a * dt
    if x < 1e-12:
        return z + (v - a * z) * dt
    e = exp(-x)
    phi = -math.expm1(-x) / x  # (1 - exp(-x)) / x
    return z * e + v * dt * phi


@numba.njit(cache=True, error_model="numpy")
def karnopp_friction(v, f_applied, f_c, f_s, b, dv):
    """Karnopp stick/slip friction.

    stuck   (|v| <  dv, or v == 0):  F = clip(f_applied, -f_s, f_s)
    sliding (otherwise):             F = f_c sign(v) + b v

    ``f_applied`` is the sum of all *other* forces on the body in the direction of v
    (e.g. A (p_a - p_b) - F_load); while stuck the friction balances it up to the
    breakaway force f_s, so the net force ``f_applied - F`` is zero below breakaway and
    ``f_applied - sign(f_applied) f_s`` above it.  The band ``dv`` replaces the exact
    ``v = 0`` test, which a fixed-step integrator never hits.  This pure function only
    returns the force; a plant should also hold (or damp) the residual velocity inside
    the band (Hopsan uses implicit damping).

    Units: v [m/s], f_applied [N], f_c [N], f_s [N], b [N s/m], dv [m/s] -> [N].
    Source: 002 eq (1) (stick branch ``min(|u|, F_S) sign(u)`` at v_p = 0, slide branch
    with the Stribeck term omitted), Karnopp (1985); Hopsan practice in docs/references.md.
    """
    if abs(v) < dv or v == 0.0:
        if f_applied > f_s:
            return f_s
        if f_applied < -f_s:
            return -f_s
        return f_applied
    if v > 0.0:
        return f_c + b * v
    return -f_c + b * v
