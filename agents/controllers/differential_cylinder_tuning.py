r"""The loops of a differential-cylinder rig on its own linearisation, for checking a tuning.

:func:`linear_rig` linearises a rig without dry friction (:func:`~agents.controllers.margins.
dry_free_linearization`) at rest, sampled at the env's 1 ms; :func:`loop_set` gives the PID
(both gains of the area-ratio compensation) and the P loop of
:mod:`agents.controllers.differential_cylinder` as discrete state-space controllers;
:func:`worst_margins` their worst gain margin over the rig's minimum-frequency position,
mid-stroke and 90 % stroke.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["linear_rig", "loop_set", "worst_margins"]

DT = 1e-3


def linear_rig(params, x: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rig without dry friction at rest at ``x``: ``(Ad, Bd, C)`` from the action to the
    position and the load pressure ``p1 - alpha p2`` (1 ms zero-order hold)."""
    from agents.controllers.margins import dry_free_linearization
    from hydro_envs.plants.differential_cylinder import model as dc
    from hydro_envs.registry import get

    Ad, Bd, C = dry_free_linearization(get("differential_cylinder"), params, dc.rest_state(params, x), [0.0], DT,
                                       (dc.X, dc.P1, dc.P2))
    # the pressure level of the sealed chambers at rest that leaves the force unchanged is a mode
    # no feedback moves: the loops measure x and p1 - alpha p2 only
    C = np.vstack([C[0], C[1] - params.area_ratio * C[2]])
    return Ad, Bd * params.command_max, C


def loop_set(params, crossover_ratio: float, k_dp: float, p_bandwidth: float, p_k_dp: float) -> dict:
    """``name -> (Ac, Bc, Cc, Dc)`` of the PID (both area-ratio gains) and the P loop on ``params``."""
    from agents.controllers.differential_cylinder import pid_tuning
    from agents.controllers.margins import pid_state_space

    t = pid_tuning(params, crossover_ratio)
    out = {}
    for name, (kp, ti, td, kd) in {"pid": (t["kp"], t["ti"], t["td"], k_dp),
                                   "p": (p_bandwidth / t["k_q"], math.inf, 0.0, p_k_dp)}.items():
        if math.isfinite(ti):
            Ac, Bc, Cc, Dc = pid_state_space(kp, ti, td, t["tf"], DT)
        else:  # the P loop: a static gain (pid_state_space's idle integrator would be a pole at 1)
            Ac, Bc, Cc, Dc = np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), np.array([[-kp]])
        Bc = np.hstack([Bc, np.zeros((Bc.shape[0], 1))])
        Dc = np.hstack([Dc, [[-kd / params.supply_pressure]]])  # -k_dp (p1 - alpha p2) / p_s
        for g in ((1.0, 1.0 / math.sqrt(params.area_ratio)) if name == "pid" else (1.0,)):
            out[f"{name} x{g:.2f}"] = (Ac, Bc, g * Cc, g * Dc)
    return out


def _positions(params) -> tuple[float, ...]:
    from hydro_envs.plants.differential_cylinder import model as dc

    return (dc.minimum_natural_frequency_position(params), 0.5 * params.stroke, 0.9 * params.stroke)


@functools.lru_cache(maxsize=64)
def _plants(params) -> tuple:
    return tuple(linear_rig(params, x) for x in _positions(params))


def worst_margins(params, loops: dict, plant=None) -> dict[str, float]:
    """Worst gain margin [dB] of each loop over the three positions of ``plant`` (default
    ``params``); ``-inf`` for a loop unstable anywhere."""
    from agents.controllers.margins import loop_margins

    worst: dict[str, float] = {}
    for Ad, Bd, C in _plants(params if plant is None else plant):
        for name, ctrl in loops.items():
            m = loop_margins(Ad, Bd, C, ctrl, DT)
            worst[name] = min(worst.get(name, math.inf), m.gain_margin_db if m.stable else -math.inf)
    return worst
