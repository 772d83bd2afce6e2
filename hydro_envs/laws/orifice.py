"""Orifice, valve-edge and compressible-flow laws (pure numba scalar kernels, SI units).

Sources (the seed papers, ``docs/references.md``):

* ``003_54985feb8193da53.txt`` eqs (1)-(4): underlapped 4/3 valve, ``sgt`` opening eq (3).
* ``004_f1423316a055addb.txt`` eq (2): circular port area; eqs (3)-(4): compressible
  (choked / subsonic) mass flow with critical ratio c_0.
* ISO 6358 (sonic conductance C, critical ratio b) as in Simscape's Orifice (G).
* numerics notes in ``docs/references.md``: regularised root ``q = K dp / (dp^2 + dp_cr^2)^(1/4)``
  (Modelica ``regRoot``, Hopsan ``signedSquareL``, Simscape), Hopsan valve laps
  ``max(+-xv - x_lap, 0)``, Simscape laminar pressure ratio 0.999.

Why regularise: the turbulent orifice law q ~ sign(dp) sqrt(|dp|) has infinite slope at
dp = 0.  A chamber stalled against a stop sits exactly there, and the Jacobian (and the
RK4 step limit) is set by the laminar transition pressure (docs/references.md, 002 cylinder:
dp_tr = 100 / 10 / 1 kPa -> |lambda| = 4.1e3 / 1.3e4 / 4.2e4 1/s, RK4 step <= 0.68 ms /
0.21 ms / 67 us).  The compressible laws have the same infinite slope as
p_down/p_up -> 1.
"""

from __future__ import annotations

import math

import numba

#: Default pressure ratio above which the pneumatic laws switch to a linear (laminar)
#: flow, Simscape's default "laminar flow pressure ratio" 0.999 (docs/references.md).  The linear
#: tail joins the turbulent law continuously at this ratio, so the flow is C0 with a
#: finite slope through p_down = p_up.  At 6 bar supply the laminar band is 600 Pa.
PNEUMATIC_LAMINAR_RATIO = 0.999


# --------------------------------------------------------------------------------------
# incompressible orifice
# --------------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def regularized_signed_sqrt(dp, dp_tr):
    """Regularised signed square root ``dp / (dp^2 + dp_tr^2)^(1/4)``.

    -> sign(dp) sqrt(|dp|) for |dp| >> dp_tr (relative error ~ dp_tr^2 / (4 dp^2)),
    -> dp / sqrt(dp_tr) (linear, laminar-like, slope 1/sqrt(dp_tr)) for |dp| << dp_tr.
    Odd, smooth (C-infinity for dp_tr > 0), monotone.  ``dp_tr = 0`` gives the exact
    signed root (0 at dp = 0).

    Transition pressure: Hopsan's default is 1e4 Pa; our hydraulic default is 1e5 Pa,
    because for the 002 cylinder stalled on a stop 100 kPa keeps |lambda| at 4.1e3 1/s
    (RK4 step <= 0.68 ms, compatible with a 1 kHz env step with sub-stepping) while
    10 kPa needs <= 0.21 ms (docs/references.md).  At 13.8 MPa supply the flow error at dp = 1 MPa
    is 0.25 %.

    Units: dp [Pa], dp_tr [Pa] -> [sqrt(Pa)].
    Source: Modelica ``regRoot`` / Hopsan ``signedSquareL`` (docs/references.md); the turbulent
    law it regularises is 002 eqs (3)-(4) and 003 eqs (1)-(2).
    """
    if dp == 0.0:
        return 0.0
    # (dp^2 + dp_tr^2)^(1/4) as two square roots: this sits on the hot path of every
    # hydraulic right-hand side and sqrt is several times cheaper than pow or hypot.
    # dp^2 only overflows beyond 1e154 Pa, far outside any physical pressure.
    return dp / math.sqrt(math.sqrt(dp * dp + dp_tr * dp_tr))


