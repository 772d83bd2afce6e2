"""Fit-quality gate of frf, arx and grey-box results, and the progress line of long fits."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from scipy import signal

from identification import cli, quality

FS = 1000.0
M, C, K = 2.0, 60.0, 2.0e4  # kg, N s/m, N/m


def _write(path, u, y):
    t = np.arange(u.size) / FS
    with open(path, "w") as f:
        f.write("# plant: servo_cylinder\nt [s],u [V],x [m]\n")
        for a, b, c in zip(t, u, y):
            f.write(f"{float(a)!r},{float(b)!r},{float(c)!r}\n")
    return path


def _msd_record(path, noise=0.0, n=8000, seed=0):
    """Position of a ZOH-driven mass-spring-damper under white force, plus output noise."""
    A, B, Cm, D, _ = signal.cont2discrete((np.array([[0.0, 1.0], [-K / M, -C / M]]), np.array([[0.0], [1.0 / M]]),
                                           np.array([[1.0, 0.0]]), np.array([[0.0]])), 1.0 / FS, method="zoh")
    rng = np.random.default_rng(seed)
    u = 100.0 * rng.standard_normal(n)
    _, y, _ = signal.dlsim((A, B, Cm, D, 1.0 / FS), u)
    y = y.ravel()
    y = y + noise * np.std(y) * rng.standard_normal(n)
    return _write(path, u, y)


def _third_order_record(path, n=8000, seed=0):
    """An integrator behind a 2nd-order low-pass: no mass-spring-damper explains it."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    b, a = signal.butter(2, 0.05)
    y = signal.lfilter(1e-3 * b, np.convolve(a, [1.0, -1.0]), u)
    return _write(path, u, y)


def _run(capsys, argv):
    code = cli.main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_assess_flags_the_known_bad_frf_case():
    res = {"parameters": {"mass": 321.0, "damping": 10.0, "stiffness": 1e4},
           "std_errors": {"mass": 229544.0, "damping": 1.0, "stiffness": 10.0},
           "units": {"mass": "kg"}, "metrics": {"fit_percent": 1.0, "n_points": 40}}
    q = quality.assess(res, "frf")
    assert q["ok"] is False
    assert len(q["reasons"]) == 2
    assert "fit_percent = 1 %" in q["reasons"][0]
    assert "mass" in q["reasons"][1] and "7.15e+04 %" in q["reasons"][1]  # 229544 / 321
    assert quality.warning_lines(q)[0].startswith("warning: poor fit")


def test_assess_thresholds_are_the_documented_ones():
    good = {"parameters": {"a": 1.0}, "std_errors": {"a": 1.0}, "metrics": {"fit_percent": 50.0, "n_points": 10}}
    assert quality.assess(good, "frf")["ok"]  # exactly at the thresholds passes
    assert not quality.assess({**good, "std_errors": {"a": 1.0001}}, "frf")["ok"]
    assert not quality.assess({**good, "metrics": {"fit_percent": 49.9, "n_points": 10}}, "frf")["ok"]
    assert not quality.assess({**good, "metrics": {"fit_percent": 90.0, "n_points": 9}}, "frf")["ok"]
    # arx: the held-out free-run fit decides, not the one-step fit
    arx = {"parameters": {}, "metrics": {"fit_one_step_percent": 99.9, "heldout_fit_free_run": 30.0}}
    assert not quality.assess(arx, "arx")["ok"]
    # greybox: 100 (1 - NRMSE) per channel
    gb = {"parameters": {}, "metrics": {"nrmse_x": 0.2, "nrmse_p1": 0.6}}
    q = quality.assess(gb, "greybox")
    assert not q["ok"] and len(q["reasons"]) == 1 and "fit_p1 = 40 %" in q["reasons"][0]
    # greybox: a fit whose optimiser ran out of evaluations is not a minimum
    stopped = {"parameters": {}, "metrics": {"nrmse_x": 0.01}, "success": False,
               "message": "The maximum number of function evaluations is exceeded."}
    q = quality.assess(stopped, "greybox")
    assert not q["ok"] and len(q["reasons"]) == 1 and "did not converge" in q["reasons"][0]
    assert quality.assess({**stopped, "success": True}, "greybox")["ok"]
    # a zero estimate with any error is flagged
    assert not quality.assess({"parameters": {"a": 0.0}, "std_errors": {"a": 1e-9}, "metrics": {}}, "arx")["ok"]


def test_frf_good_record_passes_and_noisy_record_warns(tmp_path, capsys):
    good = _msd_record(tmp_path / "good.csv")
    code, out, _ = _run(capsys, ["frf", "--plant", "servo_cylinder", "--data", str(good), "--input", "u",
                                 "--output", "x", "--json"])
    assert code == 0
    res = json.loads(out)
    assert res["quality"]["ok"] is True and res["quality"]["reasons"] == []
    assert res["parameters"]["mass"] == pytest.approx(M, rel=0.02)

    bad = _third_order_record(tmp_path / "bad.csv")
    code, out, _ = _run(capsys, ["frf", "--plant", "servo_cylinder", "--data", str(bad), "--input", "u",
                                 "--output", "x"])
    assert code == 0
    warn = [ln for ln in out.splitlines() if ln.startswith("warning: poor fit")]
    assert warn, out
    code, out, _ = _run(capsys, ["frf", "--plant", "servo_cylinder", "--data", str(bad), "--input", "u",
                                 "--output", "x", "--json"])
    q = json.loads(out)["quality"]
    assert q["ok"] is False and len(q["reasons"]) == len(warn) >= 2
    assert any(r.startswith("fit_percent") for r in q["reasons"])
    assert any("relative standard error" in r for r in q["reasons"])


def test_arx_gate_in_json(tmp_path, capsys):
    bad = _msd_record(tmp_path / "bad.csv", noise=3.0, n=3000)
    code, out, _ = _run(capsys, ["arx", "--plant", "servo_cylinder", "--data", str(bad), "--input", "u",
                                 "--output", "x", "--orders", "2", "2", "1", "--json"])
    assert code == 0
    res = json.loads(out)
    assert res["metrics"]["heldout_fit_free_run"] < 50.0
    assert res["quality"]["ok"] is False


def test_progress_is_silent_for_short_runs_and_prints_k_of_n_for_long_ones():
    s = io.StringIO()
    p = quality.Progress("fit", 10, stream=s)  # default: 2 s delay
    for i in range(10):
        p(i)
    p.close()
    assert s.getvalue() == ""
    s = io.StringIO()
    p = quality.Progress("fit", 10, unit="steps", stream=s, delay=0.0, interval=0.0)
    for i in range(3):
        p(i)
    lines = s.getvalue().splitlines()
    assert [ln.split(" (")[0] for ln in lines] == ["fit: 0/10 steps", "fit: 1/10 steps", "fit: 2/10 steps"]


def test_library_fits_accept_a_progress_callback():
    from identification.arx import select_arx_order
    from identification.frf import identify_msd_from_time_series

    rng = np.random.default_rng(1)
    u = rng.standard_normal(2000)
    y = signal.lfilter([0.0, 0.5], [1.0, -0.8], u)
    calls = []
    select_arx_order(y, u, range(1, 3), range(1, 3), range(0, 2), progress=lambda k, n: calls.append((k, n)))
    assert calls == [(i, 8) for i in range(8)]
    calls = []
    identify_msd_from_time_series(u, y, 100.0, method="magnitude", min_coherence=None,
                                  progress=lambda k, n: calls.append((k, n)))
    assert calls and calls[-1][1] == 2000 and [c[0] for c in calls] == list(range(1, len(calls) + 1))
