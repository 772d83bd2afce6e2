"""`hydro identify arx|frf|slider` end to end: simulated data with known parameters written in
the measured-data format, identified through the CLI's JSON output."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import signal

from hydro_envs.cli import main
from hydro_envs.data.measured import write_measured

# generic input/output records are stored as a registered plant's channels: the slider's
# force (input) and position (output)


def _run(capsys, argv):
    code = main(argv)
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


def test_identify_arx_recovers_coefficients(tmp_path, capsys):
    rng = np.random.default_rng(0)
    n, dt = 4000, 1e-3
    u = np.sign(rng.standard_normal(n))  # random binary input
    # y[k] = 1.5 y[k-1] - 0.7 y[k-2] + 1.0 u[k-1] + 0.5 u[k-2] + e[k]
    y = signal.lfilter([0.0, 1.0, 0.5], [1.0, -1.5, 0.7], u) + signal.lfilter([1.0], [1.0, -1.5, 0.7], 0.01 * rng.standard_normal(n))
    f = tmp_path / "arx.csv"
    # y in cm as x [m]: within the slider's stroke (a record beyond it is refused as mm under [m])
    write_measured(f, dt * np.arange(n), {"f": u, "x": 0.01 * y}, plant="slider")
    res = _run(capsys, ["identify", "arx", "--plant", "slider", "--data", str(f), "--input", "f",
                        "--output", "x", "--orders", "2", "2", "1", "--json"])
    p = res["parameters"]
    assert p["a1"] == pytest.approx(-1.5, abs=0.01) and p["a2"] == pytest.approx(0.7, abs=0.01)
    assert 100 * p["b1"] == pytest.approx(1.0, abs=0.02) and 100 * p["b2"] == pytest.approx(0.5, abs=0.02)
    assert res["metrics"]["heldout_fit_free_run"] > 90


def test_identify_frf_recovers_mass_spring_damper(tmp_path, capsys):
    m, c, k, fs = 2.0, 200.0, 2.0e5, 5000.0  # zeta = 0.16: resolved by the default Welch segments
    # state space (x, v): well conditioned, unlike the transfer-function form
    A = np.array([[0.0, 1.0], [-k / m, -c / m]])
    B = np.array([[0.0], [1.0 / m]])
    Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, np.array([[1.0, 0.0]]), np.zeros((1, 1))), 1.0 / fs, method="zoh")
    rng = np.random.default_rng(1)
    u = rng.standard_normal(2**15)
    y = signal.dlsim((Ad, Bd, Cd, Dd, 1.0 / fs), u)[1].ravel()
    f = tmp_path / "msd.csv"
    write_measured(f, np.arange(u.size) / fs, {"f": u, "x": y}, plant="slider")
    res = _run(capsys, ["identify", "frf", "--plant", "slider", "--data", str(f), "--input", "f",
                        "--output", "x", "--json"])
    p = res["parameters"]
    assert p["mass"] == pytest.approx(m, rel=0.03)
    assert p["damping"] == pytest.approx(c, rel=0.05)
    assert p["stiffness"] == pytest.approx(k, rel=0.03)


def test_identify_slider_recovers_mass_and_friction(tmp_path, capsys):
    from hydro_envs.plants.slider.params import SliderParams
    from hydro_envs.plants.slider.model import simulate_slider

    p = SliderParams()
    dt = 1e-3
    t = dt * np.arange(20000)
    # +-15 mm at 5 Hz with slow drift: well inside the 0.2 m stroke, many direction changes
    force = 25.0 * np.sin(2 * np.pi * 5.0 * t) + 8.0 * np.sin(2 * np.pi * 1.3 * t)
    states = simulate_slider(p, force, dt)  # row k is the state at t = k dt
    x = states[:-1, 0] + 1e-6 * np.random.default_rng(2).standard_normal(force.size)
    assert np.ptp(x) < 0.8 * p.stroke
    f = tmp_path / "slider.csv"
    write_measured(f, t, {"f": force, "x": x}, plant="slider")
    res = _run(capsys, ["identify", "slider", "--data", str(f), "--stribeck", "none", "--json"])
    est = res["parameters"]
    assert est["mass"] == pytest.approx(p.mass, rel=0.05)
    assert est["coulomb_friction"] == pytest.approx(p.coulomb_friction, rel=0.1)
