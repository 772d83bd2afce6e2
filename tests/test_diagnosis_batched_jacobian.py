"""The batched forward-difference Jacobian of the grey-box fits the diagnosis runs
(``identification.greybox._Evaluator.jac_forward``: every perturbed parameter vector simulated
as one copy of a single batched rollout) equals the Jacobian built column by column from one
rollout per perturbed vector, with the same steps."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hydro_envs.plants.servo_cylinder import model as sc
from identification import greybox as gb
from identification.greybox_problem import _build_problem

DT = 1e-3  # sample time [s] of the servo rig's records (the diagnosis runs at 1 kHz)
FIT = ["bulk_modulus", "viscous_friction", "coulomb_friction"]
# theta step of the diagnosis fits: greybox.fit_greybox's default fd_step, which
# identification.diagnosis.fitting.fit_model keeps
FD_STEP = 1e-4


def _problem(base: sc.ServoCylinderParams, bounds=None):
    """A 0.3 s servo-cylinder record (multisine valve command) of the true parameters, and the
    grey-box problem of fitting ``FIT`` from ``base`` to it."""
    truth = sc.ServoCylinderParams()
    t = DT * np.arange(301)
    u = 1.5 * np.sin(2 * np.pi * 2 * t) + 0.4 * np.sin(2 * np.pi * 17 * t + 1)
    y0 = np.zeros(sc.N_STATES)
    y0[sc.X] = truth.stroke / 2
    y0[sc.P1] = y0[sc.P2] = 0.5 * (truth.supply_pressure + truth.tank_pressure)
    ch = [c for c in gb.plant_setup("servo_cylinder")["channels"].values() if c.name in ("x", "p1", "p2")]
    e = gb.Experiment(DT, u, y0, {k: u for k in ("x", "p1", "p2")})
    clean = gb.simulate_outputs(truth, [e], ch)[0][0]
    data = gb.Experiment(DT, u, y0, clean)
    return _build_problem(base, FIT, [data], ch, {"x": 1e-5, "p1": 5e3, "p2": 5e3}, True, bounds, None)


def _column_by_column(prob, theta: np.ndarray, steps: np.ndarray, nsub: int) -> np.ndarray:
    """Forward differences from one rollout per perturbed vector ``theta + steps[i] e_i``."""
    r0 = prob.residuals(prob.param_arrays(theta[None, :]), nsub)[0][0]
    cols = []
    for i, h in enumerate(steps):
        th = theta.copy()
        th[i] += h
        cols.append((prob.residuals(prob.param_arrays(th[None, :]), nsub)[0][0] - r0) / h)
    return np.stack(cols, axis=1)


def _base() -> sc.ServoCylinderParams:
    return dataclasses.replace(sc.ServoCylinderParams(), bulk_modulus=500e6, viscous_friction=350.0,
                               coulomb_friction=30.0)


def test_batched_jacobian_equals_column_by_column_differences():
    base = _base()
    prob = _problem(base)
    ev = gb._Evaluator(prob, base, FD_STEP, None, 10)
    theta = prob.to_theta(np.array([getattr(base, n) for n in prob.names]))
    ev.fun(theta)
    J = ev.jac_forward(theta)
    ref = _column_by_column(prob, theta, np.full(len(FIT), FD_STEP), ev.nsub)
    assert J.shape == ref.shape == (3 * 301, len(FIT))
    assert np.all(np.abs(ref).max(axis=0) > 0)  # every parameter moves the outputs
    np.testing.assert_allclose(J, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


def test_batched_jacobian_steps_backward_at_an_upper_bound():
    base = _base()
    hi = base.viscous_friction * (1 + 0.5 * FD_STEP)  # less room than one step above the start
    prob = _problem(base, bounds={"viscous_friction": (1.0, hi)})
    ev = gb._Evaluator(prob, base, FD_STEP, None, 10)
    theta = prob.to_theta(np.array([getattr(base, n) for n in prob.names]))
    ev.fun(theta)
    J = ev.jac_forward(theta)
    i = prob.names.index("viscous_friction")
    steps = np.full(len(FIT), FD_STEP)
    steps[i] = -FD_STEP
    np.testing.assert_allclose(J, _column_by_column(prob, theta, steps, ev.nsub), rtol=1e-9,
                               atol=1e-9 * np.abs(J).max())
    forward = steps.copy()
    forward[i] = FD_STEP  # a forward step there: a different (curved) difference quotient
    assert not np.allclose(J[:, i], _column_by_column(prob, theta, forward, ev.nsub)[:, i], rtol=1e-6, atol=0)


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__, "-q"])
