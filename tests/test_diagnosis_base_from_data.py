"""The diagnosis base model read off the record: a heavy force-driven axis (60 kg, 150 N s/m,
0.3 m of travel; the slider's nominal model is 1 kg on 0.2 m) with 15 N Coulomb friction, from a
generator independent of the workflow (scipy Radau under a PD loop). Without a preset the
workflow estimates mass, damping and stroke from the record (inverse dynamics), sizes its
windows from the axis' time constant m / b, and names the dry friction at its value; with a
constant force of -3 N added (as the EMPS reference model carries), neither effect alone wins
a round, and the pair round names both (also where a backlash alone wins a round but leaves
the record unexplained: the pair explains it)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from identification.diagnosis import DiagnosisDataError, Record, diagnose, diagnosis_plant
from identification.diagnosis.base_estimates import estimate_base
from identification.diagnosis.models import null_base

DT = 1e-3
M, B, FC, V_EPS = 60.0, 150.0, 15.0, 5e-4


def heavy_axis_record(seed: int, duration: float, f0: float = 0.0) -> Record:
    """PD loop (12 rad/s, zeta 0.8) tracking slow sines of 0.1-1.1 Hz over 0.07..0.31 m; the
    recorded force of sample k is the mean force over [t_k, t_k+1); 1 um encoder noise; ``f0``: a
    constant force [N] opposing +x that the recorded force does not contain."""
    rng = np.random.default_rng(seed)
    f = np.array([0.1, 0.23, 0.5, 1.1])
    a = np.array([0.07, 0.035, 0.012, 0.004])
    ph = rng.uniform(0, 2 * np.pi, f.size)
    w = 2 * np.pi * f

    def force(t, x, v):
        r = 0.19 + np.sum(a * np.sin(w * t + ph))
        dr = np.sum(a * w * np.cos(w * t + ph))
        return M * (12.0**2 * (r - x) + 2 * 0.8 * 12.0 * (dr - v))

    def rhs(t, y):
        x, v, _ = y
        fa = force(t, x, v)
        return [v, (fa - f0 - B * v - FC * np.tanh(v / V_EPS)) / M, fa]

    n = int(round(duration / DT)) + 1
    tt = DT * np.arange(n + 1)
    with np.errstate(over="ignore"):  # the finite-difference Jacobian probes far into the tanh
        sol = solve_ivp(rhs, (0.0, tt[-1]), [0.19, 0.0, 0.0], method="Radau", t_eval=tt, rtol=1e-7, atol=1e-10)
    assert sol.success, sol.message
    x = sol.y[0, :n] + 1e-6 * rng.standard_normal(n)
    fs = np.diff(sol.y[2]) / DT
    return Record(DT, fs, {"x": x}, f"heavy axis seed {seed}")


@pytest.fixture(scope="module")
def record():
    return heavy_axis_record(11, 24.0)


def test_the_base_model_is_read_off_the_record(record):
    spec = diagnosis_plant("slider")
    base, note = estimate_base(spec, null_base(spec), [record])
    assert base.mass == pytest.approx(M, rel=0.03)
    assert base.viscous_friction == pytest.approx(B, rel=0.1)
    assert base.stroke > float(record.channels["x"].max())
    assert base.coulomb_friction == 0.0 and base.force_offset == 0.0  # effects are the diagnosis' job
    assert "inverse dynamics" in note


def test_without_a_preset_the_dry_friction_is_named_first(record):
    res = diagnose("slider", [record], None, max_effects=2, maps=False)
    assert any(n.startswith("base model read off the record") for n in res.notes), res.notes
    assert any(n.startswith("windows:") for n in res.notes), res.notes
    assert res.effects and res.effects[0]["name"] == "coulomb", (res.verdict, res.effects, res.rounds[0].decision)
    assert res.verdict == "named"
    assert res.final_model.params.coulomb_friction == pytest.approx(FC, rel=0.05)
    assert res.final_model.params.mass == pytest.approx(M, rel=0.05)


def test_a_position_below_the_lower_stop_is_an_error(record):
    spec = diagnosis_plant("slider")
    bad = Record(DT, record.inputs[:, 0], {"x": record.channels["x"] - 0.1}, "shifted")
    with pytest.raises(DiagnosisDataError, match="below the lower end stop"):
        estimate_base(spec, null_base(spec), [bad])


@pytest.mark.slow  # 20-80 s: run by make test-all
def test_two_effects_that_win_only_together_are_named_as_a_pair():
    rec = heavy_axis_record(11, 24.0, f0=-3.0)
    res = diagnose("slider", [rec], None, max_effects=2, maps=False)
    assert res.verdict == "named", (res.verdict, res.reason)
    assert sorted(e["name"] for e in res.effects) == ["coulomb", "force_offset"]
    assert all(e.get("pair") == res.rounds[0].decision for e in res.effects)
    lost = [e["explained_in_final_model"] for e in res.effects]  # listed by what each explains
    assert lost == sorted(lost, reverse=True) and lost[-1] > 0
    singles = {c.name: c for c in res.rounds[0].candidates if "+" not in c.name}
    for name in ("coulomb", "force_offset"):  # neither true effect wins alone
        c = singles[name]
        assert not (c.gain >= 0.1 and c.identifiable and c.plausible), (name, c.gain, c.reasons)
    # a single that wins (a backlash can mimic part of the pair's signature) must leave the record
    # unexplained, and the pair must explain clearly more
    pair = next(c for c in res.rounds[0].candidates if c.name == res.rounds[0].decision)
    for c in singles.values():
        if c.gain >= 0.1 and c.identifiable and c.plausible:
            assert pair.heldout * 1.15 < c.heldout, (c.name, c.heldout, pair.heldout)
    p = res.final_model.params
    assert p.coulomb_friction == pytest.approx(FC, rel=0.05)
    assert p.force_offset == pytest.approx(-3.0, rel=0.1)
    # with room for one effect only, no pair is tried
    one = diagnose("slider", [rec], None, max_effects=1, maps=False)
    assert not any("+" in c.name for r in one.rounds for c in r.candidates)


def test_a_record_zeroed_elsewhere_is_shifted_inside_the_stops(record):
    """An encoder zeroed mid-travel (positions below 0): without a preset the record is moved
    inside the base model's stops, a note says by how much, and the result is the same."""
    low = Record(DT, record.inputs[:, 0], {"x": record.channels["x"] - 0.2}, "zeroed mid-travel")
    res = diagnose("slider", [low], None, max_effects=1, maps=False)
    assert any(n.startswith("position 'x' shifted by +0.") for n in res.notes), res.notes
    assert [e["name"] for e in res.effects] == ["coulomb"]
    assert res.final_model.params.coulomb_friction == pytest.approx(FC, rel=0.05)
