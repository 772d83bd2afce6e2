"""Loading records in a lab's own layout: formats, column map, units, plausibility checks.

Every record is built here in tmp_path from known SI values; the expected SI numbers are
computed independently (hand-written factors), not through hydro_envs.data.units.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.io

from hydro_envs.data import MeasuredDataError, load_measured, write_measured
from hydro_envs.data.units import AMBIENT_PRESSURE, UnitError, conversion, parse_unit

SERVO = "servo_cylinder"  # channels u [V], x [m], p1 [Pa], p2 [Pa]; stroke 0.0696 m
N = 200
DT = 1e-3


def _clock(n=N, jitter=3e-5, seed=0):
    rng = np.random.default_rng(seed)
    return np.arange(n) * DT + rng.uniform(-jitter, jitter, n) * DT


def _servo_si(t):
    return {
        "u": 0.5 * np.sin(40 * t),
        "x": 0.03 + 0.01 * np.sin(20 * t),
        "p1": 5e6 + 1e5 * np.cos(30 * t),
        "p2": 4e6 - 1e5 * np.cos(30 * t),
    }


def _text(path, header, cols, delim, fmt="{:.17g}"):
    lines = ([delim.join(header)] if header else []) + [
        delim.join(fmt.format(v) for v in row) for row in np.column_stack(cols)
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


def _assert_close(a, b):
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)


# ---- units table ---------------------------------------------------------------------------

@pytest.mark.parametrize(
    "unit,si,value,expected",
    [
        ("mm", "m", 12.5, 0.0125), ("um", "m", 3.0, 3e-6), ("cm", "m", 2.0, 0.02),
        ("mm/s", "m/s", 40.0, 0.04), ("kN", "N", 1.5, 1500.0), ("bar", "Pa", 2.0, 2e5),
        ("mbar", "Pa", 5.0, 500.0), ("kPa", "Pa", 7.0, 7000.0), ("MPa", "Pa", 21.0, 21e6),
        ("psi", "Pa", 1.0, 6894.757293168), ("ms", "s", 11.0, 0.011), ("us", "s", 5.0, 5e-6),
        ("mA", "A", 20.0, 0.02), ("deg", "rad", 180.0, math.pi),
        ("bar(g)", "Pa", 2.0, 2e5 + 101325.0), ("barg", "Pa", 1.0, 1e5 + 101325.0),
        ("bar(a)", "Pa", 3.0, 3e5),
    ],
)
def test_unit_conversion_to_si(unit, si, value, expected):
    c = conversion(unit, si, column="q")
    assert c.apply(value) == pytest.approx(expected, rel=1e-15)


def test_gauge_channel_keeps_gauge_and_converts_absolute():
    assert conversion("bar", "Pa", column="p_gauge", gauge_channel=True).apply(2.0) == 2e5
    assert conversion("bar(a)", "Pa", column="p_gauge", gauge_channel=True).apply(2.0) == 2e5 - 101325.0
    assert conversion("bar", "Pa", column="p1", gauge=True).apply(1.0) == 1e5 + 101325.0
    assert parse_unit("g0") == ("g0", None)


def test_unit_errors_name_column_unit_and_expected():
    with pytest.raises(UnitError, match=r"column 'x'.*\[bar\].*\[m\]"):
        conversion("bar", "m", column="x")
    with pytest.raises(UnitError, match=r"column 'x'.*unknown unit \[furlong\].*\[m\]"):
        conversion("furlong", "m", column="x")


# ---- formats ------------------------------------------------------------------------------

@pytest.mark.parametrize("delim", [",", ";", "\t", " "])
def test_delimited_text_with_units_in_header(tmp_path, delim):
    t = _clock()
    si = _servo_si(t)
    header = ["time [ms]", "u [V]", "x [mm]", "p1 [bar]", "p2 [MPa]"]
    cols = [t * 1e3, si["u"], si["x"] * 1e3, si["p1"] / 1e5, si["p2"] / 1e6]
    p = _text(tmp_path / "r.txt", header, cols, delim)
    d = load_measured(p, plant=SERVO, column_map="t=time,u=u,x=x,p1=p1,p2=p2")
    _assert_close(d.t, t)
    for name in ("u", "x", "p1", "p2"):
        _assert_close(d[name], si[name])
    assert d.units == {"t": "s", "u": "V", "x": "m", "p1": "Pa", "p2": "Pa"}
    assert d.segments is None


def test_whitespace_headerless_with_units_flag_and_gauge(tmp_path):
    t = _clock()
    si = _servo_si(t)
    cols = [t, si["u"], si["x"] * 1e3, (si["p1"] - AMBIENT_PRESSURE) / 1e5, (si["p2"] - AMBIENT_PRESSURE) / 1e5]
    p = _text(tmp_path / "r.dat", None, cols, "   ")
    d = load_measured(p, plant=SERVO, column_map="t=c1[s],u=c2[V],x=c3[mm],p1=c4[barg],p2=c5",
                      units="p2=bar(g)")
    _assert_close(d["x"], si["x"])
    _assert_close(d["p1"], si["p1"])
    _assert_close(d["p2"], si["p2"])
    assert "101325" in d.metadata["unit.p1"] and "gauge" in d.metadata["unit.p1"]


def test_mat_file_product_and_constants(tmp_path):
    t = _clock()
    vir = 0.3 * np.sin(7 * t)
    gtau = 35.15
    qm = 0.1 + 0.05 * np.sin(3 * t)
    p = tmp_path / "rig.mat"
    scipy.io.savemat(p, {"t": t[:, None], "qm": qm[:, None], "vir": vir, "gtau": np.array([[gtau]]),
                         "qg": np.zeros(7)})
    d = load_measured(p, plant="slider", column_map="t=t[s],x=qm[m],f=gtau*vir[N]")
    _assert_close(d.t, t)
    _assert_close(d["x"], qm)
    np.testing.assert_allclose(d["f"], gtau * vir, rtol=1e-15)
    assert d.metadata["source.f"] == "gtau*vir"


def test_yaml_sidecar_is_used_only_when_named(tmp_path):
    t = _clock()
    si = _servo_si(t)
    p = _text(tmp_path / "run.csv", None, [t * 1e3, si["x"] * 1e3], ";")
    side = tmp_path / "run.yaml"
    side.write_text("columns: [time, pos]\nmap:\n  t: {from: time, unit: ms}\n  x: pos\nunits: {x: mm}\n")
    with pytest.raises(MeasuredDataError, match=r"run\.yaml lies beside the data and was not used.*--map-file run\.yaml"):
        load_measured(p, plant=SERVO, required=("x",))
    d = load_measured(p, plant=SERVO, required=("x",), column_map=side)
    _assert_close(d["x"], si["x"])
    _assert_close(d.t, t)
    q = write_measured(tmp_path / "own.csv", t, {"x": si["x"]}, plant=SERVO)
    (tmp_path / "own.yaml").write_text("units: {x: mm}\n")
    d = load_measured(q, plant=SERVO, required=("x",))  # own format: read as written, the sidecar noted
    _assert_close(d["x"], si["x"])
    assert len(d.notes) == 1 and "own.yaml" in d.notes[0] and "not used" in d.notes[0]


def test_mat_v73_is_refused_with_conversion_hint(tmp_path):
    p = tmp_path / "big.mat"
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    header = text.ljust(116, b" ") + b"\0" * 8 + b"\x00\x02IM"  # 128-byte MAT header, version 0x0200
    p.write_bytes(header + b"\0" * 384 + b"\x89HDF\r\n\x1a\n" + b"\0" * 512)  # HDF5 superblock at 512
    with pytest.raises(MeasuredDataError, match=r"big\.mat.*(v7\.3|HDF5|MATLAB).*-v7"):
        load_measured(p, plant="slider", column_map="t=t[s],x=qm[m],f=f[N]")


def test_format_v1_round_trip_still_bit_exact(tmp_path):
    t = np.cumsum(np.full(50, 1e-3))
    ch = _servo_si(t)
    p = write_measured(tmp_path / "v1.csv", t, ch, plant=SERVO)
    d = load_measured(p)
    assert np.array_equal(d.t, t) and all(np.array_equal(d[k], v) for k, v in ch.items())
    assert load_measured(p, check=True).segments is None


# ---- column map errors --------------------------------------------------------------------

def test_map_errors_name_the_problem(tmp_path):
    t = _clock()
    p = _text(tmp_path / "r.csv", ["time [s]", "pos [m]"], [t, 0.01 + 0 * t], ";")
    with pytest.raises(MeasuredDataError, match=r"channel 'x'.*'qm'.*available: time, pos"):
        load_measured(p, plant=SERVO, required=("x",), column_map="t=time,x=qm")
    with pytest.raises(MeasuredDataError, match=r"channel 'x' twice"):
        load_measured(p, plant=SERVO, required=("x",), column_map="t=time,x=pos,x=pos")
    with pytest.raises(MeasuredDataError, match=r"'q', which is not a channel"):
        load_measured(p, plant=SERVO, required=("x",), column_map="t=time,q=pos")
    with pytest.raises(MeasuredDataError, match=r"missing required channel\(s\) 'u'"):
        load_measured(p, plant=SERVO, required=("x", "u"), column_map="t=time,x=pos")


def test_missing_unit_in_foreign_file_names_column(tmp_path):
    t = _clock()
    p = _text(tmp_path / "r.csv", ["time [s]", "pos"], [t, 0.01 + 0 * t], "\t")
    with pytest.raises(MeasuredDataError, match=r"column 'x' \(from 'pos'\) has no unit.*\[m\]") as e:
        load_measured(p, plant=SERVO, required=("x",), column_map="t=time,x=pos")
    assert e.value.column == "x"


def test_wrong_dimension_unit_names_column_unit_expected(tmp_path):
    t = _clock()
    p = _text(tmp_path / "r.csv", ["time [s]", "pos [bar]"], [t, 0.01 + 0 * t], ",")
    with pytest.raises(MeasuredDataError, match=r"column 'x'.*\[bar\].*\[m\]"):
        load_measured(p, plant=SERVO, required=("x",), column_map="t=time,x=pos")


# ---- plausibility checks ------------------------------------------------------------------

def _servo_file(tmp_path, t, **over):
    si = dict(_servo_si(t), **over)
    return _text(tmp_path / "s.csv", ["t [s]", "u [V]", "x [m]", "p1 [Pa]", "p2 [Pa]"],
                 [t, si["u"], si["x"], si["p1"], si["p2"]], ";")


def test_mm_under_m_header_is_refused(tmp_path):
    t = _clock()
    p = _servo_file(tmp_path, t, x=(0.03 + 0.01 * np.sin(20 * t)) * 1e3)
    with pytest.raises(MeasuredDataError, match=r"column 'x', row \d+ \(t = .*\): position \d+\.\d+ m is more than 5 x the stroke 0.0696 m; most likely mm under an \[m\]") as e:
        load_measured(p, plant=SERVO, delimiter="semicolon")
    assert e.value.column == "x"


def test_negative_absolute_pressure_is_refused(tmp_path):
    t = _clock()
    p1 = 5e6 + 1e5 * np.cos(30 * t)
    p1[120] = -2.5e4
    p = _servo_file(tmp_path, t, p1=p1)
    with pytest.raises(MeasuredDataError, match=r"column 'p1', row 121 .*absolute pressure not above 0: -25000 Pa"):
        load_measured(p, plant=SERVO, delimiter="semicolon")


def test_pressure_above_physical_maximum_is_refused(tmp_path):
    t = _clock()
    p = _servo_file(tmp_path, t, p2=np.full(N, 2e8))
    with pytest.raises(MeasuredDataError, match=r"column 'p2'.*2e\+08 Pa is above the physical maximum 7e\+07"):
        load_measured(p, plant=SERVO, delimiter="semicolon")


def test_time_not_increasing_and_non_finite(tmp_path):
    t = _clock()
    t[50] = t[49]
    with pytest.raises(MeasuredDataError, match=r"column 't', row 51 .*not strictly increasing"):
        load_measured(_servo_file(tmp_path, t), plant=SERVO, delimiter="semicolon")
    t = _clock()
    u = 0.5 * np.sin(40 * t)
    u[10] = np.nan
    with pytest.raises(MeasuredDataError, match=r"column 'u', row 11: value nan is not finite"):
        load_measured(_servo_file(tmp_path, t, u=u), plant=SERVO, delimiter="semicolon")


def test_jitter_accepted_up_to_tolerance_and_resampled(tmp_path):
    t = _clock(jitter=4e-4)
    d = load_measured(_servo_file(tmp_path, t), plant=SERVO, delimiter="semicolon")
    _assert_close(d.t, t)  # actual timestamps kept
    r = d.resample_uniform()
    assert np.allclose(np.diff(r.t), d.sample_time, rtol=1e-9, atol=0)
    assert r.t[0] == d.t[0] and "resampled" in r.metadata
    t = _clock(jitter=3e-3)
    with pytest.raises(MeasuredDataError, match=r"column 't', row \d+ .*irregular"):
        load_measured(_servo_file(tmp_path, t), plant=SERVO, delimiter="semicolon")
    d = load_measured(_servo_file(tmp_path, t), plant=SERVO, delimiter="semicolon", max_jitter=0.01)
    assert len(d) == N


def test_gap_is_error_unless_allowed_then_segments(tmp_path):
    t = _clock()
    t[80:] += 1.0  # 1 s gap after row 80
    p = _servo_file(tmp_path, t)
    with pytest.raises(MeasuredDataError, match=r"column 't', row 81 .*gap of 1.00.* s.*allow_gaps"):
        load_measured(p, plant=SERVO, delimiter="semicolon")
    d = load_measured(p, plant=SERVO, delimiter="semicolon", allow_gaps=True)
    assert d.segments == [(0, 80), (80, N)]
    assert len(d) == N  # nothing interpolated, nothing dropped
    _assert_close(d.segment(1).t, t[80:])
    with pytest.raises(MeasuredDataError, match="segments"):
        d.resample_uniform()


def test_cli_options_reach_the_loader(tmp_path):
    import argparse

    from hydro_envs.data.cli_args import add_record_arguments, record_kwargs

    t = _clock()
    t[80:] += 1.0
    p = _servo_file(tmp_path, t)
    ap = argparse.ArgumentParser()
    add_record_arguments(ap)
    args = ap.parse_args(["--delimiter", "semicolon", "--allow-gaps", "--units", "x=m"])
    d = load_measured(p, plant=SERVO, **record_kwargs(args))
    assert d.segments == [(0, 80), (80, N)]


def test_a_header_without_units_is_read_as_si_and_says_so(tmp_path):
    """Not silent: the record carries which columns had no unit; identify prints it as a note."""
    from hydro_envs.data.measured import load_measured
    from identification.cli import units_note

    f = tmp_path / "nounits.csv"
    f.write_text("# plant: servo_cylinder\nt,u,x [m],p1,p2\n0,0,0.03,5e6,5e6\n0.001,0,0.03,5e6,5e6\n")
    data = load_measured(f)
    assert data.units_assumed == ("t [s]", "u [V]", "p1 [Pa]", "p2 [Pa]") and "units_assumed" not in data.metadata
    (note,) = units_note(data)
    assert "4 column(s)" in note and "p1 [Pa]" in note
    g = tmp_path / "units.csv"
    g.write_text("# plant: servo_cylinder\nt [s],u [V],x [m],p1 [Pa],p2 [Pa]\n0,0,0.03,5e6,5e6\n0.001,0,0.03,5e6,5e6\n")
    assert load_measured(g).units_assumed == () and units_note(load_measured(g)) == []


# ---- units checked against the plant's physics (issue 53) -------------------------------------

def _own(tmp_path, t, name="own.csv", meta=None, **over):
    si = dict(_servo_si(t), **over)
    return write_measured(tmp_path / name, t, si, plant=SERVO, metadata=meta or {})


@pytest.mark.parametrize("unit,scale", [("bar", 1e5), ("MPa", 1e6), ("kPa", 1e3)])
def test_pressure_in_another_unit_under_pa_is_refused_by_name(tmp_path, unit, scale):
    t = _clock()
    si = _servo_si(t)
    p = _own(tmp_path, t, p1=si["p1"] / scale, p2=si["p2"] / scale)
    with pytest.raises(MeasuredDataError, match=r"column 'p1': values .* Pa; allowed a largest absolute pressure of at "
                       r"least 50662.5 Pa .*they look like .*, not Pa; declare the unit 'p1 \[") as e:
        load_measured(p)
    assert e.value.column == "p1" and unit in str(e.value).split("look like")[1].split(", not Pa")[0]
    assert len(load_measured(_own(tmp_path, t, name="ok.csv", p1=np.full(N, 1.2e5), p2=np.full(N, 1.1e5)))) == N


def test_declared_header_unit_is_converted_then_checked(tmp_path):
    t = _clock()
    si = _servo_si(t)
    rows = "\n".join(f"{a!r},{b!r},{c!r},{d!r},{e!r}" for a, b, c, d, e in
                     zip((t * 1e3).tolist(), si["u"].tolist(), (si["x"] * 1e3).tolist(), (si["p1"] / 1e5).tolist(),
                         (si["p2"] / 1e5).tolist()))
    p = tmp_path / "declared.csv"
    p.write_text(f"# plant: {SERVO}\nt [ms],u [V],x [mm],p1 [bar],p2 [bar]\n{rows}\n")
    d = load_measured(p)
    _assert_close(d.t, t)
    _assert_close(d["x"], si["x"])
    np.testing.assert_allclose(d["p1"], si["p1"], rtol=1e-13)


def test_gauge_pressure_in_bar_under_pa_is_refused(tmp_path):
    t = _clock()
    p = write_measured(tmp_path / "seal.csv", t, {"x": 0.01 + 0 * t, "p_gauge": 5.0 + 0 * t, "F_load": 10 + 0 * t},
                       plant="seal_friction")
    with pytest.raises(MeasuredDataError, match=r"column 'p_gauge'.*look like bar or MPa, not Pa; declare the unit 'p_gauge \[bar\]'"):
        load_measured(p)
    ok = write_measured(tmp_path / "seal_ok.csv", t, {"x": 0.01 + 0 * t, "p_gauge": 5e5 + 0 * t,
                                                       "F_load": 10 + 0 * t}, plant="seal_friction")
    assert len(load_measured(ok)) == N


def test_ms_under_s_is_refused_against_sample_rate_and_dynamics(tmp_path):
    t = _clock(jitter=0)
    with pytest.raises(MeasuredDataError, match=r"column 't': median step 1 s contradicts the file's '# sample_rate: "
                       r"1000' \(a step of 0.001 s\); the times are 1000 x too large: most likely ms under an \[s\] "
                       r"header; declare the unit 't \[ms\]'"):
        load_measured(_own(tmp_path, t * 1e3, meta={"sample_rate": "1000"}))
    with pytest.raises(MeasuredDataError, match=r"column 't': median step 1 s; allowed at most 0.02 s for plant "
                       r"'servo_cylinder'.*most likely ms under an \[s\] header"):
        load_measured(_own(tmp_path, t * 1e3, name="nometa.csv"))
    assert len(load_measured(_own(tmp_path, t, name="ok.csv", meta={"sample_rate": "1 kHz"}))) == N
    assert len(load_measured(_own(tmp_path, 10 * t, name="slow.csv", meta={"sample_rate": "100"}))) == N
    with pytest.raises(MeasuredDataError, match=r"metadata sample_rate = 'fast'; allowed a number > 0 in Hz"):
        load_measured(_own(tmp_path, t, name="bad.csv", meta={"sample_rate": "fast"}))


def test_absurd_forces_velocities_and_commands_are_refused(tmp_path):
    t = _clock()
    f = 20 * np.sin(40 * t)
    x = 0.05 + 0.01 * np.sin(20 * t)
    with pytest.raises(MeasuredDataError, match=r"column 'f', row \d+ .*: f = .*e\+30\d N; allowed \|f\| <= 1e\+06 N"):
        load_measured(write_measured(tmp_path / "f.csv", t, {"f": 1e300 * f, "x": x}, plant="slider"))
    assert len(load_measured(write_measured(tmp_path / "f_ok.csv", t, {"f": 1e3 * f, "x": x}, plant="slider"))) == N
    with pytest.raises(MeasuredDataError, match=r"column 'u'.*u = .* V; allowed \|u\| <= 1000 V"):
        load_measured(_own(tmp_path, t, u=np.full(N, 5e3)))
    ls = {c.name: np.full(N, 1.0) for c in __import__("hydro_envs.data", fromlist=["channels_for"]).channels_for("load_sensing")}
    ls.update(p_s=np.full(N, 2e7), p_l=np.full(N, 1e7), p_ls=np.full(N, 1e7), xa=np.full(N, 0.1), a_cv=np.full(N, 1e-5),
              f_sol=np.full(N, 10.0))
    ls["va"] = np.full(N, 0.2)
    assert len(load_measured(write_measured(tmp_path / "ls.csv", t, ls, plant="load_sensing"))) == N
    ls["va"] = np.full(N, 1e6)
    with pytest.raises(MeasuredDataError, match=r"column 'va'.*allowed \|va\| <= .* m/s \(5 x the stroke"):
        load_measured(write_measured(tmp_path / "ls_bad.csv", t, ls, plant="load_sensing"))


def test_bench_without_a_stroke_parameter_uses_the_registry_bound(tmp_path):
    t = _clock()
    rec = {"x": 0.036 + 0 * t, "p_gauge": 5e5 + 0 * t, "F_load": 10 + 0 * t}
    assert len(load_measured(write_measured(tmp_path / "ok.csv", t, rec, plant="seal_friction"))) == N
    with pytest.raises(MeasuredDataError, match=r"position 36 m is more than 5 x the stroke 1 m"):
        load_measured(write_measured(tmp_path / "mm.csv", t, dict(rec, x=36.0 + 0 * t), plant="seal_friction"))
