"""Grey-box identification (identification/greybox.py): recovery of known parameters from
simulated noisy data, calibrated covariance, identifiability report, 003 Table 3 direction,
CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from hydro_envs.plants.shaking_table.experiments import table3_input

from hydro_envs.plants.servo_cylinder import model as sc
from hydro_envs.plants.shaking_table import model as st
from identification import greybox as gb

DT = 1e-3
SERVO_NOISE = {"x": 1e-5, "p1": 5e3, "p2": 5e3}
SERVO_FIT = ["bulk_modulus", "viscous_friction", "coulomb_friction"]


def _servo_record():
    truth = sc.ServoCylinderParams()
    t = DT * np.arange(1001)
    u = 1.5 * np.sin(2 * np.pi * 2 * t) + 0.4 * np.sin(2 * np.pi * 17 * t + 1) + 0.3 * np.sin(2 * np.pi * 41 * t + 2)
    y0 = np.zeros(sc.N_STATES)
    y0[sc.X] = truth.stroke / 2
    y0[sc.P1] = y0[sc.P2] = 0.5 * (truth.supply_pressure + truth.tank_pressure)
    ch = [c for c in gb.plant_setup("servo_cylinder")["channels"].values() if c.name in SERVO_NOISE]
    e = gb.Experiment(DT, u, y0, {k: u for k in SERVO_NOISE})
    clean = gb.simulate_outputs(truth, [e], ch)[0][0]
    return truth, t, u, y0, ch, clean


def _noisy(clean, noise, seed):
    rng = np.random.default_rng(seed)
    return {k: clean[k] + noise[k] * rng.standard_normal(clean[k].size) for k in noise}


def _servo_fit(seed, truth, u, y0, ch, clean):
    base = dataclasses.replace(truth, bulk_modulus=500e6, viscous_friction=350.0, coulomb_friction=30.0)
    return gb.fit_greybox(base, SERVO_FIT,
                          [gb.Experiment(DT, u, y0, _noisy(clean, SERVO_NOISE, seed))], ch)


def test_servo_cylinder_recovers_known_parameters():
    truth, t, u, y0, ch, clean = _servo_record()
    res = _servo_fit(0, truth, u, y0, ch, clean)
    assert res.success
    for n in SERVO_FIT:
        assert res.values[n] == pytest.approx(getattr(truth, n), rel=0.05), n
        lo, hi = res.ci95[n]
        assert lo < res.values[n] < hi
    assert res.identifiable and res.condition_number < 100
    assert res.noise_variance == pytest.approx(1.0, rel=0.1)  # noise-level weights
    assert res.nrmse["x"] < 0.01
    d = res.to_json_dict()
    json.dumps(d, allow_nan=False)
    assert set(d["parameters"]) == set(SERVO_FIT) and d["units"]["bulk_modulus"] == "Pa"


def test_servo_covariance_is_calibrated():
    """Monte-Carlo spread over seeds vs the reported standard errors (within a factor 2)."""
    truth, t, u, y0, ch, clean = _servo_record()
    fits = [_servo_fit(seed, truth, u, y0, ch, clean) for seed in range(8)]
    est = np.array([[f.values[n] for n in SERVO_FIT] for f in fits])
    se = np.array([[f.std_errors[n] for n in SERVO_FIT] for f in fits])
    spread = est.std(axis=0, ddof=1)
    ratio = spread / se.mean(axis=0)
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio
    z = (est - np.array([getattr(truth, n) for n in SERVO_FIT])) / se
    assert 0.5 < np.sqrt(np.mean(z**2)) < 2.0


def test_product_pair_is_flagged_unidentifiable():
    """C_v and w enter the orifice law only as the product C_v w (002 eqs (3)-(4))."""
    truth, t, u, y0, ch, clean = _servo_record()
    base = dataclasses.replace(truth, discharge_coefficient=0.5, area_gradient=25e-3)
    res = gb.fit_greybox(base, ["discharge_coefficient", "area_gradient"],
                         [gb.Experiment(DT, u, y0, _noisy(clean, SERVO_NOISE, 0))], ch, reweight=False)
    assert not res.identifiable
    assert res.condition_number > 1e6
    assert [(a, b) for a, b, _ in res.correlated_pairs] == [("discharge_coefficient", "area_gradient")]
    assert res.correlated_pairs[0][2] < -0.99  # the product is fixed: opposite moves
    prod = res.values["discharge_coefficient"] * res.values["area_gradient"]
    assert prod == pytest.approx(truth.discharge_coefficient * truth.area_gradient, rel=0.01)


def test_shaking_table_recovers_known_parameters():
    """E_0, F_c, F_v of the modified-IFAS table from two noisy records (x and a)."""
    truth = st.ShakingTableParams.preset("modified_ifas")
    ch = [c for c in gb.plant_setup("shaking_table")["channels"].values() if c.name in ("x", "a")]
    exps = []
    for sec, make in ((3.0, lambda t: 3.0 * np.sin(4 * np.pi * t) + 1.0 * np.sin(2 * np.pi * 7.3 * t)),
                      (1.0, lambda t: table3_input("2 sin(10 pi t)", t))):
        t = DT * np.arange(int(sec / DT) + 1)
        u = make(t)
        exps.append(gb.Experiment(DT, u, st.rest_state(truth), {"x": u, "a": u}))
    clean = gb.simulate_outputs(truth, exps, ch)[0]
    noise = {"x": 2e-5, "a": 0.01}
    meas = [gb.Experiment(DT, e.u, e.y0, _noisy(c, noise, 3)) for e, c in zip(exps, clean)]
    base = dataclasses.replace(truth, e0=truth.e0 * 1.3, coulomb_friction=460.0, viscous_friction=530.0)
    fit = ["e0", "coulomb_friction", "viscous_friction"]
    res = gb.fit_greybox(base, fit, meas, ch)
    for n in fit:
        assert res.values[n] == pytest.approx(getattr(truth, n), rel=0.05), n
        assert abs(res.values[n] - getattr(truth, n)) < 4.0 * res.std_errors[n], n
    assert len(res.nrmse_per_experiment) == 2 and res.nrmse["a"] < 0.05
    # with the seals' LuGre law (steady state eq (11) with the sign, beta read per mm/s) F_c and
    # F_v no longer trade off as they did under tanh(7.33 v) ~ linear (corr < -0.8): -0.56
    assert -0.8 < res.correlation[1, 2] < 0.0


def test_bad_problem_raises():
    truth = sc.ServoCylinderParams()
    e = gb.Experiment(DT, np.zeros(10), np.zeros(6), {"x": np.zeros(10)})
    ch = list(gb.plant_setup("servo_cylinder")["channels"].values())
    with pytest.raises(gb.GreyboxError, match="unknown parameter"):
        gb.fit_greybox(truth, ["nope"], [e], ch)
    with pytest.raises(gb.GreyboxError, match="sigma"):
        gb.fit_greybox(truth, ["mass"], [e], ch)  # constant record
    with pytest.raises(gb.GreyboxError, match="shape"):
        gb.Experiment(DT, np.zeros(10), np.zeros(6), {"x": np.zeros(9)})


def test_cli_greybox_servo(tmp_path, capsys):
    from hydro_envs.cli import main
    from hydro_envs.data.measured import write_measured

    truth, t, u, y0, ch, clean = _servo_record()
    meas = _noisy(clean, SERVO_NOISE, 0)
    f = tmp_path / "servo.csv"
    write_measured(f, t, {"u": u, **meas}, plant="servo_cylinder")
    rc = main(["identify", "greybox", "--plant", "servo_cylinder", "--data", str(f),
               "--fit", "bulk_modulus,viscous_friction,coulomb_friction",
               "--set", "bulk_modulus=5e8", "--nominal-geometry", "--json"])
    assert rc == 0
    res = json.loads(capsys.readouterr().out)
    assert res["parameters"]["bulk_modulus"] == pytest.approx(truth.bulk_modulus, rel=0.05)
    assert res["parameters"]["coulomb_friction"] == pytest.approx(truth.coulomb_friction, rel=0.05)
    assert "nrmse_x" in res["metrics"]


def test_substep_cap_keeps_the_fit_out_of_stiff_parameter_sets():
    """A true moving mass of 2 kg needs 8 sub-steps per ms (the piston on its seals' bristles
    and on the stops stiffens as the mass falls), the 12.3 kg start 2: with
    ``max_substep_ratio = 2`` the fit rejects every trial point needing more than 4, so it stops
    above the truth and says why; without the cap it reaches it."""
    truth, t, u, y0, ch, _ = _servo_record()
    truth = dataclasses.replace(truth, mass=2.0)
    e = gb.Experiment(DT, u, y0, {k: u for k in SERVO_NOISE})
    clean = gb.simulate_outputs(truth, [e], ch)[0][0]
    data = [gb.Experiment(DT, u, y0, _noisy(clean, SERVO_NOISE, 3))]
    base = dataclasses.replace(truth, mass=12.3)
    free = gb.fit_greybox(base, ["mass"], data, ch)
    assert free.values["mass"] == pytest.approx(2.0, rel=0.02)
    assert free.n_substeps >= 8
    capped = gb.fit_greybox(base, ["mass"], data, ch, max_substep_ratio=2.0)
    assert capped.n_substeps <= 4
    assert capped.values["mass"] > 4.0
    assert any("rejected" in n and "sub-steps" in n for n in capped.notes)


def test_a_fit_that_cannot_reach_its_target_stops():
    """``cost_target``: a fit whose gain per iteration, repeated over the evaluations left, cannot
    bring its cost down to the target stops early (a rival explains the data far better); without
    a target, or with one it can reach, the same fit runs to its optimum."""
    truth, t, u, y0, ch, clean = _servo_record()
    exps = [gb.Experiment(DT, u, y0, _noisy(clean, SERVO_NOISE, 3))]
    base = dataclasses.replace(truth, bulk_modulus=500e6, viscous_friction=350.0, coulomb_friction=30.0)
    kw = dict(sigma=SERVO_NOISE, reweight=False, jacobian="forward", max_nfev=25)
    free = gb.fit_greybox(base, SERVO_FIT, exps, ch, **kw)
    reachable = gb.fit_greybox(base, SERVO_FIT, exps, ch, cost_target=1.5 * free.cost, **kw)
    hopeless = gb.fit_greybox(base, SERVO_FIT, exps, ch, cost_target=1e-6 * free.cost, **kw)
    assert free.cost == pytest.approx(0.5 * clean["x"].size * len(SERVO_NOISE), rel=0.1)  # at the noise
    assert reachable.cost == free.cost and reachable.nfev == free.nfev  # the same path to the same optimum
    assert "cost_target" in hopeless.message
    assert hopeless.nfev < free.nfev and hopeless.cost > free.cost
