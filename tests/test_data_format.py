"""Measured-data format: round trips and one test per rejection rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hydro_envs.data import (
    TIME_CHANNEL,
    Channel,
    MeasuredData,
    MeasuredDataError,
    UnknownPlantError,
    channels_for,
    load_measured,
    write_measured,
)

PLANT = "servo_cylinder"
HEADER = "t [s],u [V],x [m],p1 [Pa],p2 [Pa]"
GOOD_ROWS = [
    "0.0,0.5,0.1,5000000.0,4800000.0",
    "0.001,0.5,0.10002,5001000.0,4799000.0",
    "0.002,-1.25,0.10005,5002000.5,4798000.25",
]


def _write(tmp_path, text: str, name: str = "d.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _csv(rows=GOOD_ROWS, header=HEADER, meta=("# plant: servo_cylinder",)) -> str:
    return "\n".join([*meta, header, *rows]) + "\n"


def _random_bits(rng, n):
    """Arbitrary finite doubles, including subnormals and signed zero."""
    a = rng.integers(0, 2**64, size=n, dtype=np.uint64).view(np.float64).copy()
    a[~np.isfinite(a)] = 1.0
    a[:4] = [5e-324, -0.0, 1.7976931348623157e308, -2.2250738585072014e-308]
    return a


def _same_bits(a, b):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


# --- channels registry --------------------------------------------------------------------


def test_servo_cylinder_channels_registered():
    chans = channels_for(PLANT)
    assert [(c.name, c.unit) for c in chans] == [
        ("u", "V"), ("x", "m"), ("p1", "Pa"), ("p2", "Pa")
    ]
    assert TIME_CHANNEL == Channel("t", "s", "time since start of record")


def test_unknown_plant_lists_known_plants():
    with pytest.raises(UnknownPlantError) as ei:
        channels_for("no_such_plant")
    assert isinstance(ei.value, KeyError) and isinstance(ei.value, ValueError)
    assert "servo_cylinder" in str(ei.value) and "no_such_plant" in str(ei.value)


def test_every_registered_plant_has_valid_channels_and_channel_rules_are_checked():
    from hydro_envs import registry
    from hydro_envs.spec import PlantSpec

    for spec in registry.specs():
        assert channels_for(spec.name) == spec.channels and spec.channels
        assert set(spec.inputs) <= {c.name for c in spec.channels}
    with pytest.raises(ValueError, match="reserved"):
        PlantSpec("x", "x", "x", (Channel("t", "s", "time"),))
    with pytest.raises(ValueError, match="duplicate"):
        PlantSpec("x", "x", "x", (Channel("u", "V", "a"), Channel("u", "V", "b")))
    with pytest.raises(ValueError, match="invalid"):
        Channel("1x", "m", "bad name")
    with pytest.raises(ValueError, match="brackets"):
        Channel("x", "[m]", "bad unit")


# --- round trips ------------------------------------------------------------------------


def _sample(n=257, seed=0):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(1e-4, 2e-3, n))
    t[0] = 0.0
    return t, {k: _random_bits(rng, n) for k in ("u", "x", "p1", "p2")}


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_bit_exact(tmp_path, suffix):
    if suffix == ".parquet":
        pytest.importorskip("pyarrow")
    t, ch = _sample()
    meta = {"source": "synthetic test", "license": "CC0-1.0", "sample_rate": "1000",
            "comment": "first line\nsecond: with colon\n"}
    path = write_measured(tmp_path / f"r{suffix}", t, ch, plant=PLANT, metadata=meta)
    d = load_measured(path, check=False)  # arbitrary bits: the format, not a plausible record
    assert d.plant == PLANT
    assert _same_bits(d.t, t)
    for k, v in ch.items():
        assert _same_bits(d[k], v), k
    assert d.names == ("u", "x", "p1", "p2")
    assert d.units == {"t": "s", "u": "V", "x": "m", "p1": "Pa", "p2": "Pa"}
    assert d.metadata == meta
    # and a MeasuredData round trips through the other writer form
    path2 = write_measured(tmp_path / f"r2{suffix}", d)
    d2 = load_measured(path2, check=False)
    assert d2.metadata == d.metadata and d2.plant == d.plant
    assert all(_same_bits(d2[k], d[k]) for k in ("t", *d.names))


def test_csv_written_layout(tmp_path):
    t = np.array([0.0, 0.001, 0.002])
    ch = {"p2": [1.0, 2.0, 3.0], "u": [0.1, 0.2, 0.3], "x": [0.0, 1e-5, 2e-5],
          "p1": [1e5, 1e5, 1e5]}
    path = write_measured(tmp_path / "w.csv", t, ch, plant=PLANT, metadata={"source": "s"})
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0] == "# plant: servo_cylinder"
    assert lines[1] == "# source: s"
    assert lines[2] == HEADER  # registry order, whatever the input order
    assert lines[3] == "0.0,0.1,0.0,100000.0,1.0"
    assert lines[4] == "0.001,0.2,1e-05,100000.0,2.0"


def test_load_small_hand_written_file(tmp_path):
    text = (
        "\ufeff# plant: servo_cylinder\n"
        "# source: hand-written fixture\n"
        "# recorded on a test rig, free text line\n"
        "\n"
        "t [s], x [m] ,u,p1 [Pa],p2\n"
        "0, 0.1 ,0.5,5e6,4.8e6\r\n"
        "0.001,0.10002,0.5,5.001e6,4.799e6\r\n"
        "\n"
    )
    d = load_measured(_write(tmp_path, text))
    assert len(d) == 2 and d.n_samples == 2
    assert d.names == ("u", "x", "p1", "p2")  # canonical order
    np.testing.assert_array_equal(d["x"], [0.1, 0.10002])
    assert d.sample_time == pytest.approx(0.001) and d.duration == pytest.approx(0.001)
    assert d.metadata == {"source": "hand-written fixture",
                          "comment": "recorded on a test rig, free text line"}
    assert d.to_array(["t", "p1"]).shape == (2, 2)
    assert d.to_array().shape == (2, 4)
    assert "u" in d and "t" in d and "q" not in d
    with pytest.raises(KeyError, match="available"):
        d["q"]


def test_required_subset_and_plant_argument(tmp_path):
    text = "t,u,x\n0,0,0\n0.001,0,0.05\n"
    p = _write(tmp_path, text)
    d = load_measured(p, plant=PLANT, required=["u", "x"])
    assert d.names == ("u", "x")
    with pytest.raises(MeasuredDataError, match="'p1'"):
        load_measured(p, plant=PLANT)  # default: all channels required


def test_write_requires_plant_and_validates(tmp_path):
    t = np.array([0.0, 1.0])
    with pytest.raises(MeasuredDataError, match="no plant"):
        write_measured(tmp_path / "a.csv", t, {"u": [0, 0]})
    with pytest.raises(MeasuredDataError, match="'u'.*not finite"):
        write_measured(tmp_path / "a.csv", t, {"u": [0, np.nan]}, plant=PLANT)
    with pytest.raises(MeasuredDataError, match="strictly increasing"):
        write_measured(tmp_path / "a.csv", [0.0, 0.0], {"u": [0, 0]}, plant=PLANT)
    with pytest.raises(MeasuredDataError, match="'q' is not a channel"):
        write_measured(tmp_path / "a.csv", t, {"q": [0, 0]}, plant=PLANT)
    with pytest.raises(MeasuredDataError, match=r"\[mm\]"):
        write_measured(tmp_path / "a.csv", t, {"x": [0, 0]}, plant=PLANT, units={"x": "mm"})
    assert not (tmp_path / "a.csv").exists()


def test_extra_columns_opt_in(tmp_path):
    p = _write(tmp_path, _csv(header=HEADER + ",flow [m^3/s]",
                              rows=[r + ",1e-4" for r in GOOD_ROWS]))
    with pytest.raises(MeasuredDataError, match="'flow' is not a channel"):
        load_measured(p)
    d = load_measured(p, allow_extra=True)
    assert d.units["flow"] == "m^3/s" and d.names[-1] == "flow"


# --- rejections -------------------------------------------------------------------------


def _reject(tmp_path, text, *fragments, **kw):
    p = _write(tmp_path, text)
    with pytest.raises(MeasuredDataError) as ei:
        load_measured(p, **kw)
    msg = str(ei.value)
    assert str(p) in msg, msg
    for frag in fragments:
        assert frag in msg, f"{frag!r} not in {msg!r}"
    return ei.value


def test_reject_missing_column(tmp_path):
    text = _csv(header="t [s],u [V],x [m],p1 [Pa]", rows=[r.rsplit(",", 1)[0] for r in GOOD_ROWS])
    e = _reject(tmp_path, text, "missing required column", "'p2'", "servo_cylinder")
    assert e.column == "p2"


def test_reject_nan_cell(tmp_path):
    rows = list(GOOD_ROWS)
    rows[1] = "0.001,0.5,0.10002,nan,4799000.0"
    e = _reject(tmp_path, _csv(rows=rows), "line 4", "column 'p1'", "not finite")
    assert (e.line, e.column) == (4, "p1")


def test_reject_inf_cell(tmp_path):
    rows = list(GOOD_ROWS)
    rows[2] = "0.002,-inf,0.10005,5002000.5,4798000.25"
    _reject(tmp_path, _csv(rows=rows), "line 5", "column 'u'", "not finite")


def test_reject_overflow_to_inf(tmp_path):
    rows = list(GOOD_ROWS)
    rows[0] = "0.0,0.5,1e999,5000000.0,4800000.0"
    _reject(tmp_path, _csv(rows=rows), "line 3", "column 'x'", "not finite")


def test_reject_non_numeric_cell(tmp_path):
    rows = list(GOOD_ROWS)
    rows[2] = "0.002,-1.25,abc,5002000.5,4798000.25"
    _reject(tmp_path, _csv(rows=rows), "line 5", "column 'x'", "'abc' is not a number")


def test_reject_empty_cell(tmp_path):
    rows = list(GOOD_ROWS)
    rows[1] = "0.001,,0.10002,5001000.0,4799000.0"
    _reject(tmp_path, _csv(rows=rows), "line 4", "column 'u'", "empty cell")


def test_reject_wrong_cell_count(tmp_path):
    rows = list(GOOD_ROWS)
    rows[1] = "0.001,0.5,0.10002,5001000.0"
    _reject(tmp_path, _csv(rows=rows), "line 4", "has 4 cells, expected 5")


def test_reject_non_increasing_time(tmp_path):
    rows = list(GOOD_ROWS)
    rows[2] = "0.0005,-1.25,0.10005,5002000.5,4798000.25"
    e = _reject(tmp_path, _csv(rows=rows), "line 5", "column 't'", "time goes backwards",
                "strictly increasing")
    assert (e.line, e.column) == (5, "t")


def test_reject_duplicate_time(tmp_path):
    rows = list(GOOD_ROWS)
    rows[2] = "0.001,-1.25,0.10005,5002000.5,4798000.25"
    _reject(tmp_path, _csv(rows=rows), "line 5", "duplicate time", "line 4")


def test_header_unit_is_converted_and_noted(tmp_path):
    rows = ["0,0.5,100,50,48", "1,0.5,100.02,50.01,47.99", "2,-1.25,100.05,50.02,47.98"]
    p = _write(tmp_path, _csv(rows=rows, header="t [ms],u [V],x [mm],p1 [bar],p2 [MPa]"))
    d = load_measured(p)
    np.testing.assert_allclose(d.t, [0.0, 0.001, 0.002], rtol=1e-15)
    np.testing.assert_allclose(d["x"], [0.1, 0.10002, 0.10005], rtol=1e-15)
    np.testing.assert_allclose(d["p1"], [5e6, 5.001e6, 5.002e6], rtol=1e-15)
    np.testing.assert_allclose(d["p2"], [48e6, 47.99e6, 47.98e6], rtol=1e-15)
    assert d.units["x"] == "m" and "[mm]" in d.metadata["unit.x"] and "[bar]" in d.metadata["unit.p1"]


def test_reject_unknown_or_wrong_dimension_unit_in_header(tmp_path):
    e = _reject(tmp_path, _csv(header="t [s],u [V],x [furlong],p1 [Pa],p2 [Pa]"), "column 'x'", "[furlong]", "[m]")
    assert e.column == "x"
    _reject(tmp_path, _csv(header="t [s],u [V],x [bar],p1 [Pa],p2 [Pa]"), "column 'x'", "[bar]", "[m]")
    _reject(tmp_path, _csv(header="t [m],u [V],x [m],p1 [Pa],p2 [Pa]"), "'t'", "[m]", "[s]")
    _reject(tmp_path, _csv(header="t [s],u [V],x [m],p1 [mPa],p2 [Pa]"), "'p1'", "[mPa]")


def test_reject_empty_file(tmp_path):
    _reject(tmp_path, "", "file is empty")
    _reject(tmp_path, "  \n\n", "file is empty")


def test_reject_no_header_only_comments(tmp_path):
    _reject(tmp_path, "# plant: servo_cylinder\n# source: x\n", "no header row")


def test_reject_no_header_data_first(tmp_path):
    text = "# plant: servo_cylinder\n" + "\n".join(GOOD_ROWS) + "\n"
    e = _reject(tmp_path, text, "line 2", "no header row", "'t'")
    assert e.line == 2


def test_reject_first_column_not_t(tmp_path):
    text = _csv(header="time [s],u [V],x [m],p1 [Pa],p2 [Pa]")
    _reject(tmp_path, text, "first column must be 't'", "'time'")


def test_reject_wrong_delimiter_hint(tmp_path):
    text = "# plant: servo_cylinder\nt;u;x;p1;p2\n0;0;0;0;0\n1;0;0;0;0\n"
    _reject(tmp_path, text, "first column must be 't'", "separated by ','")


def test_reject_unknown_plant(tmp_path):
    text = _csv(meta=("# plant: warp_drive",))
    _reject(tmp_path, text, "unknown plant 'warp_drive'", "servo_cylinder")


def test_reject_no_plant(tmp_path):
    _reject(tmp_path, _csv(meta=()), "no plant given", "# plant:")


def test_reject_plant_mismatch(tmp_path):
    _reject(tmp_path, _csv(), "'slider'", "servo_cylinder", plant="slider")


def test_reject_duplicate_column(tmp_path):
    text = _csv(header=HEADER + ",x [m]", rows=[r + ",0.1" for r in GOOD_ROWS])
    e = _reject(tmp_path, text, "duplicate column 'x'", "columns 3 and 6")
    assert e.column == "x"


def test_reject_unknown_column(tmp_path):
    text = _csv(header=HEADER + ",q", rows=[r + ",1" for r in GOOD_ROWS])
    _reject(tmp_path, text, "'q' is not a channel of plant 'servo_cylinder'", "u, x, p1, p2")


def test_reject_single_row(tmp_path):
    _reject(tmp_path, _csv(rows=GOOD_ROWS[:1]), "1 data row", "at least 2")


def test_reject_header_only(tmp_path):
    _reject(tmp_path, _csv(rows=[]), "0 data row", "at least 2")


def test_reject_blank_line_inside_data(tmp_path):
    rows = [GOOD_ROWS[0], "", *GOOD_ROWS[1:]]
    _reject(tmp_path, _csv(rows=rows), "line 4", "blank line")


def test_reject_comment_after_header(tmp_path):
    rows = [GOOD_ROWS[0], "# oops", *GOOD_ROWS[1:]]
    _reject(tmp_path, _csv(rows=rows), "line 4", "comment line after the header")


def test_reject_duplicate_metadata_key(tmp_path):
    text = _csv(meta=("# plant: servo_cylinder", "# source: a", "# source: b"))
    _reject(tmp_path, text, "line 3", "'source'", "repeats line 2")


def test_reject_malformed_header_cell(tmp_path):
    _reject(tmp_path, _csv(header="t [s],u [V,x [m],p1 [Pa],p2 [Pa]"), "header column 2",
            "malformed")


def test_reject_missing_file(tmp_path):
    with pytest.raises(MeasuredDataError, match="file not found"):
        load_measured(tmp_path / "nope.csv")


def test_reject_bad_encoding(tmp_path):
    p = tmp_path / "latin1.csv"
    p.write_bytes(_csv().encode("utf-8") + b"# caf\xe9\n")
    with pytest.raises(MeasuredDataError, match="UTF-8"):
        load_measured(p)


def test_reject_unsupported_number_syntax(tmp_path):
    rows = list(GOOD_ROWS)
    rows[0] = "0.0,0.5,0.1,5_000_000,4800000.0"
    _reject(tmp_path, _csv(rows=rows), "line 3", "column 'p1'", "not a number")


# --- parquet rejections -----------------------------------------------------------------


def test_parquet_rejections(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    import json

    def put(cols, meta=None, name="bad.parquet"):
        tab = pa.table(cols)
        md = {b"hydro_envs.metadata": json.dumps({"plant": PLANT}).encode()}
        md.update(meta or {})
        tab = tab.replace_schema_metadata(md)
        p = tmp_path / name
        pq.write_table(tab, p)
        return p

    good = {"t": [0.0, 0.001, 0.002], "u": [0.0, 0.0, 0.0], "x": [0.1, 0.1, 0.1],
            "p1": [1e5, 1e5, 1e5], "p2": [1e5, 1e5, 1e5]}
    d = load_measured(put(good, name="ok.parquet"))
    assert d.names == ("u", "x", "p1", "p2")

    nan = dict(good, p1=[1e5, float("nan"), 1e5])
    with pytest.raises(MeasuredDataError, match=r"data row 2, column 'p1'.*not finite"):
        load_measured(put(nan))
    null = dict(good, x=pa.array([0.1, None, 0.1], type=pa.float64()))
    with pytest.raises(MeasuredDataError, match=r"data row 2, column 'x'.*null"):
        load_measured(put(null))
    back = dict(good, t=[0.0, 0.002, 0.001])
    with pytest.raises(MeasuredDataError, match=r"data row 3, column 't'"):
        load_measured(put(back))
    text = dict(good, u=["a", "b", "c"])
    with pytest.raises(MeasuredDataError, match=r"column 'u' has type string"):
        load_measured(put(text))
    units = {b"hydro_envs.units": json.dumps({"x": "furlong"}).encode()}
    with pytest.raises(MeasuredDataError, match=r"\[furlong\]"):
        load_measured(put(good, units))
    units = {b"hydro_envs.units": json.dumps({"x": "mm"}).encode()}  # a unit that converts: read in SI
    assert load_measured(put(dict(good, x=[100.0, 100.0, 100.0]), units))["x"].tolist() == [0.1, 0.1, 0.1]
    missing = {k: v for k, v in good.items() if k != "p2"}
    with pytest.raises(MeasuredDataError, match="'p2'"):
        load_measured(put(missing))


# --- data class -------------------------------------------------------------------------


def test_measured_data_shape_check():
    with pytest.raises(MeasuredDataError, match="'x'"):
        MeasuredData(PLANT, np.arange(3.0), {"x": np.zeros(2)})
    d = MeasuredData(PLANT, [0.0, 0.5, 1.5], {"x": [1, 2, 3]})
    assert d.sample_time == pytest.approx(0.75) and d.duration == 1.5
    assert d["x"].dtype == np.float64
    assert math.isnan(MeasuredData(PLANT, [0.0], {}).sample_time)
