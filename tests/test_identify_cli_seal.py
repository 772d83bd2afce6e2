"""`hydro identify friction --plant seal_friction`: geometry from --bore / --area (never a silent
default) and a friction coefficient clamped at its bound refused, on the shipped X-ring records."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from hydro_envs.cli import main
from identification.seal_friction import load_seal_friction, seal_friction_points

DATA = Path(__file__).resolve().parent / "data" / "pneumatic_seal_friction"
FILE = str(DATA / "X-ring257_3bar.csv")
BASE = ["identify", "friction", "--plant", "seal_friction", "--data", FILE, "--drop-rows", "5"]


def _json(capsys, argv):
    code = main(argv + ["--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def test_without_geometry_is_an_error(capsys):
    assert main(BASE + ["--model", "coulomb"]) != 0
    err = capsys.readouterr().err
    assert "no geometry" in err and "--bore" in err and "--area" in err
    assert main(BASE + ["--model", "coulomb", "--bore", "0.0257", "--area", "5e-4"]) != 0
    assert "not both" in capsys.readouterr().err


def test_bore_and_area_agree_and_set_the_friction(capsys):
    bore = 0.0257
    area = math.pi * bore**2 / 4
    a = _json(capsys, BASE + ["--model", "coulomb", "--bore", repr(bore)])
    b = _json(capsys, BASE + ["--model", "coulomb", "--area", repr(area)])
    assert a["area"] == pytest.approx(area, rel=1e-15)
    assert a["parameters"]["F_c"] == pytest.approx(b["parameters"]["F_c"], rel=1e-12)
    assert a["parameters"]["F_c"] == pytest.approx(_raw_half_hysteresis(FILE, area), rel=0.06)
    # a different bore moves the friction by (A2 - A1) * mean pressure: the area is used
    c = _json(capsys, BASE + ["--model", "coulomb", "--bore", "0.025"])
    assert abs(c["parameters"]["F_c"] - a["parameters"]["F_c"]) > 0.05


def _raw_half_hysteresis(path: str, area: float) -> float:
    """Independent truth from the raw columns (numpy only, none of the package's code): half the
    difference of the mean friction ``F_loadcell - p A`` while extending and while retracting,
    over the samples faster than half the stroke speed (turnarounds left out)."""
    d = np.loadtxt(path)[5:]
    t, x, p, f_lc = d[:, 0] / 1e3, d[:, 4] / 1e3, d[:, 5] * 1e5, d[:, 6]
    v = np.gradient(x, t)
    fr = f_lc - p * area
    fast = 0.5 * np.percentile(np.abs(v), 90)
    return 0.5 * (np.mean(fr[v > fast]) - np.mean(fr[v < -fast]))


def test_coulomb_level_is_half_the_raw_hysteresis_and_rises_with_pressure(capsys):
    """1-7 bar: the identified Coulomb level within 6 % of half the friction hysteresis read off
    the raw columns, and rising with the chamber pressure."""
    bore = 0.0257
    area = math.pi * bore**2 / 4
    levels = []
    for bar in (1, 3, 5, 7):
        path = str(DATA / f"X-ring257_{bar}bar.csv")
        fc = _json(capsys, ["identify", "friction", "--plant", "seal_friction", "--data", path, "--drop-rows", "5",
                            "--model", "coulomb", "--bore", repr(bore)])["parameters"]["F_c"]
        assert fc == pytest.approx(_raw_half_hysteresis(path, area), rel=0.06), bar
        levels.append(fc)
    assert levels == sorted(levels)


def test_loader_without_bore_keeps_no_area():
    data = load_seal_friction(FILE, drop_rows=5, bore=None)
    assert "piston_area" not in data.metadata and "bore" not in data.metadata
    with pytest.raises(ValueError, match="piston_area is unknown"):
        seal_friction_points(data)
    with pytest.raises(ValueError, match="bore = -1"):
        load_seal_friction(FILE, bore=-1.0)


def test_clamped_coefficient_is_an_error(capsys):
    from identification.cli import _refuse_clamped

    with pytest.raises(ValueError, match="F_v_neg = 0 N s/m is clamped at its bound 0"):
        _refuse_clamped({"F_c_neg": 3.0, "F_v_neg": 0.0}, {"F_c_neg": 0.1, "F_v_neg": 50.0},
                        {"F_v_neg": "N s/m"}, "coulomb_viscous")
    _refuse_clamped({"F_c": 3.0, "F_v": 12.0}, {"F_c": 0.1, "F_v": 5.0}, {}, "coulomb_viscous")


@pytest.mark.parametrize("flag,value", [("--area", "-1"), ("--area", "0"), ("--bore", "-0.025"), ("--bore", "nan")])
def test_nonpositive_geometry_is_refused_naming_the_flag(flag, value, capsys):
    from hydro_envs.cli import main as hydro

    record = Path(__file__).parent / "data" / "seal_friction_oring" / "O-ring_5bar_3cycles.csv"
    code = hydro(["identify", "friction", "--plant", "seal_friction", "--data", str(record), flag, value,
                  "--model", "coulomb"])
    err = capsys.readouterr().err
    assert code == 2 and f"{flag} = " in err and "allowed" in err and len(err.splitlines()) == 1


@pytest.mark.parametrize("flag,value,meant", [("--bore", "25", "0.025 m"), ("--area", "490", "0.00049 m^2")])
def test_geometry_in_mm_is_refused_naming_the_si_value(flag, value, meant, capsys):
    from hydro_envs.cli import main as hydro

    record = Path(__file__).parent / "data" / "seal_friction_oring" / "O-ring_5bar_3cycles.csv"
    code = hydro(["identify", "friction", "--plant", "seal_friction", "--data", str(record), flag, value,
                  "--model", "coulomb"])
    err = capsys.readouterr().err
    assert code == 2 and f"{flag} = {value} " in err and meant in err, err
