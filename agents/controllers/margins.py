r"""Stability margins of the classical loops on the plants' linearisation without dry friction.

A loop's stability must not rest on friction: on the hydraulic plants the old tanh-regularised
friction acted as a stiff damper at rest. So every classical loop is checked on the plant
linearised *without its dry friction* (:meth:`hydro_envs.spec.PlantSpec.without_dry_friction`:
Coulomb, static and Stribeck levels zero, viscous friction kept), sampled with the env's
zero-order hold (:func:`hydro_envs.sim.linear.zoh`), in the controller's linear region (no
saturation, anti-windup idle).

Controller in state space, ``xi_{k+1} = Ac xi_k + Bc y_k``, ``a_k = Cc xi_k + Dc y_k`` with the
measurements ``y_k`` (reference zero). The PID of :class:`agents.controllers.core.PIDCore`
(``e = -y``, derivative on the measurement) has ``xi = (I_k, D_{k-1}, y_{k-1})``::

    a_k     = I_k + alpha D_{k-1} + beta y_{k-1} - (K_p + beta) y_k
    I_{k+1} = I_k - K_p dt / T_i y_k
    D_k     = alpha D_{k-1} + beta y_{k-1} - beta y_k,   alpha = T_f/(T_f + dt), beta = K_p T_d/(T_f + dt)

:func:`loop_margins` breaks the loop at the plant input: ``L(z) = -K(z) P(z)``; the gain margin
is ``1 / |L|`` where its phase crosses -180 deg (the smallest over the crossings), the phase
margin ``180 deg + arg L`` where ``|L|`` crosses 1, and ``stable`` says whether every
closed-loop pole the loop places lies inside the unit circle (modes no feedback moves -- a
friction state without dry friction, the common-mode pressure of sealed chambers -- are the
plant's own and left out).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

__all__ = ["LoopMargins", "pid_state_space", "loop_margins", "dry_free_linearization"]


@dataclasses.dataclass(frozen=True)
class LoopMargins:
    """Margins of a sampled loop (module docstring)."""

    gain_margin_db: float
    phase_margin_deg: float
    crossover_hz: float  # where |L| = 1 (the loop's bandwidth)
    phase_crossover_hz: float  # where arg L = -180 deg (nan: none below Nyquist)
    spectral_radius: float  # largest closed-loop pole magnitude
    stable: bool

    def as_dict(self) -> dict[str, float | bool]:
        return dataclasses.asdict(self)


def pid_state_space(kp: float, ti: float, td: float, tf: float, dt: float) -> tuple[np.ndarray, ...]:
    """``(Ac, Bc, Cc, Dc)`` of the PID of :class:`~agents.controllers.core.PIDCore` from the
    measured output ``y`` [m] to the action (module docstring); ``ti = inf``: no integral."""
    alpha = tf / (tf + dt)
    beta = kp * td / (tf + dt)
    ki = kp * dt / ti if math.isfinite(ti) else 0.0
    Ac = np.array([[1.0, 0.0, 0.0], [0.0, alpha, beta], [0.0, 0.0, 0.0]])
    Bc = np.array([[-ki], [-beta], [1.0]])
    Cc = np.array([[1.0, alpha, beta]])
    Dc = np.array([[-(kp + beta)]])
    return Ac, Bc, Cc, Dc


def _fixed_modes(Ad: np.ndarray, Bd: np.ndarray, C: np.ndarray, tol: float = 1e-9) -> list[complex]:
    """Eigenvalues of ``Ad`` that no feedback from ``C`` through ``Bd`` moves (PBH test: an
    unobservable or uncontrollable mode, e.g. a friction state without dry friction or the
    common-mode pressure of two sealed chambers); they stay poles of the closed loop."""
    lam, right = np.linalg.eig(Ad)
    lam_l, left = np.linalg.eig(Ad.T)
    out = []
    for i, li in enumerate(lam):
        v = right[:, i]
        j = int(np.argmin(np.abs(lam_l - li)))
        w = left[:, j]
        unobs = np.linalg.norm(C @ v) <= tol * np.linalg.norm(v) * max(1.0, np.linalg.norm(C))
        unctrl = np.linalg.norm(w @ Bd) <= tol * np.linalg.norm(w) * max(1.0, np.linalg.norm(Bd))
        if unobs or unctrl:
            out.append(complex(li))
    return out


def _spectral_radius(poles: np.ndarray, fixed: list[complex]) -> float:
    """Largest closed-loop pole magnitude once the fixed modes (matched to the nearest pole)
    are taken out: the poles the loop places."""
    rest = list(np.asarray(poles, dtype=complex))
    for f in fixed:
        k = int(np.argmin([abs(r - f) for r in rest]))
        if abs(rest[k] - f) < 1e-6:
            rest.pop(k)
    return float(max(abs(r) for r in rest)) if rest else 0.0


def loop_margins(Ad: Any, Bd: Any, C: Any, ctrl: tuple[np.ndarray, ...], dt: float,
                 n_freq: int = 4000) -> LoopMargins:
    """Margins of the sampled plant ``(Ad, Bd, C)`` (action in, measurements out) under the
    controller ``ctrl = (Ac, Bc, Cc, Dc)`` (module docstring). Frequencies: ``n_freq`` log-spaced
    points from 1e-3 Hz to Nyquist."""
    Ad, Bd, C = (np.atleast_2d(np.asarray(m, dtype=float)) for m in (Ad, Bd, C))
    Ac, Bc, Cc, Dc = (np.atleast_2d(np.asarray(m, dtype=float)) for m in ctrl)
    n, nc = Ad.shape[0], Ac.shape[0]
    A_cl = np.block([[Ad + Bd @ Dc @ C, Bd @ Cc], [Bc @ C, Ac]])
    rho = _spectral_radius(np.linalg.eigvals(A_cl), _fixed_modes(Ad, Bd, C))
    f = np.logspace(-3.0, math.log10(0.5 / dt), n_freq)
    z = np.exp(1j * 2.0 * math.pi * f * dt)
    L = np.empty(f.size, dtype=complex)
    eye, eye_c = np.eye(n), np.eye(nc)
    for k, zk in enumerate(z):
        P = C @ np.linalg.solve(zk * eye - Ad, Bd)
        K = Cc @ np.linalg.solve(zk * eye_c - Ac, Bc) + Dc
        L[k] = -(K @ P)[0, 0]
    mag = np.abs(L)
    ph = np.unwrap(np.angle(L))
    # phase margin at the first gain crossover from above
    pm, f_gc = float("inf"), float("nan")
    down = np.flatnonzero((mag[:-1] >= 1.0) & (mag[1:] < 1.0))
    if down.size:
        i = down[0]
        t = (0.0 - math.log(mag[i])) / (math.log(mag[i + 1]) - math.log(mag[i]))
        f_gc = float(f[i] * (f[i + 1] / f[i]) ** t)
        phase = ph[i] + t * (ph[i + 1] - ph[i])
        pm = float(math.degrees(phase) + 180.0 + 360.0 * math.floor(-(math.degrees(phase) + 180.0) / 360.0 + 0.5))
    # gain margin: the smallest 1/|L| where the phase passes an odd multiple of -180 deg
    gm, f_pc = float("inf"), float("nan")
    k180 = (ph + math.pi) / (2.0 * math.pi)
    cross = np.flatnonzero(np.floor(k180[:-1]) != np.floor(k180[1:]))
    for i in cross:
        target = math.floor(max(k180[i], k180[i + 1])) * 2.0 * math.pi - math.pi
        t = (target - ph[i]) / (ph[i + 1] - ph[i])
        m = mag[i] * (mag[i + 1] / mag[i]) ** t
        g = -20.0 * math.log10(m)
        if g < gm:
            gm, f_pc = g, float(f[i] * (f[i + 1] / f[i]) ** t)
    # at Nyquist the response of a real loop is real: a phase of -180 deg there is a crossing too
    frac = k180[-1] - round(k180[-1])
    if abs(frac) < 1e-6 and -20.0 * math.log10(mag[-1]) < gm:
        gm, f_pc = -20.0 * math.log10(mag[-1]), float(f[-1])
    return LoopMargins(gm, pm, f_gc, f_pc, rho, rho < 1.0)


def dry_free_linearization(spec: Any, params: Any, y0: Any, u0: Any, dt: float,
                           outputs: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Ad, Bd, C)`` of ``params`` without dry friction linearised at ``(y0, u0)`` and sampled
    at ``dt`` (zero-order hold); ``C`` selects the measured states ``outputs``. The plant's input
    is the env action times ``input_scale``: pass ``u0`` in the plant's input units and scale
    ``Bd`` by the action's range outside."""
    from hydro_envs.sim.linear import linearize, zoh

    p0 = type(params).from_mapping(spec.without_dry_friction({}), base=params)
    A, B = linearize(spec, p0, y0, u0)
    Ad, Bd = zoh(A, B, dt)
    C = np.zeros((len(outputs), A.shape[0]))
    for r, j in enumerate(outputs):
        C[r, j] = 1.0
    return Ad, Bd, C