@numba.njit(cache=True, error_model="numpy")  # a call: compiled once, not at each of its dozen call sites
def regularized_signed_sqrt_slope_bound(dp, dp_tr):
    """Upper bound ``(dp^2 + dp_tr^2)^(-1/4)`` [Pa^-1/2] of the slope of
    :func:`regularized_signed_sqrt` at ``dp``.

    The slope is ``(dp^2/2 + dp_tr^2) / (dp^2 + dp_tr^2)^(5/4)``: equal to the bound at zero
    drop (``1/sqrt(dp_tr)``), half of it for ``|dp| >> dp_tr``; the bound falls monotonically
    with ``|dp|``. An orifice's contribution to a chamber's Jacobian is its coefficient times
    this (sub-step control of the look-ahead kernels).
    Units: dp [Pa], dp_tr [Pa] -> [Pa^-1/2].
    """
    return 1.0 / math.sqrt(math.sqrt(dp * dp + dp_tr * dp_tr))


@numba.njit(cache=True, error_model="numpy")
def orifice_flow(cd, area, dp, rho, dp_tr):
    """Turbulent orifice volume flow with a laminar core.

    Q = cd * area * sqrt(2 / rho) * regularized_signed_sqrt(dp, dp_tr)

    Units: cd [-], area [m^2], dp = p_up - p_down [Pa], rho [kg/m^3], dp_tr [Pa]
    -> Q [m^3/s] (positive from the high- to the low-pressure side).
    Source: 002 eqs (3)-(4) with K_v = C_v sqrt(2/rho) (002 Table 1: C_v = 0.6,
    rho = 847 kg/m^3), 003 eqs (1)-(2) (R = C_d w / sqrt(rho)); regularisation from
    docs/references.md (see :func:`regularized_signed_sqrt`).
    """
    return cd * area * math.sqrt(2.0 / rho) * regularized_signed_sqrt(dp, dp_tr)


@numba.njit(cache=True, error_model="numpy")
def supply_pressure_at_flow(p_s, p_down, cd, area, rho, r_line):
    """Pressure at a valve's supply port when its metering edge draws flow through a supply
    line of linear resistance ``r_line``: ``p = p_s - r_line Q`` with
    ``Q = cd area sqrt(2 (p - p_down) / rho)`` (the turbulent edge of :func:`orifice_flow`),
    solved in closed form::

        k = cd area sqrt(2 / rho),   Q = (sqrt(k^4 r^2 + 4 k^2 (p_s - p_down)) - k^2 r) / 2

    ``r_line = 0`` (a stiff supply), a closed edge or no forward drop (``p_s <= p_down``, the
    edge then feeds back into the supply) return ``p_s``.

    Units: p_s, p_down [Pa], cd [-], area [m^2], rho [kg/m^3], r_line [Pa s/m^3] -> [Pa].
    Source: a supply whose pressure falls in proportion to the drawn flow: the laminar
    (Hagen-Poiseuille) resistance ``128 mu L / (pi d^4)`` of a long supply hose, or the droop
    of a pump's pressure compensator. The servo-valve flow law (002 eqs (3)-(4)) assumes a
    constant p_s, which a real supply holds only up to its rated flow; the linear droop is
    assumed.
    """
    dp = p_s - p_down
    if r_line <= 0.0 or area <= 0.0 or dp <= 0.0:
        return p_s
    k = cd * area * math.sqrt(2.0 / rho)
    kk = k * k
    q = 0.5 * (math.sqrt(kk * kk * r_line * r_line + 4.0 * kk * dp) - kk * r_line)
    return p_s - r_line * q


