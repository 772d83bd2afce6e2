"""Seed 004 sec. 4.2's identification procedure on the rodless model with the project's ARX tools
(analysis beside the validation rows; the rows themselves are
:func:`hydro_envs.plants.rodless_cylinder.validation.eq32_rows`).

Seed 004 sec. 4.2 identifies the rodless cylinder's open-loop model in closed loop: a
proportional position loop with an M-sequence added to the controller output, and an ARX(3)
fit from that input to the slider position, eq (32). The functions below run the same procedure on
the nominal model (:func:`hydro_envs.plants.rodless_cylinder.experiments.closed_loop_m_sequence`,
:func:`identification.arx.fit_arx`) for comparison with eq (32)'s poles:

* the pole near ``z = 1`` (the slider's integrator);
* the damping ratio of the other two poles, ``-(ln z1 + ln z2) / (2 sqrt(ln z1 ln z2))``,
  which is ``-ln|z| / |ln z|`` for a complex pair, ``(a + b) / (2 sqrt(ab))`` for real poles
  ``exp(-a T), exp(-b T)``, and needs no sample time (004 does not print it).

The gain per sample depends on the sample time, so it is not compared;
:func:`gain_matched_sample_time` finds the sample time at which the model has eq (32)'s gain, at
which eq (32)'s pair can be read as a continuous mode (its frequency, and the viscous damping
that would give its damping ratio).
"""

from __future__ import annotations

import math

import numpy as np

from hydro_envs.plants.rodless_cylinder.experiments import closed_loop_m_sequence
from hydro_envs.plants.rodless_cylinder.params import RodlessCylinderParams
from hydro_envs.plants.rodless_cylinder.validation import (
    DRY_FRICTION_COMPENSATED as FRICTIONLESS,
)
from hydro_envs.plants.rodless_cylinder.validation import (
    EQ32_AMPLITUDE,
    EQ32_DT,
    EQ32_KP,
    EQ32_NOISE,
    pole_pair_damping,
)
from hydro_envs.validation import ValidationRow
from identification.arx import SEED_004_EQ32, fit_arx

__all__ = ["FRICTIONLESS", "gain_matched_sample_time", "pole_pair_damping", "rodless_eq32_poles", "rows"]

#: sample times [s] at which the procedure's gain per sample is compared with eq (32)'s
GAIN_SAMPLE_TIMES = (0.004, 0.005, 0.0065, 0.008, 0.01)


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


def rows() -> list[ValidationRow]:
    """No rows: the eq (32) rows run the procedure in the plant's own validation module
    (:func:`hydro_envs.plants.rodless_cylinder.validation.eq32_rows`, a least-squares ARX(3) of
    its own). Kept so that an install whose metadata still lists this entry point adds nothing."""
    return []
