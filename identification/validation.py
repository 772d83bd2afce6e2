"""Validation rows that run a seed's identification procedure on a plant model (entry point of
``hydro validate``, group ``hydro_envs.validation``).

Seed 004 sec. 4.2 identifies the rodless cylinder's open-loop model in closed loop: a
proportional position loop with an M-sequence added to the controller output, and an ARX(3)
fit from that input to the slider position, eq (32). The rows below run the same procedure on
the nominal model (:func:`hydro_envs.plants.rodless_cylinder.experiments.closed_loop_m_sequence`,
:func:`identification.arx.fit_arx`) and compare the identified poles with eq (32)'s:

* the pole near ``z = 1`` (the slider's integrator);
* the damping ratio of the other two poles, ``-(ln z1 + ln z2) / (2 sqrt(ln z1 ln z2))``,
  which is ``-ln|z| / |ln z|`` for a complex pair, ``(a + b) / (2 sqrt(ab))`` for real poles
  ``exp(-a T), exp(-b T)``, and needs no sample time (004 does not print it).

The gain per sample depends on the sample time, so it is not compared. The damping row's source
gives it at three sample times, and the sample time at which the model has eq (32)'s gain
(:func:`gain_matched_sample_time`). At that sample time, eq (32)'s pair is read as a
continuous mode: its frequency, and the viscous damping that would give its damping ratio.
"""

from __future__ import annotations

import cmath
import dataclasses
import math

import numpy as np

from hydro_envs.plants.rodless_cylinder.experiments import closed_loop_m_sequence
from hydro_envs.plants.rodless_cylinder.model import linearize_mid_stroke
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.validation import damping_with_viscous_friction
from hydro_envs.validation import ValidationRow
from identification.arx import SEED_004_EQ32, fit_arx

__all__ = ["rows", "pole_pair_damping", "rodless_eq32_poles", "gain_matched_sample_time"]

#: 004 sec. 4.2 on the model: sample time [s] (eq (32)'s is not printed), P gain [V/m],
#: M-sequence amplitude [V], position noise [m] (the grating ruler's resolution order)
EQ32_DT = 0.01
EQ32_KP = 50.0
EQ32_AMPLITUDE = 0.3
EQ32_NOISE = 5e-6
#: a small M-sequence amplitude [V]: the piston's travel stays within the bristles' pre-sliding
#: deflection
SMALL_AMPLITUDE = 0.05
#: a moving mass [kg] near the one at which the linear model (eqs (19)-(24)) with Table 2's
#: viscous friction has eq (32)'s damping (about 21 kg)
HEAVY_MASS = 20.0
#: sample times [s] at which the procedure's gain per sample is compared with eq (32)'s
GAIN_SAMPLE_TIMES = (0.004, 0.005, 0.0065, 0.008, 0.01)
#: parameter overrides that remove the seal friction (Table 2 curve, LuGre bristles)
FRICTIONLESS = {"static_friction": 0.0, "coulomb_friction": 0.0, "viscous_friction": 0.0,
                "bristle_stiffness": 0.0, "bristle_damping": 0.0}


def pole_pair_damping(z1: complex, z2: complex) -> float:
    """Damping ratio of the continuous pole pair that maps to the discrete poles ``z1, z2``
    (``s = ln z / T``, any T): ``-(s1 + s2) / (2 sqrt(s1 s2))``. NaN when a pole has no
    continuous counterpart (on or left of ``z = 0`` on the real axis) or the pair is neither
    real nor conjugate."""
    zs = (complex(z1), complex(z2))
    if any(abs(z.imag) <= 1e-12 * max(abs(z), 1.0) and z.real <= 0.0 for z in zs):
        return math.nan
    s1, s2 = (cmath.log(z) for z in zs)
    prod = s1 * s2
    if abs(prod.imag) > 1e-9 * abs(prod) or prod.real <= 0.0:
        return math.nan
    return float(-(s1 + s2).real / (2.0 * math.sqrt(prod.real)))


def _split(poles: np.ndarray) -> tuple[complex, complex, complex]:
    """(pole nearest z = 1, the other two)."""
    i = int(np.argmin(np.abs(poles - 1.0)))
    rest = np.delete(poles, i)
    return complex(poles[i]), complex(rest[0]), complex(rest[1])