@numba.njit(cache=True, error_model="numpy")
def spool_edge_opening(x_v, x_lap):
    """Opening of one metering edge of a lapped spool, Hopsan style.

    opening = max(x_v - x_lap, 0)

    x_lap > 0 is an overlap (dead band of width x_lap), x_lap < 0 an underlap (the edge
    is already open by |x_lap| at x_v = 0).  For the opposite edge pass ``-x_v``.
    Units: x_v [m], x_lap [m] -> [m] (or any consistent length / normalised unit).
    Source: Hopsan valve laps ``max(+-xv - x_lap, 0)`` (docs/references.md); equals 003 eq (3)
    with x_lap = -U (see :func:`underlap_orifice_opening`).
    """
    d = x_v - x_lap
    if d > 0.0:
        return d
    return 0.0


@numba.njit(cache=True, error_model="numpy")
def underlap_orifice_opening(x_v, u_lap):
    """Opening function ``sgt(x_v, U)`` of the underlapped valve, 003 eq (3).

    sgt(x_v, U) = 0          for x_v <= -U
                = x_v + U    for x_v >  -U

    x_v is the *normalised* spool position and U the normalised underlap (003 Table 1:
    U = 0.005, i.e. 0.5 % of full stroke; the Bosch-Rexroth 4WS.2E is quoted as "5 %
    underlap" in the text), both dimensionless; the function is linear so any
    consistent length unit also works.  No upper saturation (implemented exactly as
    printed); the valve flow of 003 eqs (1)-(2) is
    Q_a = R (sgt(x_v, U) sgn(P_s - P_a) sqrt|P_s - P_a| - sgt(-x_v, U) sgn(P_a - P_T) sqrt|P_a - P_T|)
    with R = 1.28e-7 m^3/(s sqrt(Pa)) per unit normalised opening (003 Table 1; its
    printed unit is garbled).  Continuous at x_v = -U.
    Units: x_v [-], u_lap [-] -> [-].
    Source: ``003_54985feb8193da53.txt`` eq (3).  Equals spool_edge_opening(x_v, -U).
    """
    if x_v <= -u_lap:
        return 0.0
    return x_v + u_lap


@numba.njit(cache=True, error_model="numpy")
def circular_orifice_area(x, r):
    """Area of a circular port of radius r uncovered by a straight spool edge, 004 eq (2).

    004 eq (2):  S = r^2 arccos((d - x_v)/r) - (d - x_v) sqrt(r^2 - (d - x_v)^2)
                 for d - r < x_v <= d, S = 0 for x_v <= d - r,
    where 2d is the spool shoulder width and x_v the shoulder displacement.

    Here ``x`` is the *edge travel past the near rim of the port* (x = x_v - (d - r) in
    004's notation), so with h = r - x (distance from the port centre to the edge):

        S = 0                                    x <= 0
        S = r^2 acos(h/r) - h sqrt(r^2 - h^2)    0 < x < 2r   (circular segment)
        S = pi r^2                               x >= 2r

    004 prints only the first half (x <= r, i.e. x_v <= d, S <= pi r^2 / 2); the same
    expression continues exactly to the full circle for r < x < 2r (acos(-y) = pi -
    acos(y)), which we use, then saturates.  Continuous, monotone, S(r) = pi r^2 / 2.
    Units: x [m], r [m] -> [m^2].
    Source: ``004_f1423316a055addb.txt`` eq (2) (Fig. 8 geometry).
    """
    if x <= 0.0:
        return 0.0
    if x >= 2.0 * r:
        return math.pi * r * r
    h = r - x
    return r * r * math.acos(h / r) - h * math.sqrt(r * r - h * h)


# --------------------------------------------------------------------------------------
# compressible orifice
# --------------------------------------------------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def _nozzle_flow_function(ratio, kappa, ratio_lam):
    """Dimensionless flow function psi(p_down/p_up) of 004 eqs (3)-(4) with laminar tail."""
    crit = (2.0 / (kappa + 1.0)) ** (kappa / (kappa - 1.0))
    if ratio <= crit:
        # choked: sqrt(2k/(k+1) (2/(k+1))^(2/(k-1)))
        return math.sqrt(2.0 * kappa / (kappa + 1.0) * (2.0 / (kappa + 1.0)) ** (2.0 / (kappa - 1.0)))
    if ratio <= ratio_lam:
        t = ratio ** (2.0 / kappa) - ratio ** ((kappa + 1.0) / kappa)
        if t < 0.0:
            t = 0.0
        return math.sqrt(2.0 * kappa / (kappa - 1.0) * t)
    t = ratio_lam ** (2.0 / kappa) - ratio_lam ** ((kappa + 1.0) / kappa)
    psi_lam = math.sqrt(2.0 * kappa / (kappa - 1.0) * t)
    return psi_lam * (1.0 - ratio) / (1.0 - ratio_lam)


