"""The threshold of verdict ``unexplained`` adapts to the record and says what it used (issue 56
item 1): twice the residual a correct model is expected to leave on the record (the noise floor,
the start-state error the noise and mains lines cause, the lines' in-band part) times the
pure-noise spread over the record's independent scored samples, at least the plant's
``unexplained_factor``.

Records: the rigid axis of tests/test_diagnosis_unexplained.py (scipy Radau, independent of the
workflow's kernels), effect-free with and without 1 um of 50 Hz hum, and with a backlash.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from identification.diagnosis import diagnosis_plant
from identification.diagnosis.decision import verdict_reason
from identification.diagnosis.floor import (
    THRESHOLD_MARGIN,
    line_part,
    mains_lines,
    noise_floor,
    spread_factor,
    threshold_factor,
)
from identification.diagnosis.models import Model
from identification.diagnosis.synthetic import base_for
from identification.diagnosis.workflow import prepare
from test_diagnosis_unexplained import _run, axis_record, backlash_outside_the_catalogue

DT = 1e-3


def test_the_noise_spread_shrinks_with_more_samples_and_the_factor_keeps_its_minimum():
    assert spread_factor(100) > spread_factor(1000) > spread_factor(10000) > 1
    assert spread_factor(50) == pytest.approx(1 + 3 / 10)
    assert threshold_factor(10.0, 1.2, 1.1) == 10.0
    assert threshold_factor(10.0, 6.0, 1.1) == pytest.approx(THRESHOLD_MARGIN * 6.0 * 1.1)


def test_a_line_beyond_the_score_band_counts_little():
    assert line_part([(10.0, 1.0)], DT, 50.0) == pytest.approx(1 / np.sqrt(2), rel=0.01)
    assert line_part([(200.0, 1.0)], DT, 50.0) < 0.05
    assert line_part([], DT, 50.0) == 0.0


def test_mains_lines_are_found_in_the_residual_but_not_where_the_model_has_them_too():
    rng = np.random.default_rng(3)
    t = DT * np.arange(500)
    motion = 0.02 * np.sin(2 * np.pi * 0.7 * t)
    noise = [1e-6 * rng.standard_normal(t.size) for _ in range(6)]
    hum = [n + 1e-6 * np.sin(2 * np.pi * 50 * t + k) for k, n in enumerate(noise)]
    got = mains_lines([(r, motion) for r in hum], DT)
    assert [f for f, _ in got] == [50.0] and got[0][1] == pytest.approx(1e-6, rel=0.2)
    assert mains_lines([(r, motion) for r in noise], DT) == []
    excited = motion + 1e-3 * np.sin(2 * np.pi * 50 * t)  # the model reproduces a 50 Hz excitation
    assert mains_lines([(r, excited) for r in hum], DT) == []


def _floor(hold: float, minimum: float | None = None, **kw):
    spec = diagnosis_plant("slider")
    if minimum is not None:
        spec = dataclasses.replace(spec, unexplained_factor=minimum)
    data = prepare(spec, [axis_record(None, 3, 5.0, **kw)], [axis_record(None, 1003, hold, **kw)],
                   base=base_for(spec, None), effects=None, holdout_fraction=0.3)
    return noise_floor(data.spec, Model(data.base), data.holdout)["x"]


def test_a_longer_record_gives_a_tighter_threshold():
    short, long_ = _floor(2.0, minimum=1.0), _floor(12.0, minimum=1.0)
    assert long_["n_eff"] > 4 * short["n_eff"]
    assert long_["spread"] < short["spread"]
    assert long_["factor"] < short["factor"]  # the plant's minimum set below both
    for fl in (short, long_):
        assert fl["factor"] == pytest.approx(THRESHOLD_MARGIN * fl["expected"] * fl["spread"])


def test_hum_raises_the_expected_residual_and_says_where():
    clean, hum = _floor(3.0), _floor(3.0, hum=1e-6)
    assert clean["lines_hz"] == [] and clean["lines"] == 0.0 and clean["expected"] < 1.1
    assert hum["lines_hz"] == [50.0] and hum["lines"] > 0.5 * hum["floor"]
    assert hum["start_state"] > clean["start_state"] and hum["expected"] > 1.3
    assert clean["factor"] == hum["factor"] == 10.0  # both below the slider's minimum
    assert clean["minimum_factor"] == 10.0 and "max(plant minimum" in clean["rule"]


def test_the_verdict_compares_each_channel_with_its_own_threshold():
    floor = {"x": {"floor": 1.0, "factor": 15.0, "expected": 7.0, "spread": 1.07, "minimum_factor": 10.0}}
    mismatch = {"channel": "x", "rms": 12.0, "unit": "m", "ratio": 12.0, "floor": 1.0}
    name, why = verdict_reason([], "", {"x": 12.0}, floor, mismatch, "base model")
    assert name == "none" and "<= 15" in why and "7 floors a correct model" in why
    floor["x"].update(factor=10.0, expected=1.2)
    name, why = verdict_reason([], "", {"x": 12.0}, floor, mismatch, "base model")
    assert name == "unexplained" and "above 10 noise floors, the plant's minimum" in why


def test_effect_free_gives_none_and_backlash_outside_the_catalogue_unexplained_with_the_threshold_reported():
    from identification.diagnosis.cli import summary_text

    free = _run(None, 3, hum=1e-6, offset=2e-3)
    assert free.verdict == "none", (free.verdict, free.reason)
    assert free.noise_floor["x"]["lines_hz"] == [50.0]
    assert free.residual[-1]["floors"]["x"] <= free.noise_floor["x"]["factor"]
    back = backlash_outside_the_catalogue()[0]
    assert back.verdict in ("unexplained", "ambiguous"), (back.verdict, back.reason)
    if back.verdict == "unexplained":
        assert back.mismatch["factor"] == back.noise_floor["x"]["factor"] and "noise floors" in back.reason
    d = json.loads(json.dumps(back.to_json_dict(), allow_nan=False))
    assert {"start_state", "lines", "n_eff", "expected", "spread", "factor", "threshold"} <= set(d["noise_floor"]["x"])
    assert "expected" in summary_text(back) and "N_eff" in summary_text(back)
