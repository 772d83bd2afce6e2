"""Tests of the declarative domain-randomisation loader (hydro_envs.randomization).

Checks the shipped ``configs/randomization/servo_cylinder.yaml`` against the nominal
parameter set, the statistics of the draws (scale entries multiply the nominal value,
loguniform entries are uniform in log), and that every malformed spec is rejected with a
:class:`RandomizationError` naming the offending entry.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import hydro_envs  # noqa: F401
from hydro_envs.plants.servo_cylinder.params import ServoCylinderParams
from hydro_envs.randomization import (
    ParameterDistribution,
    RandomizationError,
    RandomizationSpec,
    randomization_path,
    load_randomization,
)

ENV_ID = "hydro_envs/ServoCylinderPosition-v0"
NOMINAL = ServoCylinderParams()
YAML_PATH = Path(__file__).resolve().parents[1] / "configs" / "plants" / "servo_cylinder" / "randomization.yaml"


@pytest.fixture(scope="module")
def spec() -> RandomizationSpec:
    return load_randomization("servo_cylinder", ServoCylinderParams)


def _entry(spec: RandomizationSpec, name: str) -> ParameterDistribution:
    (e,) = [e for e in spec.entries if e.name == name]
    return e


_DROP = object()  # marks a key to leave out of _one's entry


def _one(name: str, **entry) -> dict:
    """A minimal spec mapping with one entry (defaults: a valid mass scale entry)."""
    base = {"distribution": "uniform", "mode": "scale", "range": [1.0, 2.0], "unit": "1", "source": "test"}
    base.update(entry)
    base = {k: v for k, v in base.items() if v is not _DROP}
    return {"plant": "servo_cylinder", "parameters": {name: base}}


def _from(data) -> RandomizationSpec:
    return RandomizationSpec.from_mapping(data, ServoCylinderParams)


# ----------------------------------------------------------------------------- shipped YAML
def test_shipped_yaml_loads_and_is_sourced(spec):
    assert Path(spec.source_file) == YAML_PATH
    assert Path(str(randomization_path("servo_cylinder"))) == YAML_PATH
    assert spec.params_cls is ServoCylinderParams
    raw = yaml.safe_load(YAML_PATH.read_text())
    assert list(spec.names) == list(raw["parameters"])  # order kept, nothing dropped
    assert len(spec.names) >= 10
    for e in spec.entries:
        assert e.source.strip(), e.name
        assert e.source == raw["parameters"][e.name]["source"]
        lo, hi = e.value_range(getattr(NOMINAL, e.name))
        assert lo <= getattr(NOMINAL, e.name) <= hi, e.name
        assert lo < hi, e.name


def test_shipped_yaml_values(spec):
    # "12.6e6" is a YAML 1.1 string: it must be read as the number
    sp = _entry(spec, "supply_pressure")
    assert (sp.low, sp.high) == (12.6e6, 15.1e6) and sp.mode == "absolute" and sp.unit == "Pa"
    m = _entry(spec, "mass")
    assert (m.mode, m.low, m.high, m.unit) == ("scale", 1.0, 2.0, "1")
    assert m.value_range(NOMINAL.mass) == pytest.approx((12.3, 24.6))
    assert _entry(spec, "stribeck_velocity").distribution == "loguniform"
    rows = {r["name"]: r for r in spec.table()}
    assert rows["bulk_modulus"]["value_range"] == (5e8, 1e9)
    assert rows["bulk_modulus"]["nominal"] == 689e6
    assert rows["mass"]["range"] == (1.0, 2.0)


def test_corners_of_shipped_spec_are_valid(spec):
    lo, hi = spec.corner(False), spec.corner(True)
    assert lo.mass == pytest.approx(12.3) and hi.mass == pytest.approx(24.6)
    assert (lo.bulk_modulus, hi.bulk_modulus) == (5e8, 1e9)
    assert (lo.coulomb_friction, lo.static_friction) == (20.0, 55.0)
    assert (hi.coulomb_friction, hi.static_friction) == (55.0, 90.0)
    for name in ServoCylinderParams.names():
        if name not in spec.names:
            assert getattr(lo, name) == getattr(NOMINAL, name)
    flags = [i % 2 == 0 for i in range(len(spec.entries))]
    mixed = spec.corner(flags)
    for e, f in zip(spec.entries, flags):
        assert getattr(mixed, e.name) == e.value_range(getattr(NOMINAL, e.name))[int(f)]


# ----------------------------------------------------------------------------- sampling
def test_sample_draws_inside_ranges_and_keeps_the_rest_nominal(spec):
    rng = np.random.default_rng(0)
    ranges = {e.name: e.value_range(getattr(NOMINAL, e.name)) for e in spec.entries}
    for _ in range(300):
        p = spec.sample(rng)
        assert isinstance(p, ServoCylinderParams)
        for name in ServoCylinderParams.names():
            v = getattr(p, name)
            if name in ranges:
                assert ranges[name][0] <= v <= ranges[name][1], name
            else:
                assert v == getattr(NOMINAL, name), name


def test_scale_entries_multiply_the_nominal(spec):
    e = _entry(spec, "mass")
    rng = np.random.default_rng(1)
    draws = np.array([e.sample(rng, 12.3) for _ in range(20000)])
    assert draws.min() >= 12.3 * 1.0 and draws.max() <= 12.3 * 2.0
    assert draws.mean() == pytest.approx(18.45, abs=0.1)  # 12.3 * 1.5
    assert draws.std() == pytest.approx(12.3 / math.sqrt(12), rel=0.03)  # uniform width 12.3
    # scale is relative to the base passed in (never an additive offset)
    rng = np.random.default_rng(1)
    d100 = np.array([e.sample(rng, 100.0) for _ in range(20000)])
    np.testing.assert_allclose(d100, draws / 12.3 * 100.0, rtol=1e-12)
    base = ServoCylinderParams(mass=20.0)
    p = spec.sample(np.random.default_rng(2), base)
    assert 20.0 <= p.mass <= 40.0


def test_loguniform_is_uniform_in_log(spec):
    e = _entry(spec, "stribeck_velocity")
    lo, hi = 3e-3, 3e-2
    rng = np.random.default_rng(3)
    draws = np.array([e.sample(rng, NOMINAL.stribeck_velocity) for _ in range(20000)])
    assert draws.min() >= lo and draws.max() <= hi
    logs = np.log(draws)
    mid = 0.5 * (math.log(lo) + math.log(hi))
    assert logs.mean() == pytest.approx(mid, abs=0.03)
    assert logs.std() == pytest.approx(math.log(hi / lo) / math.sqrt(12), rel=0.03)
    # decade halves equally populated: a linear-uniform draw would put ~74 % above the mid
    assert np.mean(logs > mid) == pytest.approx(0.5, abs=0.02)
    assert draws.mean() == pytest.approx((hi - lo) / math.log(hi / lo), rel=0.03)


def test_sampling_is_deterministic_for_the_same_generator_seed(spec):
    a = [spec.sample(np.random.default_rng(7)) for _ in range(3)]
    b = [spec.sample(np.random.default_rng(7)) for _ in range(3)]
    assert a == b
    rng1, rng2 = np.random.default_rng(8), np.random.default_rng(8)
    seq1 = [spec.sample(rng1).as_dict() for _ in range(5)]
    seq2 = [spec.sample(rng2).as_dict() for _ in range(5)]
    assert seq1 == seq2
    assert seq1[0] != seq1[1]
    assert spec.sample(np.random.default_rng(9)) != a[0]


def test_widened_doubles_the_width_about_the_centre(spec):
    w = spec.widened(2.0)
    assert w.names == spec.names
    for old, new in zip(spec.entries, w.entries):
        assert (new.distribution, new.mode, new.unit, new.source) == (
            old.distribution,
            old.mode,
            old.unit,
            old.source,
        )
        if old.distribution == "loguniform":
            c_old = 0.5 * (math.log(old.low) + math.log(old.high))
            c_new = 0.5 * (math.log(new.low) + math.log(new.high))
            assert c_new == pytest.approx(c_old, abs=1e-12)
            assert math.log(new.high / new.low) == pytest.approx(2 * math.log(old.high / old.low), rel=1e-12)
        else:
            assert 0.5 * (new.low + new.high) == pytest.approx(0.5 * (old.low + old.high), rel=1e-12)
            assert new.high - new.low == pytest.approx(2 * (old.high - old.low), rel=1e-12)
    sv = _entry(w, "stribeck_velocity")
    assert (sv.low, sv.high) == (pytest.approx(9.4868e-4, rel=1e-4), pytest.approx(9.4868e-2, rel=1e-4))
    m = _entry(w, "mass")
    assert (m.low, m.high) == (pytest.approx(0.5), pytest.approx(2.5))
    assert _entry(spec, "mass").low == 1.0  # the original is untouched
    one = spec.widened(1.0)
    for a, b in zip(one.entries, spec.entries):
        assert a.low == pytest.approx(b.low, rel=1e-12) and a.high == pytest.approx(b.high, rel=1e-12)


# ----------------------------------------------------------------------------- error cases
def test_minimal_mapping_is_valid():
    s = _from(_one("mass"))
    assert s.names == ("mass",)
    s = _from(_one("stribeck_velocity", distribution="loguniform", mode="absolute", range=[0.005, 0.02], unit="m/s", note="x"))
    assert s.entries[0].distribution == "loguniform"


@pytest.mark.parametrize(
    "data, pattern",
    [
        (_one("mas"), r"parameters\.mas\b.*unknown parameter"),
        (_one("mass", distrib="uniform"), r"parameters\.mass.*unknown key.*distrib"),
        (_one("mass", source=_DROP), r"parameters\.mass.*missing 'source'"),
        (_one("mass", unit=_DROP), r"parameters\.mass.*missing 'unit'"),
        (_one("mass", range=[2.0, 1.0]), r"parameters\.mass.*inverted"),
        (_one("mass", range=["a", 2.0]), r"parameters\.mass.*range"),
        (_one("mass", range=[1.0]), r"parameters\.mass.*range"),
        (_one("mass", range=1.5), r"parameters\.mass.*range"),
        (_one("mass", range=[1.0, float("nan")]), r"parameters\.mass.*range"),
        (_one("mass", range=[1.0, float("inf")]), r"parameters\.mass.*range"),
        (_one("mass", distribution="gaussian"), r"parameters\.mass.*distribution"),
        (_one("mass", mode="offset"), r"parameters\.mass.*mode"),
        (
            _one("stribeck_velocity", distribution="loguniform", mode="absolute", range=[0.0, 0.03], unit="m/s"),
            r"parameters\.stribeck_velocity.*> 0",
        ),
        (
            _one("mass", distribution="loguniform", range=[-1.0, 2.0]),
            r"parameters\.mass.*> 0",
        ),
        (_one("mass", mode="absolute", range=[10.0, 20.0], unit="1"), r"parameters\.mass.*unit.*'kg'"),
        (_one("supply_pressure", range=[0.9, 1.1], unit="Pa"), r"parameters\.supply_pressure.*unit.*'1'"),
        (_one("mass", mode="absolute", range=[20.0, 30.0], unit="kg"), r"parameters\.mass.*nominal value 12\.3"),
        (_one("mass", range=[1.1, 2.0]), r"parameters\.mass.*nominal"),
        ({"plant": "servo_cylinder", "parameters": {"mass": [1, 2]}}, r"parameters\.mass.*mapping"),
    ],
)
def test_malformed_entries_raise_naming_the_entry(data, pattern):
    with pytest.raises(RandomizationError, match=pattern):
        _from(data)


def test_wrong_plant_and_top_level_errors():
    with pytest.raises(RandomizationError, match=r"plant.*'pneumatic_cylinder'.*'servo_cylinder'"):
        _from({**_one("mass"), "plant": "pneumatic_cylinder"})
    with pytest.raises(RandomizationError, match="plant"):
        _from({"parameters": _one("mass")["parameters"]})
    with pytest.raises(RandomizationError, match="parameters"):
        _from({"plant": "servo_cylinder", "parameters": {}})
    with pytest.raises(RandomizationError, match="mapping"):
        _from([1, 2, 3])


def test_corner_violating_a_relation_raises():
    data = {
        "plant": "servo_cylinder",
        "parameters": {
            "coulomb_friction": {"distribution": "uniform", "mode": "absolute", "range": [20.0, 80.0], "unit": "N", "source": "t"},
            "static_friction": {"distribution": "uniform", "mode": "absolute", "range": [55.0, 90.0], "unit": "N", "source": "t"},
        },
    }
    with pytest.raises(RandomizationError, match=r"corner.*static_friction.*coulomb_friction"):
        _from(data)
    ok = copy.deepcopy(data)
    ok["parameters"]["coulomb_friction"]["range"] = [20.0, 55.0]
    assert _from(ok).names == ("coulomb_friction", "static_friction")


def test_corner_making_a_parameter_invalid_raises():
    # a scale range whose low end drives the value to 0 (mass must be > 0)
    with pytest.raises(RandomizationError, match=r"corner.*mass"):
        _from(_one("mass", range=[0.0, 2.0]))


@pytest.mark.parametrize("blank", ["", "   ", None])
def test_blank_source_is_rejected(blank):
    with pytest.raises(RandomizationError, match=r"parameters\.mass.*source"):
        _from(_one("mass", source=blank))


def test_boolean_range_is_rejected():
    with pytest.raises(RandomizationError, match=r"parameters\.mass.*range"):
        _from(_one("mass", range=[True, 2.0]))


# ----------------------------------------------------------------------------- YAML loading
def _write(tmp_path: Path, text: str, name="spec.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_yaml_python_object_tag_is_rejected(tmp_path):
    evil = _write(tmp_path, "!!python/object/apply:os.system ['echo pwned']\n")
    with pytest.raises(RandomizationError, match="YAML"):
        load_randomization("servo_cylinder", ServoCylinderParams, evil)
    evil2 = _write(
        tmp_path,
        "plant: servo_cylinder\nparameters:\n  mass: !!python/object:builtins.dict {}\n",
        "evil2.yaml",
    )
    with pytest.raises(RandomizationError):
        load_randomization("servo_cylinder", ServoCylinderParams, evil2)


def test_yaml_errors(tmp_path):
    with pytest.raises(RandomizationError, match="missing.yaml: randomisation spec not found"):
        load_randomization("servo_cylinder", ServoCylinderParams, tmp_path / "missing.yaml")
    with pytest.raises(RandomizationError, match="not valid YAML"):
        load_randomization("servo_cylinder", ServoCylinderParams, _write(tmp_path, "plant: [unclosed\n"))
    bad = YAML_PATH.read_text().replace("range: [5.0e8, 1.0e9]", "range: [1.0e9, 5.0e8]")
    assert bad != YAML_PATH.read_text()
    with pytest.raises(RandomizationError, match=r"bad\.yaml.*parameters\.bulk_modulus.*inverted"):
        load_randomization("servo_cylinder", ServoCylinderParams, _write(tmp_path, bad, "bad.yaml"))


def test_yaml_roundtrip_and_config_dir_override(tmp_path, monkeypatch):
    d = tmp_path / "cfg" / "randomization"
    d.mkdir(parents=True)
    text = (
        "plant: servo_cylinder\n"
        "parameters:\n"
        "  bulk_modulus:\n"
        "    distribution: uniform\n"
        "    mode: absolute\n"
        "    range: [6.0e8, 7.0e8]\n"
        "    unit: Pa\n"
        "    source: test\n"
    )
    (d / "servo_cylinder.yaml").write_text(text)
    monkeypatch.setenv("HYDRO_ENVS_CONFIG_DIR", str(tmp_path / "cfg"))
    s = load_randomization("servo_cylinder", ServoCylinderParams)
    assert s.names == ("bulk_modulus",)
    assert s.source_file == str(d / "servo_cylinder.yaml")
    # the env picks the custom spec up: only bulk_modulus varies, within [6e8, 7e8]
    env = gym.make(ENV_ID)
    for seed in range(4):
        _, info = env.reset(seed=seed)
        p = info["params"]
        assert 6e8 <= p["bulk_modulus"] <= 7e8
        assert {k: v for k, v in p.items() if k != "bulk_modulus"} == {
            k: v for k, v in NOMINAL.as_dict().items() if k != "bulk_modulus"
        }


def test_env_accepts_a_spec_object_and_a_path(tmp_path):
    narrow = RandomizationSpec.from_mapping(_one("mass", range=[1.0, 1.01]), ServoCylinderParams)
    env = gym.make(ENV_ID, randomization=narrow)
    _, info = env.reset(seed=0)
    assert 12.3 <= info["params"]["mass"] <= 12.3 * 1.01
    assert info["params"]["bulk_modulus"] == NOMINAL.bulk_modulus
    p = _write(
        tmp_path,
        "plant: servo_cylinder\nparameters:\n  valve_damping: {distribution: uniform, mode: absolute, "
        "range: [0.6, 0.7], unit: '1', source: t}\n",
        "vd.yaml",
    )
    env = gym.make(ENV_ID, randomization=str(p))
    _, info = env.reset(seed=0)
    assert 0.6 <= info["params"]["valve_damping"] <= 0.7
    assert info["params"]["mass"] == NOMINAL.mass