@numba.njit(cache=True, error_model="numpy")
def pneumatic_critical_ratio(kappa):
    """Critical pressure ratio ``c_0 = (2/(kappa+1))^(kappa/(kappa-1))`` (004, after eq (4)).

    004 prints ``c_0 = [(kappa+1)/2]^(kappa/(1-kappa))``, the same number
    (0.5283 for kappa = 1.4).  Units: kappa [-] -> [-].
    """
    return (2.0 / (kappa + 1.0)) ** (kappa / (kappa - 1.0))


@numba.njit(cache=True, error_model="numpy")
def _flow_direction(p_a, p_b):
    """(sign, upstream pressure, downstream/upstream ratio in [0, 1]) for flow a -> b.

    Compressible flow always runs from the higher to the lower pressure: sign +1 for a -> b.
    """
    if p_a >= p_b:
        s, pu, pd = 1.0, p_a, p_b
    else:
        s, pu, pd = -1.0, p_b, p_a
    ratio = pd / pu if pu > 0.0 else 0.0
    return s, pu, max(ratio, 0.0)


@numba.njit(cache=True, error_model="numpy")
def pneumatic_mass_flow_laminar(cd, area, p_up, p_down, t_up, kappa, r_gas, ratio_lam):
    """004 eqs (3)-(4) compressible orifice mass flow with an explicit laminar ratio.

    See :func:`pneumatic_mass_flow`; ``ratio_lam`` in (c_0, 1) is the pressure ratio
    above which the flow is linear in (p_up - p_down).
    """
    s, pu, ratio = _flow_direction(p_up, p_down)
    if pu <= 0.0:
        return 0.0
    psi = _nozzle_flow_function(ratio, kappa, ratio_lam)
    return s * cd * area * pu / math.sqrt(r_gas * t_up) * psi


@numba.njit(cache=True, error_model="numpy")
def pneumatic_mass_flow(cd, area, p_up, p_down, t_up, kappa, r_gas):
    """Compressible (isentropic nozzle) orifice mass flow, 004 eqs (3)-(4).

    With r = p_down / p_up and c_0 = (2/(kappa+1))^(kappa/(kappa-1)):

      subsonic (r > c_0):  m = cd A p_up / sqrt(R T_up) sqrt(2k/(k-1) (r^(2/k) - r^((k+1)/k)))
      choked  (r <= c_0):  m = cd A p_up / sqrt(R T_up) sqrt(2k/(k+1) (2/(k+1))^(2/(k-1)))

    The two branches are equal at r = c_0 (continuous), and the choked flow does not
    depend on p_down.  Hand check (air, k = 1.4, R = 287): choked
    m = 0.6847 cd A p_up / sqrt(287 T) = 0.0404 cd A p_up / sqrt(T).

    Interpretation of the garbled extraction: 004 eq (3) closes the square root before
    the bracket and eq (4) writes p_b/(R T_b) instead of p_b/sqrt(R T_b); we use the
    standard, dimensionally consistent form above (sqrt over the whole bracket,
    p/sqrt(R T)), which is the only one continuous at c_0.

    Reverse flow: if p_down > p_up the roles swap and the flow is negative
    (antisymmetric: m(a, b) = -m(b, a)).  ``t_up`` is used as given: the caller must
    pass the temperature of the side the gas actually comes from (the higher-pressure
    side), e.g. T_s for supply -> chamber and T_chamber for chamber -> exhaust.

    Regularisation: for r > PNEUMATIC_LAMINAR_RATIO = 0.999 (Simscape's default laminar
    pressure ratio) the flow is continued linearly to zero at r = 1,
    m = m(0.999) (1 - r) / (1 - 0.999).  Since m(0.999) is proportional to p_up this is
    m = K (p_up - p_down) with one constant K on both sides of p_up = p_down, so the flow
    is continuous with a finite slope (about 44.7 cd A / sqrt(R T) for kappa = 1.4)
    instead of the infinite slope of the sqrt law (which would make a near-balanced
    chamber arbitrarily stiff).  Use :func:`pneumatic_mass_flow_laminar` to change it.

    Units: cd [-], area [m^2], p_up, p_down [Pa abs], t_up [K], kappa [-] (> 1; air 1.4),
    r_gas [J/(kg K)] (air 287) -> [kg/s].
    Source: ``004_f1423316a055addb.txt`` eqs (3)-(4) and c_0 below them.
    """
    return pneumatic_mass_flow_laminar(cd, area, p_up, p_down, t_up, kappa, r_gas,
                                       PNEUMATIC_LAMINAR_RATIO)


