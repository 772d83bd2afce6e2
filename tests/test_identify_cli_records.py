"""`hydro identify` reading foreign records through the loader options (--map, --units,
--map-file, --allow-gaps) and the slider options --stribeck / --asymmetric.

The truth of each loader test is the same record written in the package's own SI format: the
identified parameters must be identical, whatever the column names, order, units and products.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from hydro_envs.cli import main
from hydro_envs.data.measured import write_measured


def _run(capsys, argv):
    code = main(argv)
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


@pytest.fixture(scope="module")
def slider_record():
    from hydro_envs.plants.slider.model import simulate_slider
    from hydro_envs.plants.slider.params import SliderParams

    p = SliderParams()
    dt = 1e-3
    t = dt * np.arange(20000)
    force = 25.0 * np.sin(2 * np.pi * 5.0 * t) + 8.0 * np.sin(2 * np.pi * 1.3 * t)
    x = simulate_slider(p, force, dt)[:-1, 0] + 1e-6 * np.random.default_rng(2).standard_normal(t.size)
    return p, t, force, x


def _foreign_csv(path, t, force, x):
    """Semicolon CSV: time in ms, position in mm, force as drive * gain, columns reordered."""
    gain = 4.0
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("pos;drive;time;gain\n")
        for ti, fi, xi in zip(t, force, x):
            fh.write(f"{float(xi) * 1e3!r};{float(fi) / gain!r};{float(ti) * 1e3!r};{gain!r}\n")


def test_slider_map_and_units_equal_si_record(tmp_path, capsys, slider_record):
    p, t, force, x = slider_record
    si = tmp_path / "si.csv"
    write_measured(si, t, {"f": force, "x": x}, plant="slider")
    foreign = tmp_path / "foreign.csv"
    _foreign_csv(foreign, t, force, x)
    ref = _run(capsys, ["identify", "slider", "--data", str(si), "--stribeck", "none", "--json"])
    got = _run(capsys, ["identify", "slider", "--data", str(foreign), "--stribeck", "none",
                        "--map", "t=time[ms],x=pos,f=drive*gain[N]", "--units", "x=mm", "--json"])
    for k, v in ref["parameters"].items():
        if v is not None:
            assert got["parameters"][k] == pytest.approx(v, rel=1e-9, abs=1e-12), k
    assert got["parameters"]["mass"] == pytest.approx(p.mass, rel=0.05)
    # the same map as a YAML file
    side = tmp_path / "map.yaml"
    side.write_text("map:\n  t: {from: time, unit: ms}\n  x: {from: pos, unit: mm}\n"
                    "  f: {from: drive * gain, unit: N}\n", encoding="utf-8")
    got2 = _run(capsys, ["identify", "slider", "--data", str(foreign), "--stribeck", "none",
                         "--map-file", str(side), "--json"])
    assert got2["parameters"] == got["parameters"]


def test_slider_without_units_is_an_error_naming_the_column(tmp_path, capsys, slider_record):
    _, t, force, x = slider_record
    foreign = tmp_path / "foreign.csv"
    _foreign_csv(foreign, t[:3000], force[:3000], x[:3000])
    code = main(["identify", "slider", "--data", str(foreign), "--map", "t=time,x=pos,f=drive*gain"])
    err = capsys.readouterr().err
    assert code != 0
    assert "no unit" in err and "'t'" in err


def test_slider_default_is_auto_and_asymmetric_prints_directions(tmp_path, capsys, slider_record):
    p, t, force, x = slider_record
    si = tmp_path / "si.csv"
    write_measured(si, t, {"f": force, "x": x}, plant="slider")
    res = _run(capsys, ["identify", "slider", "--data", str(si), "--json"])
    assert res["stribeck"] in ("none", "fit")  # chosen by 'auto'
    assert any("stribeck='auto'" in n for n in res["notes"])
    res = _run(capsys, ["identify", "slider", "--data", str(si), "--asymmetric", "--json"])
    d, se = res["direction_parameters"], res["direction_std_errors"]
    # the simulated slider's friction is symmetric: both directions recover it
    for side in ("pos", "neg"):
        assert d[f"coulomb_friction_{side}"] == pytest.approx(p.coulomb_friction, rel=0.15)
        assert se[f"coulomb_friction_{side}"] > 0
    assert main(["identify", "slider", "--data", str(si), "--asymmetric"]) == 0
    out = capsys.readouterr().out
    assert "per direction of motion:" in out and "coulomb_friction_neg = " in out and "+-" in out


def test_allow_gaps_is_passed_to_the_loader(tmp_path, capsys):
    rng = np.random.default_rng(0)
    n, dt = 4000, 1e-3
    t = dt * np.arange(n)
    t[n // 2:] += 0.5  # a half-second logger pause
    u = np.sign(rng.standard_normal(n))
    y = np.convolve(u, [0.0, 1.0, 0.5])[:n]
    f = tmp_path / "gap.csv"
    write_measured(f, t, {"f": u, "x": y}, plant="slider")
    argv = ["identify", "arx", "--plant", "slider", "--data", str(f), "--input", "f", "--output", "x",
            "--orders", "0", "2", "1", "--stroke", "10"]
    assert main(argv) != 0  # a check option switches the loader's checks on: the gap is refused
    assert "gap" in capsys.readouterr().err.lower()
    res = _run(capsys, argv + ["--allow-gaps", "--json"])
    assert any("2 gap-separated segments" in n for n in res["notes"])
    # only the longest segment (2000 samples, 70 % for estimation) is fitted, not all 4000
    assert res["metrics"]["n_samples"] < 1400
    assert res["parameters"]["b1"] == pytest.approx(1.0, abs=1e-5)
    assert res["parameters"]["b2"] == pytest.approx(0.5, abs=1e-5)


def test_sidecar_beside_the_data_is_not_used_and_a_note_says_so(tmp_path, capsys, slider_record):
    p, t, force, x = slider_record
    si = tmp_path / "run.csv"
    write_measured(si, t, {"f": force, "x": x}, plant="slider")
    ref = _run(capsys, ["identify", "slider", "--data", str(si), "--stribeck", "none", "--json"])
    (tmp_path / "run.yaml").write_text("units: {x: mm}\n")  # read as mm the positions shrink 1000 x
    got = _run(capsys, ["identify", "slider", "--data", str(si), "--stribeck", "none", "--json"])
    assert got["parameters"] == ref["parameters"]
    assert any("run.yaml lies beside the data and was not used" in n for n in got["notes"])
    named = _run(capsys, ["identify", "slider", "--data", str(si), "--stribeck", "none", "--json", "--map-file",
                          str(tmp_path / "run.yaml")])
    assert named["parameters"]["mass"] > 100 * ref["parameters"]["mass"]  # used when named