def rodless_eq32_poles(params: RodlessCylinderParams | None = None, *, dt: float = EQ32_DT,
                       amplitude: float = EQ32_AMPLITUDE, kp: float = EQ32_KP,
                       friction_compensation: bool = False) -> dict:
    """The 004 sec. 4.2 procedure on the rodless model (sample time ``dt`` [s], M-sequence
    ``amplitude`` [V], P gain ``kp`` [V/m]): poles, damping of the non-integrator
    pair and gain per sample [mm/V] of the ARX(3, 3, 1) fit (least squares, position in mm,
    command about its centre), the integrator pole's standard error, the peak-to-peak travel
    [m], guard clamps and whether the valve command saturated."""
    p = params if params is not None else RodlessCylinderParams()
    d = closed_loop_m_sequence(p, dt=dt, kp=kp, amplitude=amplitude,
                               position_noise_std=EQ32_NOISE, seed=0, friction_compensation=friction_compensation)
    y_mm = (d["y"] - d["y"].mean()) * 1e3
    m = fit_arx(y_mm, d["u"] - p.command_centre, SEED_004_EQ32["na"], SEED_004_EQ32["nb"], SEED_004_EQ32["nk"], dt=dt)
    out = _summary(m.poles, m.b)
    out["integrator_se"] = _real_pole_se(m, out["integrator"])
    out["travel"] = float(np.ptp(d["y_true"]))
    out["clamps"] = int(d["clamps"])
    out["saturated"] = bool(np.any((d["u_valve"] <= 0.0) | (d["u_valve"] >= p.command_max)))
    return out


def gain_matched_sample_time(params: RodlessCylinderParams, gain: float,
                             times: tuple[float, ...] = GAIN_SAMPLE_TIMES) -> float:
    """Sample time [s] at which the 004 sec. 4.2 procedure on the model identifies the gain per
    sample ``gain`` [mm/V] (linear interpolation between the procedure's gains at ``times``;
    NaN where they do not rise with the sample time or do not bracket ``gain``)."""
    t = np.asarray(times, dtype=float)
    g = np.array([rodless_eq32_poles(params, dt=float(x))["gain"] for x in t])
    if not (np.all(np.diff(g) > 0.0) and g[0] <= gain <= g[-1]):
        return math.nan
    return float(np.interp(gain, g, t))


def _real_pole_se(model, z: float) -> float:
    """Standard error of the real pole ``z`` of an ARX fit (delta method: a root of
    ``A(z) = z^na + a_1 z^(na-1) + ..`` moves by ``-z^(na-i) / A'(z)`` per unit ``a_i``)."""
    na = model.na
    a = np.asarray(model.a, dtype=float)
    da = sum((na - i) * a[i] * z ** (na - i - 1) for i in range(na))
    grad = np.zeros(model.covariance.shape[0])
    grad[:na] = [-(z ** (na - i)) / da for i in range(1, na + 1)]
    return float(math.sqrt(max(grad @ model.covariance @ grad, 0.0)))


def _summary(poles: np.ndarray, b) -> dict:
    near, z1, z2 = _split(np.asarray(poles, dtype=complex))
    gain = float(np.sum(b) / ((1.0 - z1) * (1.0 - z2)).real)  # integrator gain per sample
    return {"poles": np.asarray(poles), "integrator": near.real if abs(near.imag) < 1e-12 else math.nan,
            "zeta": pole_pair_damping(z1, z2), "gain": gain}


def _fmt(poles: np.ndarray) -> str:
    out = []
    for z in sorted(np.asarray(poles, dtype=complex), key=lambda z: -z.real):
        out.append(f"{z.real:.3f}" if abs(z.imag) < 1e-12 else f"{z.real:.3f}{z.imag:+.3f}j")
    return ", ".join(out)


def _others(poles: np.ndarray) -> np.ndarray:
    """The poles besides the one nearest z = 1."""
    _, z1, z2 = _split(np.asarray(poles, dtype=complex))
    return np.array([z1, z2])


def _zeta(summary: dict) -> str:
    z = summary["zeta"]
    return f"{z:.2f}" if math.isfinite(z) else f"none (poles {_fmt(summary['poles'])}: a negative real pole)"


