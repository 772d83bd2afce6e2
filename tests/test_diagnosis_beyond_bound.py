"""An effect whose best fit lies beyond its plausible bound is reported with its value and the
bound ("check the rig"), never dropped without a word (issue 56 item 3): a servo record with an
internal leak of 2e-11 m^3/(s Pa), four times the catalogue's plausible 5e-12."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from identification.diagnosis import diagnose, diagnosis_plant
from identification.diagnosis.synthetic import base_for, closed_loop_record
from identification.diagnosis.decision import implausible_best_notes
from identification.diagnosis.models import Model, with_effect


def test_a_better_but_implausible_candidate_is_noted_with_its_value_and_bound():
    def cand(name, heldout, gain, plausible, reasons=()):
        return SimpleNamespace(name=name, heldout=heldout, gain=gain, plausible=plausible, identifiable=True,
                               reasons=list(reasons))

    leak = cand("internal_leakage", 0.01, 0.9, False, ["internal_leakage = 2e-11 outside its plausible range"])
    lap = cand("valve_lap", 0.05, 0.5, True)
    notes = implausible_best_notes([leak, lap], "valve_lap", 0.02, 1)
    assert len(notes) == 1 and "internal_leakage = 2e-11 outside its plausible range" in notes[0]
    assert "check the rig" in notes[0]
    assert implausible_best_notes([lap, cand("x", 0.09, 0.1, False)], "valve_lap", 0.02, 1) == []  # worse
    assert len(implausible_best_notes([leak], "none", 0.02, 2)) == 1
    assert len(implausible_best_notes([leak, lap], "ambiguous: valve_lap vs coulomb", 0.02, 1)) == 1


@pytest.fixture(scope="module")
def leak_run():
    spec = diagnosis_plant("servo_cylinder")
    base = Model(base_for(spec, "internal_leakage"))
    truth = with_effect(spec, base, "internal_leakage", {"internal_leakage": 2e-11})
    rng = np.random.default_rng(7)
    fit = closed_loop_record(spec, truth, 6.0, spec.sample_time, rng, "leak fit")
    hold = closed_loop_record(spec, truth, 3.0, spec.sample_time, rng, "leak hold")
    return diagnose(spec, [fit], [hold], base=base.params)


def test_a_leak_beyond_its_plausible_bound_is_reported_not_dropped(leak_run):
    res = leak_run
    assert "internal_leakage" not in [e["name"] for e in res.effects]  # not named: beyond the bound
    note = next(n for n in res.notes if n.startswith("round 1: internal_leakage"))
    value = float(note.split("internal_leakage = ")[1].split()[0])
    assert value == pytest.approx(2e-11, rel=0.15)  # the fitted value, reported
    assert "outside its plausible range [1e-15, 5e-12]" in note and "check the rig" in note
    assert "beyond its plausible bound, not named: internal_leakage" in res.reason
