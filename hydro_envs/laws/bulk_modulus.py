"""Effective bulk modulus and liquid density laws (pure numba scalar kernels, SI units).

Sources (the seed papers, ``docs/references.md``):

* ``003_54985feb8193da53.txt`` eq (13): IFAS effective bulk modulus (oil + entrained air);
  eqs (15)-(19): modified IFAS (IFAS times a load-pressure shape h(P_a - P_b));
  Table 2: fitted parameters.
* ``002_af30b681d6ccfd6c.txt`` Table 1: constant beta_h = 689 MPa.

Known defect of the printed 003 Table 2 and the valid default we chose
---------------------------------------------------------------------
Table 2 prints ``lambda_1 = 1.08`` and a second ``lambda_1`` row ``0.64`` that is
``lambda_2``, with ``mu = 8.80e-6`` and ``P_Lt = 9.177e5``.  Units are not printed; we
read them as SI: mu in 1/Pa and P_Lt in Pa (mu P_Lt = 8.08, so a 9.2 bar threshold with a
~1.1 bar (1/mu) transition is plausible against P_s = 206 bar; any other unit choice makes
mu P_Lt absurdly large or small).  Writing a = mu (P_a - P_b), c = mu P_Lt, the bracket of
eq (19) is

    tanh(a + c) - tanh(a - c) = 2 sinh(2c) / (cosh(2a) + cosh(2c)),

which for c > 0 lies in (0, 2 tanh(c)] with its maximum at P_a = P_b.  Hence

    inf h = min(lambda_1, lambda_1 - 2 lambda_2 tanh(mu P_Lt)),

and the printed set gives h(0) = 1.08 - 2 * 0.64 * tanh(8.08) = -0.20: a *negative*
bulk modulus at mid stroke, which cannot be used (the chamber pressure ODE would run
backwards).  See :func:`modified_ifas_shape_is_valid`.

Chosen valid default (used in tests, recommended for configs), SI units:

    E_0 = 4.73e8 Pa, m = 9.02, alpha = 7.9e-7, kappa = 0.49, P_0 = 36.85 bar = 3.685e6 Pa
    lambda_1 = 1.08, lambda_2 = 0.32, mu = 8.80e-6 1/Pa, P_Lt = 9.177e5 Pa

Only lambda_2 differs from Table 2.  lambda_2 = 0.32 = 0.64 / 2 keeps the printed 0.64
as the *depth of the notch*: h(0) = 1.08 - 0.64 = 0.44 (the stiffness at mid stroke
drops to 41 % of the far-field 1.08 E_IFAS), which is what eq (19) would give with the
printed numbers if its tanh bracket were normalised by 1/2 (bracket in (0, 1]) -- the
most likely reading of a fitted 0.64 that must satisfy lambda_2 < lambda_1 / 2 = 0.54.
It keeps a wide margin: h > 0 for lambda_2 up to 0.54 (+69 %), so randomisation ranges
of lambda_2 must stay below 0.54 (or of lambda_1 above 0.64).

P_0 is printed as 36.85 without unit.  We read it as bar (3.685e6 Pa): the air content
alpha = 7.9e-7 is then defined at 36.85 bar and expands to ~0.12 % by volume at 1 bar
(alpha (P_0/1 bar)^(1/kappa)), a typical entrained-air level; read as Pa, the air would
be referred to a near-vacuum state and drop out entirely.  The choice only matters below
~10 bar for the air term (tank-side chambers: 36 MPa vs 474 MPa at 1 bar); at 100 bar
the readings differ by 6 % (530 vs 563 MPa) only through the oil term E_0 + m (P - P_0).
"""

from __future__ import annotations

import math

import numba

from hydro_envs.laws.elementary import tanh_one_exp


@numba.njit(cache=True)
def constant_bulk_modulus(p, e0):
    """Constant bulk modulus ``E = e0`` (pressure ignored; present for a uniform API).

    Units: p [Pa], e0 [Pa] -> [Pa].
    Source: 002 Table 1, beta_h = 689 MPa (002 eqs (5)-(6)).
    """
    return e0


@numba.njit(cache=True)
def ifas_bulk_modulus(p, e0, p0, m, alpha, kappa, p_floor):
    """IFAS effective bulk modulus of oil with entrained air, 003 eq (13).

             (1-a) (1 + m (P-P0)/E0)^(-1/m)          + a (P0/P)^(1/k)
    E(P) = -----------------------------------------------------------------------
           (1-a)/E0 (1 + m (P-P0)/E0)^(-(m+1)/m) + a/(k P0) (P0/P)^((k+1)/k)

    i.e. E = V / (-dV/dP) for a volume V/V0 = (1-a) (oil, Murnaghan-type with tangent
    modulus E0 + m (P - P0)) + a (air, polytropic exponent k), both referred to P0.
    Limits: a = 0 gives E = E0 + m (P - P0); P = P0 gives 1 / ((1-a)/E0 + a/(k P0)).

    Regularisation: the air term is singular as P -> 0 (E -> 0 and 0/0 at P = 0), so P
    is clamped to ``p_floor`` (> 0, e.g. 1e3 Pa; docs/references.md: "air-based bulk modulus models
    are singular as p -> 0, so clamp pressure before evaluating them") before evaluation.
    The oil base (1 + m (P-P0)/E0) is also floored at 1e-12 so that a P0 > E0/m
    parameterisation cannot produce NaN.

    Arguments (003 Table 2 names, SI): p = P [Pa abs], e0 = E_0 [Pa], p0 = P_0 [Pa],
    m [-], alpha [-], kappa [-], p_floor [Pa] -> E [Pa].
    Table 2 (IFAS column): E_0 = 4.7e8, P_0 = 8.7 (unit not printed), m = 7.88,
    alpha = 6.8e-7, kappa = 0.7224.
    Source: ``003_54985feb8193da53.txt`` eq (13) (IFAS, RWTH Aachen, 003 ref [24]).
    """
    pp = p
    if pp < p_floor:
        pp = p_floor
    base = 1.0 + m * (pp - p0) / e0
    if base < 1e-12:
        base = 1e-12
    r = p0 / pp
    num = (1.0 - alpha) * base ** (-1.0 / m) + alpha * r ** (1.0 / kappa)
    den = ((1.0 - alpha) / e0) * base ** (-(m + 1.0) / m) + (alpha / (kappa * p0)) * r ** ((kappa + 1.0) / kappa)
    return num / den