@numba.njit(cache=True, error_model="numpy")
def iso6358_mass_flow_laminar(c_sonic, b_crit, p_up, p_down, t_up, t_ref, rho_ref, ratio_lam):
    """ISO 6358 mass flow with an explicit laminar ratio (see :func:`iso6358_mass_flow`)."""
    s, pu, ratio = _flow_direction(p_up, p_down)
    if pu <= 0.0:
        return 0.0
    m_choked = c_sonic * rho_ref * pu * math.sqrt(t_ref / t_up)
    if ratio <= b_crit:
        return s * m_choked
    if ratio <= ratio_lam:
        y = (ratio - b_crit) / (1.0 - b_crit)
        return s * m_choked * math.sqrt(1.0 - y * y)
    y = (ratio_lam - b_crit) / (1.0 - b_crit)
    return s * m_choked * math.sqrt(1.0 - y * y) * (1.0 - ratio) / (1.0 - ratio_lam)


@numba.njit(cache=True, error_model="numpy")
def iso6358_mass_flow(c_sonic, b_crit, p_up, p_down, t_up, t_ref, rho_ref):
    """ISO 6358 pneumatic component flow (sonic conductance C, critical ratio b).

      choked   (r <= b):        m = C rho_ref p_up sqrt(T_ref / T_up)
      subsonic (b < r <= r_l):  m = C rho_ref p_up sqrt(T_ref / T_up) sqrt(1 - ((r - b)/(1 - b))^2)
      laminar  (r > r_l):       m = m(r_l) (1 - r) / (1 - r_l),  r_l = 0.999

    r = p_down / p_up.  The laminar tail (Simscape Orifice (G) form, laminar pressure
    ratio 0.999) makes the flow continuous with a finite slope at r = 1, where the
    elliptic law has an infinite one; as in :func:`pneumatic_mass_flow` it equals
    K (p_up - p_down) on both sides.  Reverse flow is antisymmetric; ``t_up`` is the
    temperature of the side the gas comes from (caller's choice).  Requires b < 0.999.

    ISO 6358 reference conditions (ANR): T_ref = 293.15 K, rho_ref = 1.185 kg/m^3.
    Units: c_sonic [m^3/(s Pa)], b_crit [-], p_up, p_down [Pa abs], t_up [K], t_ref [K],
    rho_ref [kg/m^3] -> [kg/s].
    Source: ISO 6358-1 / Simscape (docs/references.md "Pneumatics"); an alternative
    parameterisation of the 004 valve (FESTO MPYE-5) flow.
    """
    return iso6358_mass_flow_laminar(c_sonic, b_crit, p_up, p_down, t_up, t_ref, rho_ref,
                                     PNEUMATIC_LAMINAR_RATIO)
