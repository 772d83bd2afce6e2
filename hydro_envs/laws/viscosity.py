"""Mineral-oil viscosity versus temperature (pure numba scalar kernels, SI units).

* ISO 3448: the ISO VG grade is the kinematic viscosity at 40 C in mm^2/s (cSt).
* ASTM D341 (Walther / Ubbelohde-Walther):  log10(log10(nu + 0.7)) = A - B log10(T),
  nu in mm^2/s, T in K, fixed by two points (40 C and 100 C).  The plain ``+0.7`` form
  is valid for nu >= ~2 mm^2/s (all ISO VG >= 10 between 0 and 120 C).
* The 100 C point comes from viscosity index VI = 100 (ASTM D2270 / ISO 2909): for a
  VI-100 oil the 40 C viscosity equals the table value H(nu_100).  We invert H by
  log-log linear interpolation through 36 nodes of the D2270 H column
  (nu_100 = 2 ... 70 mm^2/s, i.e. ISO VG 6.4 ... 1558); interpolation error against the
  full table < 0.1 %.  ISO VG 46 -> nu_100 = 6.76 mm^2/s (D2270: H(6.7) = 45.33,
  H(6.8) = 46.44; the commonly quoted ~6.8).
  Outside the table: above 1558 the D2270 formula H = 0.1684 nu^2 + 11.85 nu - 97 is
  inverted; below 6.394 the first segment is extrapolated.

Why it matters: seed 000 (``000_d7d5fd9bd6b165a2.txt``) measured a spool viscous
coefficient c proportional to oil viscosity (ISO VG 46: 3.5-4 N s/m at 40 C, 5-6 at
30 C, 7-9 at 22 C), so plants scale viscous friction with nu(T)/nu(40 C).  This law gives
nu(30 C)/nu(40 C) = 1.64 and nu(22 C)/nu(40 C) = 2.59 for VG 46.  The seed's c values
imply c ratios 5-6 / 3.5-4 = 1.25-1.71 (30 C, ours inside) and 7-9 / 3.5-4 = 1.75-2.57
(22 C, ours 0.5 % above the top, i.e. consistent with c = 9 at 22 C against c = 3.5 at
40 C; the midpoints 8/3.75 = 2.13 suggest the real oil has VI > 100 or c is not purely
proportional to nu).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_KELVIN = 273.15

# ASTM D2270 Table 1 (VI = 100 reference oils): kinematic viscosity at 100 C (nu_100) and
# the 40 C viscosity H of a VI-100 oil with that nu_100, both mm^2/s.  Subset of nodes.
_D2270_NU100 = np.array([
    2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0, 6.5, 7.0, 7.5, 8.0, 9.0, 10.0, 11.0,
    12.0, 13.0, 14.0, 15.0, 16.0, 18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 35.0, 40.0,
    45.0, 50.0, 55.0, 60.0, 65.0, 70.0])
_D2270_H = np.array([
    6.394, 9.063, 12.15, 15.66, 19.56, 23.81, 28.49, 33.34, 38.19, 43.18, 48.57, 53.98,
    59.6, 71.1, 82.87, 95.19, 108.0, 121.5, 135.4, 149.7, 164.6, 196.2, 229.5, 264.9,
    301.8, 340.5, 380.6, 421.7, 532.5, 651.8, 780.9, 919.6, 1066.0, 1222.0, 1386.0,
    1558.0])
_LOG_NU100 = np.log(_D2270_NU100)
_LOG_H = np.log(_D2270_H)


@numba.njit(cache=True)
def vi100_viscosity_at_100c(nu40_cst):
    """Kinematic viscosity at 100 C [mm^2/s] of a VI = 100 oil with ``nu40_cst`` at 40 C.

    Inverse of the ASTM D2270 H column (log-log linear interpolation, < 0.1 % error vs
    the full table; see module docstring).  Units: mm^2/s -> mm^2/s (cSt, not SI: an
    internal helper of :func:`iso_vg_kinematic_viscosity`).
    """
    n = _LOG_H.shape[0]
    if nu40_cst > _D2270_H[n - 1]:
        # invert H = 0.1684 nu^2 + 11.85 nu - 97 (D2270, nu_100 > 70)
        a = 0.1684
        b = 11.85
        c = -97.0 - nu40_cst
        return (-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
    x = math.log(nu40_cst)
    i = 0
    if x > _LOG_H[0]:
        i = n - 2
        for j in range(n - 1):
            if x <= _LOG_H[j + 1]:
                i = j
                break
    t = (x - _LOG_H[i]) / (_LOG_H[i + 1] - _LOG_H[i])
    return math.exp(_LOG_NU100[i] + t * (_LOG_NU100[i + 1] - _LOG_NU100[i]))


@numba.njit(cache=True)
def iso_vg_kinematic_viscosity(grade, temperature_c):
    """Kinematic viscosity [m^2/s] of an ISO VG ``grade`` mineral oil (VI = 100).

    nu(40 C) = grade mm^2/s exactly (ISO 3448); nu(100 C) from VI = 100 (ASTM D2270,
    :func:`vi100_viscosity_at_100c`); in between and outside, ASTM D341 Walther:

        log10(log10(nu + 0.7)) = A - B log10(T / K)

    through (313.15 K, grade) and (373.15 K, nu_100).  Valid 0-120 C (about -20-150 C
    usable).  Example: VG 46 -> 46.0 mm^2/s at 40 C, 6.76 at 100 C, 75.5 at 30 C,
    118.9 at 22 C, 584 at 0 C.
    Units: grade [mm^2/s at 40 C, i.e. the VG number], temperature_c [deg C] -> [m^2/s].
    Source: ISO 3448, ASTM D341, ASTM D2270; motivation seed 000 (c proportional to
    viscosity).
    """
    nu40 = grade
    nu100 = vi100_viscosity_at_100c(grade)
    y40 = math.log10(math.log10(nu40 + 0.7))
    y100 = math.log10(math.log10(nu100 + 0.7))
    t40 = math.log10(40.0 + _KELVIN)
    t100 = math.log10(100.0 + _KELVIN)
    b = (y40 - y100) / (t100 - t40)
    a = y40 + b * t40
    y = a - b * math.log10(temperature_c + _KELVIN)
    nu_cst = 10.0 ** (10.0 ** y) - 0.7
    return nu_cst * 1e-6


@numba.njit(cache=True)
def dynamic_viscosity(nu, rho):
    """Dynamic viscosity ``mu = nu * rho``.

    Units: nu [m^2/s], rho [kg/m^3] -> [Pa s].  (002 Table 1: rho = 847 kg/m^3.)
    """
    return nu * rho