@numba.njit(cache=True)
def modified_ifas_shape(p_a, p_b, lambda_1, lambda_2, mu, p_lt):
    """Load-pressure shape function h(P_a, P_b) of 003 eq (19).

    h = lambda_1 - lambda_2 (tanh(mu (P_a - P_b + P_Lt)) - tanh(mu (P_a - P_b - P_Lt)))

    For mu, P_Lt, lambda_2 > 0 it has a notch of width ~2 P_Lt centred at P_a = P_b with
    minimum h(0) = lambda_1 - 2 lambda_2 tanh(mu P_Lt), and -> lambda_1 for
    |P_a - P_b| >> P_Lt.  Implemented exactly as printed (no clamp): check parameters
    with :func:`modified_ifas_shape_is_valid`.
    Units: p_a, p_b [Pa], lambda_1, lambda_2 [-], mu [1/Pa], p_lt [Pa] -> [-].
    Source: ``003_54985feb8193da53.txt`` eq (19).
    """
    d = p_a - p_b
    return lambda_1 - lambda_2 * (tanh_one_exp(mu * (d + p_lt)) - tanh_one_exp(mu * (d - p_lt)))


@numba.njit(cache=True)
def modified_ifas_shape_is_valid(lambda_1, lambda_2, mu, p_lt):
    """True iff the 003 eq (19) shape h(P_a - P_b) is > 0 for every pressure difference.

    With a = mu (P_a - P_b) and c = mu P_Lt the bracket of eq (19) equals
    2 sinh(2c) / (cosh(2a) + cosh(2c)), which ranges over (0, 2 tanh(c)] (for c > 0;
    mirrored for c < 0, identically 0 for c = 0), extremal at a = 0 and -> 0 as |a| -> inf.
    So inf h = min(lambda_1, lambda_1 - 2 lambda_2 tanh(mu P_Lt)) and h > 0 everywhere
    (bounded away from 0) iff lambda_1 > 0 and lambda_1 - 2 lambda_2 tanh(mu P_Lt) > 0.
    The printed 003 Table 2 set (1.08, 0.64, 8.8e-6, 9.177e5) gives -0.20 -> False.
    Units: lambda_1, lambda_2 [-], mu [1/Pa], p_lt [Pa] -> bool.
    Source: ``003_54985feb8193da53.txt`` eq (19), Table 2; seeds README defect list.
    """
    if not (lambda_1 > 0.0):
        return False
    return lambda_1 - 2.0 * lambda_2 * math.tanh(mu * p_lt) > 0.0


@numba.njit(cache=True)
def modified_ifas_bulk_modulus(p, p_a, p_b, e0, p0, m, alpha, kappa,
                               lambda_1, lambda_2, mu, p_lt, p_floor):
    """Modified IFAS bulk modulus of one chamber, 003 eqs (15)-(19).

    E_a = E_ai(P_a) h(P_a, P_b)   (15),  E_b = E_bi(P_b) h(P_a, P_b)   (16)

    with E_ai, E_bi the IFAS law eq (13) evaluated at the chamber's own pressure
    (eqs (17)-(18)) and h the shape of eq (19).  Pass ``p = p_a`` for chamber a and
    ``p = p_b`` for chamber b; (p_a, p_b) always in that order for h.
    Faithful to the paper: h is not clamped, so the printed Table 2 set yields a negative
    modulus near P_a = P_b -- use the valid default of this module's docstring
    (lambda_2 = 0.32) and :func:`modified_ifas_shape_is_valid`.

    Units: p, p_a, p_b [Pa abs], e0 [Pa], p0 [Pa], m, alpha, kappa, lambda_1, lambda_2 [-],
    mu [1/Pa], p_lt [Pa], p_floor [Pa] -> [Pa].
    Source: ``003_54985feb8193da53.txt`` eqs (15)-(19); regularisation (pressure floor)
    as in :func:`ifas_bulk_modulus`.
    """
    return (ifas_bulk_modulus(p, e0, p0, m, alpha, kappa, p_floor)
            * modified_ifas_shape(p_a, p_b, lambda_1, lambda_2, mu, p_lt))


@numba.njit(cache=True)
def fluid_density(p, rho0, p0, beta):
    """Density of a constant-bulk-modulus liquid ``rho = rho0 exp((p - p0) / beta)``.

    Integrates d rho / rho = dp / beta exactly (beta = const).
    Units: p [Pa], rho0 [kg/m^3] at p0 [Pa], beta [Pa] -> [kg/m^3].
    Source: definition of the bulk modulus; 002 Table 1 (rho = 847 kg/m^3,
    beta_h = 689 MPa).
    """
    return rho0 * math.exp((p - p0) / beta)