def _kind(poles: np.ndarray) -> str:
    return "a complex pair" if abs(_others(poles)[0].imag) > 1e-12 else "real (an overdamped pair)"


def _read_at_matched_gain(nominal: RodlessCylinderParams, seed: dict, omega_n: float) -> str:
    """Eq (32)'s pole pair read as a continuous mode at the sample time where the model has eq
    (32)'s gain per sample: its frequency against the model's air spring ``omega_n`` and the
    viscous damping on the slide that its damping ratio means."""
    t = gain_matched_sample_time(nominal, seed["gain"])
    if not math.isfinite(t):
        return (f"the model's gain does not bracket eq (32)'s over {GAIN_SAMPLE_TIMES[0] * 1e3:g}-"
                f"{GAIN_SAMPLE_TIMES[-1] * 1e3:g} ms, so eq (32)'s pair is not read as a mode.")
    _, z1, _ = _split(seed["poles"])
    omega = abs(cmath.log(z1)) / t
    c = 2.0 * seed["zeta"] * omega * nominal.mass
    return (f"the model has eq (32)'s gain at about {t * 1e3:.1f} ms. At that sample time eq (32)'s pair "
            f"is a mode at {omega:.0f} rad/s, {abs(omega / omega_n - 1.0):.0%} "
            f"{'above' if omega > omega_n else 'below'} the model's air spring (eq (24): omega_n = "
            f"{omega_n:.1f} rad/s), damped as by {c:.0f} N s/m of viscous friction on the {nominal.mass:g} kg "
            f"slide, where Table 2 gives sigma = {nominal.viscous_friction:g} N s/m on top of its Coulomb "
            "level. So the two printed sources disagree about the friction's damping, and the seed says "
            "nothing that explains it.")


