r"""Identified friction models for the friction feedforward controllers.

The feedforward controllers never read the plant's friction parameters: they use a model
identified from a *virtual* constant-velocity experiment on the nominal plant, as a user of the
suite would on the rig, then fitted either with the static Stribeck law
(:func:`identification.friction.fit_friction`) or with the neural friction net of 002 sec. 5
(:func:`identification.neural.fit_feedforward`, 10 tanh units, Levenberg-Marquardt).

Experiments (all on the nominal parameter set, ideal sensors):

* servo cylinder: the square-wave test of 002 sec. 4
  (:func:`identification.experiments.run_friction_experiment`, periods capped at 3 s: 68
  amplitudes 0.05-3.4 V in about 40 s instead of 150 s, then
  :func:`~identification.experiments.friction_points_from_square_wave`); Stribeck law 002 eq (1)
  with the plant's sign regularisation.
* shaking table: constant valve commands held from one end of the stroke; the mean velocity
  and the mean pressure force ``A (P_a - P_b)`` while the table crosses the middle 40 % of the
  stroke give one point per command (003 eq (10) at zero acceleration); Gaussian Stribeck law
  003 eq (11) with the tanh sign of eq (12) (``v_eps = 1/beta`` of the nominal plant).
* rodless cylinder: 004 sec. 3 constant-command runs
  (:func:`hydro_envs.plants.rodless_cylinder.constant_command_run`, eq (1)); Stribeck law of
  004 Table 2.

Results are cached per process (:func:`functools.lru_cache`); each identification takes well
under a second.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

__all__ = ["FRICTION_KINDS", "FRICTION_PLANTS", "friction_points", "identified_friction"]

FRICTION_PLANTS = ("servo_cylinder", "shaking_table", "rodless_cylinder")
FRICTION_KINDS = ("stribeck", "neural")


def _servo_points():
    from identification.experiments import (
        friction_points_from_square_wave,
        run_friction_experiment,
    )

    exp = run_friction_experiment(period_max=3.0)
    return friction_points_from_square_wave(exp.data), exp.params.friction_sign_velocity, "stribeck"


def _table_points():
    from hydro_envs import registry
    from hydro_envs.plants.shaking_table import model as st
    from hydro_envs.sim.stiffness import substeps_from_stiffness

    step = registry.get("shaking_table").kernels.step_serial
    p = st.ShakingTableParams.preset("modified_ifas")
    dt = 1e-3
    half = 0.5 * p.stroke
    speeds = np.geomspace(0.006, 0.3, 20)
    commands = np.concatenate([speeds, -speeds]) / st.no_load_velocity(p)  # fraction of full opening
    n = commands.size
    y = np.stack([st.rest_state(p, -0.95 * half * np.sign(c)) for c in commands])
    U = (commands * p.command_max).reshape(n, 1)
    P = np.tile(p.to_array(), (n, 1))
    nsub = np.full(n, substeps_from_stiffness(st.stiffness_modes(p), dt)[0], dtype=np.int64)
    W = np.zeros((n, 5, st.N_STATES))
    clamps = np.zeros(n, dtype=np.int64)
    lo, hi = -0.2 * half * 2, 0.2 * half * 2  # middle 40 % of the stroke
    sums = np.zeros((n, 3))  # samples, sum v, sum force
    x_in, t_in = np.full(n, np.nan), np.zeros(n)
    done = np.zeros(n, dtype=bool)
    for k in range(int(60.0 / dt)):
        step(y, U, P, dt, nsub, W, clamps)
        x = y[:, st.X]
        inside = (x > lo) & (x < hi) & ~done
        first = inside & np.isnan(x_in)
        x_in[first], t_in[first] = x[first], k * dt
        sums[inside, 0] += 1
        sums[inside, 2] += p.piston_area * (y[inside, st.PA] - y[inside, st.PB])
        leaving = ~np.isnan(x_in) & ~inside & ~done
        v_mean = (x - x_in) / np.maximum(k * dt - t_in, dt)
        sums[leaving, 1] = v_mean[leaving]
        done |= leaving
        if done.all():
            break
    ok = done & (sums[:, 0] > 10)
    v = sums[ok, 1]
    f = sums[ok, 2] / sums[ok, 0]
    return (v, f), 1.0 / p.tanh_gain, "stribeck_gaussian"


def _rodless_points():
    from hydro_envs.plants.rodless_cylinder import model as rc

    from hydro_envs.plants.rodless_cylinder.experiments import constant_command_run

    p = rc.RodlessCylinderParams()
    du = np.geomspace(0.03, 2.5, 24)
    vs, fs = [], []
    for c in np.concatenate([p.command_centre + du, p.command_centre - du]):
        v, f, _ = constant_command_run(p, float(c), max_time=10.0)
        if np.isfinite(v):
            vs.append(v)
            fs.append(f)
    return (np.array(vs), np.array(fs)), 0.0, "stribeck"


_EXPERIMENTS = {"servo_cylinder": _servo_points, "shaking_table": _table_points, "rodless_cylinder": _rodless_points}


@functools.cache
def friction_points(plant: str):
    """``(points, sign_velocity, static_model)`` of the plant's virtual experiment (cached)."""
    if plant not in _EXPERIMENTS:
        raise ValueError(f"plant = {plant!r}; friction identification available for {FRICTION_PLANTS}")
    return _EXPERIMENTS[plant]()


@functools.cache
def identified_friction(plant: str, kind: str = "stribeck") -> Any:
    """Friction model ``F = model.predict(v)`` [N] identified on the nominal ``plant``.

    ``kind``: ``"stribeck"`` (static law, see the module docstring) or ``"neural"`` (002 sec. 5
    feed-forward net, seed 0, 3 restarts).
    """
    from identification.friction import fit_friction
    from identification.neural import fit_feedforward

    if kind not in FRICTION_KINDS:
        raise ValueError(f"kind = {kind!r}; allowed {FRICTION_KINDS}")
    pts, v_eps, model = friction_points(plant)
    if isinstance(pts, tuple):
        v, f = pts
        if kind == "stribeck":
            return fit_friction(v, f, model=model, sign_velocity=v_eps)
        return fit_feedforward(v, f, restarts=3, seed=0)
    if kind == "stribeck":
        return fit_friction(pts, model=model, sign_velocity=v_eps)
    return fit_feedforward(pts, restarts=3, seed=0)