def rows() -> list[ValidationRow]:
    seed = _summary(np.roots(SEED_004_EQ32["a"]), SEED_004_EQ32["b"])
    nominal = RodlessCylinderParams()
    model = rodless_eq32_poles(nominal)
    faster = rodless_eq32_poles(nominal, dt=0.5 * EQ32_DT)
    slower = rodless_eq32_poles(nominal, dt=2.0 * EQ32_DT)
    low_gain = rodless_eq32_poles(nominal, kp=EQ32_KP / 5.0)
    high_gain = rodless_eq32_poles(nominal, kp=EQ32_KP * 4.0)
    heavy = rodless_eq32_poles(dataclasses.replace(nominal, mass=HEAVY_MASS))
    compensated = rodless_eq32_poles(nominal, friction_compensation=True)
    small = rodless_eq32_poles(nominal, amplitude=SMALL_AMPLITUDE)
    small_fast = rodless_eq32_poles(nominal, amplitude=SMALL_AMPLITUDE, dt=0.2 * EQ32_DT)
    no_viscous = rodless_eq32_poles(dataclasses.replace(nominal, viscous_friction=0.0))
    no_sigma1 = rodless_eq32_poles(dataclasses.replace(nominal, bristle_damping=0.0))
    frictionless = rodless_eq32_poles(dataclasses.replace(nominal, **FRICTIONLESS))
    presliding = (nominal.coulomb_friction / nominal.bristle_stiffness,
                  nominal.static_friction / nominal.bristle_stiffness)
    lin = linearize_mid_stroke(nominal)
    linear = damping_with_viscous_friction(lin, nominal.viscous_friction)
    gain_reading = _read_at_matched_gain(nominal, seed, lin.omega_n)
    procedure = (
        f"004 sec. 4.2 on the nominal model: P loop ({EQ32_KP:g} V/m) at mid-stroke, +-{EQ32_AMPLITUDE:g} V "
        f"M-sequence (1023 bits, twice) added to the controller output, {EQ32_DT * 1e3:g} ms samples "
        f"(eq (32)'s are not printed), 5 um position noise; ARX(3,3,1) least squares from that input to the "
        f"position (identification.arx.fit_arx)"
    )
    return [
        ValidationRow(
            name="rodless_cylinder: sec. 4.2 loop ARX(3), pole near z = 1 vs eq (32)",
            published=seed["integrator"],
            reproduced=model["integrator"],
            tolerance=0.01,
            unit="1",
            source=(
                f"004 eq (32): poles {_fmt(seed['poles'])}; the real pole near 1 is the piston's integrator "
                f"(position from a velocity-type plant). {procedure}: poles {_fmt(model['poles'])}. "
                "Tolerance 0.01, the bound within which this procedure's tests take a pole for the integrator: "
                f"eq (32)'s pole is 1 {seed['integrator'] - 1:+.4f}, the model's 1 {model['integrator'] - 1:+.4f} "
                f"(standard error of the fit {model['integrator_se']:.4f}), so the row says that both have an "
                "integrator, and little more"
            ),
            kind="independent",
        ),
        ValidationRow(
            name="rodless_cylinder: sec. 4.2 loop ARX(3), damping of the other poles vs eq (32)",
            published=seed["zeta"],
            reproduced=model["zeta"],
            tolerance=0.3,
            unit="1",
            source=(
                f"004 eq (32): the pair {_fmt(seed['poles'][np.abs(seed['poles'].imag) > 0])}, "
                "zeta = -(ln z1 + ln z2)/(2 sqrt(ln z1 ln z2)) (no sample time needed). "
                f"{procedure}: the two poles besides the integrator are {_kind(model['poles'])}. "
                "The unprinted details do not explain it: the damping is "
                f"{_zeta(faster)} at {0.5 * EQ32_DT * 1e3:g} ms and {_zeta(slower)} at {2 * EQ32_DT * 1e3:g} ms, "
                f"{_zeta(low_gain)} and {_zeta(high_gain)} with P gains of {EQ32_KP / 5.0:g} and {EQ32_KP * 4.0:g} "
                "V/m (004 prints none), "
                f"{_zeta(heavy)} with a {HEAVY_MASS:g} kg moving mass (004 prints none; the model assumes "
                f"{nominal.mass:g} kg), and with friction compensation in the loop (sec. 4.1 says the loop "
                "had one and does not print it; here the Table 2 curve at the measured velocity through "
                f"eq (27)) the poles are {_fmt(compensated['poles'])}. At +-{SMALL_AMPLITUDE:g} V the piston "
                f"travels {small['travel'] * 1e6:.0f} um peak to peak "
                f"({'within' if 0.5 * small['travel'] <= presliding[1] else 'beyond'} the assumed LuGre bristles' "
                f"pre-sliding deflection of {presliding[0] * 1e6:.0f}-{presliding[1] * 1e6:.0f} um) and the other "
                f"poles are {_fmt(_others(small['poles']))}, damping {_zeta(small)}; at "
                f"{0.2 * EQ32_DT * 1e3:g} ms they are {_fmt(_others(small_fast['poles']))}, nearly the same place in "
                "z, so not a mode of the plant (a mode moves in z with the sample time) but the fit of an almost "
                "stuck piston. The identified model depends on "
                "the M-sequence amplitude, which 004 does not print either (its text has the piston move left "
                "and right, i.e. slide). The linear model (eqs (19)-(24)) with "
                f"Table 2's viscous sigma gives {linear:.2f}: the seal friction damps the air spring. The "
                f"procedure on the model without that sigma gives {_zeta(no_viscous)} (poles "
                f"{_fmt(_others(no_viscous['poles']))}), so the Coulomb and bristle parts of the friction alone "
                f"overdamp it; without the assumed bristle damping sigma1 ({nominal.bristle_damping:g} N s/m) it is "
                f"{_zeta(no_sigma1)}; without any friction it is "
                f"{_zeta(frictionless)} ({_kind(frictionless['poles'])}). "
                "Eq (32) lies between: the rig's friction damps its air spring less than Table 2's curve "
                "damps the model's. Gain per sample (depends on the sample time): eq (32) "
                f"{seed['gain']:.3f} mm/V, the model {faster['gain']:.3f} / {model['gain']:.3f} / "
                f"{slower['gain']:.3f} at {0.5 * EQ32_DT * 1e3:g} / {EQ32_DT * 1e3:g} / "
                f"{2 * EQ32_DT * 1e3:g} ms; {gain_reading} Tolerance 30 %: an ARX fit identified in closed loop"
            ),
            kind="independent",
        ),
    ]
