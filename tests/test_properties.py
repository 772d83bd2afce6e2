"""Property tests (hypothesis) of the input boundaries.

(a) config validation: invalid parameter values and malformed randomisation specs raise the
    package's error naming the field; valid draws construct;
(b) the measured-data loader: malformed files raise :class:`MeasuredDataError` (never a bare
    numpy/csv exception); well-formed files round-trip bit for bit;
(c) the action path of every env, single and vector: NaN/inf, wrong shapes and non-numeric
    dtypes raise ``ValueError``; finite out-of-range values are clipped (the same trajectory
    as the clipped action); integer arrays, lists and float64 act as their float values;
(d) copy ``i`` of a vector env reset with seed ``s`` follows the single env reset with seed
    ``s + i`` bit for bit under the same actions.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import string

import gymnasium as gym
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

import hydro_envs  # noqa: F401  (registers the envs)
from hydro_envs.data.channels import channels_for
from hydro_envs.data.measured import MeasuredData, MeasuredDataError, load_measured, write_measured
from hydro_envs.params import ParameterError
from hydro_envs import registry
from hydro_envs.randomization import RandomizationError, RandomizationSpec, randomization_path

ENV_IDS = tuple(entry.id for _spec, entry in registry.env_entries())
PARAM_CLASSES = {s.name: s.params_cls for s in registry.specs(with_model=True) if s.randomization_file() is not None}
PLANTS = sorted(PARAM_CLASSES)
FAST = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
ENV_SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _spec_data(plant: str) -> dict:
    return yaml.safe_load(randomization_path(plant).read_text(encoding="utf-8"))


SPEC_DATA = {p: _spec_data(p) for p in PLANTS}
SPECS = {p: RandomizationSpec.from_mapping(SPEC_DATA[p], PARAM_CLASSES[p]) for p in PLANTS}


def _is_number_text(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


# ============================================================================ (a) parameters
@st.composite
def invalid_field_value(draw):
    plant = draw(st.sampled_from(PLANTS))
    cls = PARAM_CLASSES[plant]
    f = draw(st.sampled_from(dataclasses.fields(cls)))
    meta = f.metadata
    lo, hi = meta["allowed"]
    options = [
        st.just(math.nan), st.just(math.inf), st.just(-math.inf), st.none(), st.booleans(),
        st.text(string.ascii_letters + string.punctuation + " ", max_size=8).filter(lambda s: not _is_number_text(s)),
        st.lists(st.floats(allow_nan=False), min_size=1, max_size=2), st.just({}), st.just(1 + 1j),
    ]
    if math.isfinite(lo):
        options.append(st.floats(max_value=lo, exclude_max=not meta["open_low"], allow_nan=False))
    if math.isfinite(hi):
        options.append(st.floats(min_value=hi, exclude_min=not meta["open_high"], allow_nan=False))
    value = draw(st.one_of(options))
    return cls, f.name, value


@FAST
@given(invalid_field_value())
@example((PARAM_CLASSES["servo_cylinder"], "mass", True))  # bool was accepted as 1.0 kg
def test_invalid_parameter_value_names_the_field(case):
    cls, name, value = case
    with pytest.raises(ParameterError) as err:
        cls.from_mapping({name: value})
    msg = str(err.value)
    assert f"{cls.__name__}.{name}" in msg
    assert "allowed range" in msg or "must be a number" in msg


@FAST
@given(st.sampled_from(PLANTS), st.text(string.ascii_letters + "_", min_size=1, max_size=12))
def test_unknown_parameter_name_is_rejected(plant, name):
    cls = PARAM_CLASSES[plant]
    assume(name not in cls.names())
    with pytest.raises(ParameterError, match="unknown parameter"):
        cls.from_mapping({name: 1.0})


@FAST
@given(st.sampled_from(PLANTS), st.data())
def test_in_range_value_constructs_or_names_the_field(plant, data):
    """Any one field moved inside its allowed interval either gives a valid set or a
    ParameterError (a cross-field relation) that names the field moved."""
    cls = PARAM_CLASSES[plant]
    f = data.draw(st.sampled_from(dataclasses.fields(cls)))
    lo, hi = f.metadata["allowed"]
    value = data.draw(st.floats(lo, hi, exclude_min=f.metadata["open_low"], exclude_max=f.metadata["open_high"]))
    try:
        p = cls.from_mapping({f.name: value})
    except ParameterError as exc:
        assert f.name in str(exc), str(exc)
    else:
        assert getattr(p, f.name) == value


@pytest.mark.parametrize("plant, overrides", [
    # relation errors found by the property above (the messages named only the other field)
    ("servo_cylinder", {"line_volume_1": 5e-8}),
    ("rodless_cylinder", {"dead_volume_a": 5e-9}),
    ("force_actuator", {"stiction_retract": 10.0}),
    ("force_actuator", {"coulomb_friction": 0.0}),
    ("load_sensing", {"spool_diameter": 0.05}),
    ("ls_compensator", {"spring_chamber_pressure": 500.0}),
    ("shaking_table", {"oil_exponent": 50.0, "p0": 1e8, "e0": 1e7}),
])
def test_relation_errors_name_every_field_involved(plant, overrides):
    with pytest.raises(ParameterError) as err:
        PARAM_CLASSES[plant].from_mapping(overrides)
    for name in overrides:
        if not (plant == "force_actuator" and name == "coulomb_friction"):
            assert name in str(err.value), str(err.value)
    if overrides == {"coulomb_friction": 0.0}:
        assert "stiction_retract" in str(err.value)


@FAST
@given(st.sampled_from(PLANTS), st.integers(0, 2**32 - 1), st.data())
def test_randomised_draws_and_every_corner_are_valid(plant, seed, data):
    spec = SPECS[plant]
    spec.sample(np.random.default_rng(seed))  # raises if a draw is not a valid parameter set
    flags = data.draw(st.lists(st.booleans(), min_size=len(spec.entries), max_size=len(spec.entries)))
    spec.corner(flags)


# ============================================================================ (a) randomisation specs
_MUTATIONS = ("unknown_key", "missing_key", "range_nan", "range_inf", "range_inverted", "range_shape",
              "range_text", "range_bool", "distribution", "mode", "unit", "source", "loguniform_nonpositive",
              "entry_not_mapping", "excludes_nominal")


@st.composite
def mutated_spec(draw):
    plant = draw(st.sampled_from(PLANTS))
    data = copy.deepcopy(SPEC_DATA[plant])
    name = draw(st.sampled_from(sorted(data["parameters"])))
    entry = data["parameters"][name]
    kind = draw(st.sampled_from(_MUTATIONS))
    lo, hi = (float(v) for v in entry["range"])
    if kind == "unknown_key":
        entry[draw(st.sampled_from(["ranges", "dist", "scale", "low", "default"]))] = 1.0
    elif kind == "missing_key":
        del entry[draw(st.sampled_from(["distribution", "mode", "range", "unit", "source"]))]
    elif kind == "range_nan":
        entry["range"] = [math.nan, hi] if draw(st.booleans()) else [lo, math.nan]
    elif kind == "range_inf":
        entry["range"] = [-math.inf, hi] if draw(st.booleans()) else [lo, math.inf]
    elif kind == "range_inverted":
        assume(lo < hi)
        entry["range"] = [hi, lo]
    elif kind == "range_shape":
        entry["range"] = draw(st.sampled_from([[lo], [lo, hi, hi], lo, {"low": lo, "high": hi}, None]))
    elif kind == "range_text":
        entry["range"] = [draw(st.text(string.ascii_letters, min_size=1, max_size=5)), hi]
    elif kind == "range_bool":
        entry["range"] = [True, hi]
    elif kind == "distribution":
        entry["distribution"] = draw(st.text(max_size=10).filter(lambda s: s not in ("uniform", "loguniform")))
    elif kind == "mode":
        entry["mode"] = draw(st.text(max_size=10).filter(lambda s: s not in ("absolute", "scale")))
    elif kind == "unit":
        entry["unit"] = draw(st.sampled_from(["mm", "bar", "MPa", "kg*m", "", "2"]).filter(lambda u: u != entry["unit"]))
    elif kind == "source":
        entry["source"] = draw(st.sampled_from(["", "   ", None, 3.0]))
    elif kind == "loguniform_nonpositive":
        entry["distribution"] = "loguniform"
        entry["range"] = [draw(st.sampled_from([0.0, -1.0, -1e-9])), max(hi, 1.0)]
    elif kind == "entry_not_mapping":
        data["parameters"][name] = draw(st.sampled_from([1.0, "uniform", [lo, hi], None]))
    elif kind == "excludes_nominal":
        nom = 1.0 if entry["mode"] == "scale" else getattr(PARAM_CLASSES[plant](), name)
        span = max(abs(nom), 1e-12)
        entry["range"] = [nom + 0.5 * span, nom + 1.5 * span]
        entry["distribution"] = "uniform"
    return plant, name, data


@FAST
@given(mutated_spec())
def test_malformed_randomisation_spec_names_the_entry(case):
    plant, name, data = case
    with pytest.raises(RandomizationError) as err:
        RandomizationSpec.from_mapping(data, PARAM_CLASSES[plant], "spec.yaml")
    assert f"parameters.{name}" in str(err.value), str(err.value)


@FAST
@given(st.sampled_from(PLANTS), st.sampled_from(["seed", "parameter", "version", "Parameters"]))
@example("servo_cylinder", "seed")  # was silently ignored
def test_unknown_top_level_key_of_a_spec_is_rejected(plant, key):
    data = copy.deepcopy(SPEC_DATA[plant])
    data[key] = 1
    with pytest.raises(RandomizationError) as err:
        RandomizationSpec.from_mapping(data, PARAM_CLASSES[plant], "spec.yaml")
    assert repr(key) in str(err.value)


@FAST
@given(st.sampled_from(PLANTS), st.data())
def test_narrowed_spec_containing_the_nominal_loads_and_draws_valid_sets(plant, data):
    """Ranges shrunk to any sub-interval that still holds the nominal value stay a valid spec
    (every corner of a sub-box of a valid box is checked by the loader)."""
    d = copy.deepcopy(SPEC_DATA[plant])
    nominal = PARAM_CLASSES[plant]()
    for name, entry in d["parameters"].items():
        lo, hi = (float(v) for v in entry["range"])
        nom = 1.0 if entry["mode"] == "scale" else getattr(nominal, name)
        a = data.draw(st.floats(lo, nom))
        b = data.draw(st.floats(nom, hi))
        entry["range"] = [a, b]
    spec = RandomizationSpec.from_mapping(d, PARAM_CLASSES[plant])
    spec.sample(np.random.default_rng(data.draw(st.integers(0, 2**32 - 1))))


# ============================================================================ (b) measured-data loader
try:
    import pyarrow  # noqa: F401

    _HAVE_PYARROW = True
except ImportError:  # parquet is optional
    _HAVE_PYARROW = False
LOADER_PLANTS = ("servo_cylinder", "shaking_table", "force_actuator", "load_sensing", "rodless_cylinder")
finite = st.floats(-1e12, 1e12, allow_nan=False, allow_infinity=False)


@st.composite
def measured_table(draw):
    plant = draw(st.sampled_from(LOADER_PLANTS))
    chans = channels_for(plant)
    n = draw(st.integers(2, 25))
    t0 = draw(st.floats(-10.0, 10.0))
    dts = draw(st.lists(st.floats(1e-6, 1.0), min_size=n - 1, max_size=n - 1))
    t = np.concatenate([[t0], t0 + np.cumsum(dts)])
    assume(np.all(np.diff(t) > 0))
    cols = {c.name: np.array(draw(st.lists(finite, min_size=n, max_size=n))) for c in chans}
    units = [draw(st.booleans()) for _ in range(len(chans) + 1)]
    return plant, t, cols, units


def _csv_text(plant, t, cols, with_units, meta=("source: hypothesis",)):
    chans = channels_for(plant)
    head = [("t [s]" if with_units[0] else "t")]
    head += [f"{c.name} [{c.unit}]" if u else c.name for c, u in zip(chans, with_units[1:])]
    lines = [f"# plant: {plant}", *(f"# {m}" for m in meta), ",".join(head)]
    for i in range(len(t)):
        lines.append(",".join([repr(float(t[i]))] + [repr(float(cols[c.name][i])) for c in chans]))
    return "\n".join(lines) + "\n"


@FAST
@given(measured_table())
def test_well_formed_file_round_trips(tmp_path_factory, table):
    plant, t, cols, with_units = table
    path = tmp_path_factory.mktemp("ok") / "rec.csv"
    path.write_text(_csv_text(plant, t, cols, with_units), encoding="utf-8")
    d = load_measured(path, check=False)  # arbitrary finite values: the format, not a plausible record
    assert d.plant == plant and d.metadata["source"] == "hypothesis"
    assert np.array_equal(d.t, t)
    for name, v in cols.items():
        assert np.array_equal(d.channels[name], v)
        assert d.units[name] == next(c.unit for c in channels_for(plant) if c.name == name)
    suffixes = [".csv"] + ([".parquet"] if _HAVE_PYARROW else [])
    for suffix in suffixes:
        d2 = load_measured(write_measured(path.with_name("again" + suffix), d), check=False)
        assert d2.plant == plant and d2.metadata == d.metadata
        assert np.array_equal(d2.t, d.t) and all(np.array_equal(d2.channels[k], d.channels[k]) for k in cols)


def _converts(unit, si):
    from hydro_envs.data.units import UnitError, conversion

    try:
        conversion(unit, si, column="c")
    except UnitError:
        return False
    return True


_FILE_MUTATIONS = ("missing_column", "backwards_time", "duplicate_time", "bad_cell", "wrong_unit", "short_row",
                   "one_row", "empty", "no_header", "no_plant")


@FAST
@given(measured_table(), st.sampled_from(_FILE_MUTATIONS), st.data())
def test_malformed_file_gives_a_clear_error(tmp_path_factory, table, kind, data):
    plant, t, cols, with_units = table
    chans = channels_for(plant)
    column = None
    if kind == "missing_column":
        gone = data.draw(st.sampled_from([c.name for c in chans]))
        keep = {k: v for k, v in cols.items() if k != gone}
        head = ["t"] + [c.name for c in chans if c.name != gone]
        rows = [",".join(repr(float(x)) for x in [t[i]] + [keep[c][i] for c in head[1:]]) for i in range(len(t))]
        text = "\n".join([f"# plant: {plant}", ",".join(head), *rows]) + "\n"
        column = gone
    elif kind in ("backwards_time", "duplicate_time"):
        i = data.draw(st.integers(1, len(t) - 1))
        t = t.copy()
        t[i] = t[i - 1] if kind == "duplicate_time" else t[i - 1] - data.draw(st.floats(0.0, 1.0))
        text = _csv_text(plant, t, cols, with_units)
        column = "t"
    elif kind == "bad_cell":
        c = data.draw(st.sampled_from([c.name for c in chans]))
        i = data.draw(st.integers(0, len(t) - 1))
        cell = data.draw(st.sampled_from(["nan", "NaN", "inf", "-inf", "", "abc", "1e999", "0x10", "1_000", "--1"]))
        lines = _csv_text(plant, t, cols, with_units).splitlines()
        j = 1 + [ch.name for ch in chans].index(c)
        cells = lines[2 + 1 + i].split(",")
        cells[j] = cell
        lines[2 + 1 + i] = ",".join(cells)
        text = "\n".join(lines) + "\n"
        column = c
    elif kind == "wrong_unit":
        ch = data.draw(st.sampled_from(chans))
        unit = data.draw(st.sampled_from(["mm", "bar", "MPa", "kN", "s", "1", "m/s^2", "A", "V", "furlong"]))
        assume(not _converts(unit, ch.unit))  # a unit that converts (mm for m) is read in SI
        text = _csv_text(plant, t, cols, [False] * (len(chans) + 1)).replace(
            "," + ch.name + ",", f",{ch.name} [{unit}],").replace("," + ch.name + "\n", f",{ch.name} [{unit}]\n")
        column = ch.name
    elif kind == "short_row":
        lines = _csv_text(plant, t, cols, with_units).splitlines()
        i = data.draw(st.integers(3, len(lines) - 1))
        lines[i] = lines[i].rsplit(",", 1)[0]
        text = "\n".join(lines) + "\n"
    elif kind == "one_row":
        text = _csv_text(plant, t[:1], {k: v[:1] for k, v in cols.items()}, with_units)
    elif kind == "empty":
        text = data.draw(st.sampled_from(["", "\n", "   \n\n", "# plant: servo_cylinder\n"]))
    elif kind == "no_header":
        text = "\n".join(_csv_text(plant, t, cols, with_units).splitlines()[:2] + [
            ",".join(["0.0"] * (len(chans) + 1))] + _csv_text(plant, t, cols, with_units).splitlines()[3:]) + "\n"
    else:  # no_plant
        text = "\n".join(_csv_text(plant, t, cols, with_units).splitlines()[1:]) + "\n"
    path = tmp_path_factory.mktemp("bad") / "rec.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(MeasuredDataError) as err:
        load_measured(path)
    msg = str(err.value)
    assert str(path) in msg
    if column is not None:
        assert repr(column) in msg, msg


@FAST
@given(st.binary(max_size=200), st.booleans())
@example(b"t,x\x00,u\n0,1,2\n1,2,3\n", True)
@example(b"\xff\xfe\x00t", False)
@example(b"t\rx,u\n0,1,2\n", False)  # a lone CR inside a line: csv.Error before the fix
def test_garbage_bytes_never_crash_the_loader(tmp_path_factory, raw, with_plant):
    path = tmp_path_factory.mktemp("garbage") / "rec.csv"
    path.write_bytes((b"# plant: servo_cylinder\n" if with_plant else b"") + raw)
    try:
        d = load_measured(path)
    except MeasuredDataError as exc:
        assert str(path) in str(exc)
    else:
        assert isinstance(d, MeasuredData)


# ============================================================================ (c) action path
_ENVS: dict[str, tuple] = {}


def _envs(env_id):
    """(single env A, single env B, vector env of 2) built once per env id."""
    if env_id not in _ENVS:
        _ENVS[env_id] = (
            gym.make(env_id).unwrapped,
            gym.make(env_id).unwrapped,
            gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point"),
        )
    return _ENVS[env_id]


def _dim(env_id):
    return _envs(env_id)[0].action_space.shape[0]


@ENV_SETTINGS
@given(st.sampled_from(ENV_IDS), st.integers(0, 10**6), st.sampled_from([math.nan, math.inf, -math.inf]), st.data())
def test_non_finite_action_raises_and_changes_nothing(env_id, seed, bad, data):
    env, twin, venv = _envs(env_id)
    dim = _dim(env_id)
    env.reset(seed=seed)
    twin.reset(seed=seed)
    a = np.array(data.draw(st.lists(st.floats(-1, 1), min_size=dim, max_size=dim)))
    a_bad = a.copy()
    a_bad[data.draw(st.integers(0, dim - 1))] = bad
    for act in (a_bad.astype(np.float32), a_bad, list(a_bad)):
        with pytest.raises(ValueError, match="finite"):
            env.step(act)
    # the rejected actions left no trace: both envs take the same valid step
    o1, r1, *_ , i1 = env.step(a)
    o2, r2, *_ , i2 = twin.step(a)
    assert np.array_equal(o1, o2) and r1 == r2 and i1["state"] == i2["state"]
    venv.reset(seed=seed)
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.stack([a, a_bad]))


@ENV_SETTINGS
@given(st.sampled_from(ENV_IDS), st.integers(0, 10**6), st.data())
def test_out_of_range_actions_are_clipped(env_id, seed, data):
    env, twin, venv = _envs(env_id)
    dim = _dim(env_id)
    big = st.one_of(st.floats(-1e308, 1e308, allow_nan=False), st.floats(-3, 3))
    env.reset(seed=seed)
    twin.reset(seed=seed)
    for _ in range(3):
        a = np.array(data.draw(st.lists(big, min_size=dim, max_size=dim)))
        o1, r1, *_ , i1 = env.step(a)
        o2, r2, *_ , i2 = twin.step(np.clip(a, -1.0, 1.0))
        assert np.array_equal(o1, o2) and r1 == r2 and i1["state"] == i2["state"]
        assert np.all(np.isfinite(o1)) and math.isfinite(r1)


@ENV_SETTINGS
@given(st.sampled_from(ENV_IDS), st.integers(0, 10**6), st.data())
def test_ints_lists_and_float64_act_as_their_values(env_id, seed, data):
    env, twin, _ = _envs(env_id)
    dim = _dim(env_id)
    env.reset(seed=seed)
    twin.reset(seed=seed)
    for _ in range(3):
        ints = data.draw(st.lists(st.integers(-3, 3), min_size=dim, max_size=dim))
        flo = data.draw(st.lists(st.floats(-1.5, 1.5), min_size=dim, max_size=dim))
        for a, ref in ((np.array(ints), np.array(ints, dtype=np.float64)), (flo, np.array(flo)),
                       (np.array(flo, dtype=np.float32), np.array(flo, dtype=np.float32).astype(np.float64))):
            o1, r1, *_ = env.step(a)
            o2, r2, *_ = twin.step(ref)
            assert np.array_equal(o1, o2) and r1 == r2


_BAD_ACTIONS = {
    "string": lambda d: "abc",
    "numeric string array": lambda d: np.array(["0.5"] * d),
    "None": lambda d: None,
    "dict": lambda d: {"a": 0.5},
    "bool array": lambda d: np.ones(d, dtype=bool),
    "bool list": lambda d: [True] * d,
    "complex": lambda d: np.full(d, 0.5 + 0.5j),
    "object array": lambda d: np.array([0.5] * d, dtype=object),
    "ragged": lambda d: [[0.5], [0.5, 0.5]],
}


@ENV_SETTINGS
@given(st.sampled_from(ENV_IDS), st.sampled_from(sorted(_BAD_ACTIONS)))
def test_non_numeric_actions_raise_a_clear_error(env_id, kind):
    env, _, venv = _envs(env_id)
    dim = _dim(env_id)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must"):
        env.step(_BAD_ACTIONS[kind](dim))
    venv.reset(seed=0)
    bad = _BAD_ACTIONS[kind](dim)
    vbad = [bad, bad] if not isinstance(bad, np.ndarray) else np.stack([bad, bad])
    with pytest.raises(ValueError, match="action must"):
        venv.step(vbad)


@ENV_SETTINGS
@given(st.sampled_from(ENV_IDS), st.data())
def test_wrong_action_shapes_raise(env_id, data):
    env, _, venv = _envs(env_id)
    dim = _dim(env_id)
    shape = data.draw(st.lists(st.integers(0, 4), min_size=0, max_size=3).map(tuple))
    ok_single = {(dim,)} | ({()} if dim == 1 else set()) | {(1, dim)}
    ok_vector = {(2, dim)} | ({(2,)} if dim == 1 else set())
    env.reset(seed=0)
    venv.reset(seed=0)
    a = np.zeros(shape)
    if shape not in ok_single:
        with pytest.raises(ValueError, match="shape"):
            env.step(a)
    if shape not in ok_vector:
        with pytest.raises(ValueError, match="shape"):
            venv.step(a)


# ============================================================================ (d) single == vector copy
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(ENV_IDS), st.integers(0, 2**31 - 10), st.data())
def test_vector_copy_i_equals_single_env_seeded_s_plus_i(env_id, seed, data):
    env, _, _ = _envs(env_id)
    n = 3
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    dim = _dim(env_id)
    steps = data.draw(st.integers(1, 25))
    value = st.one_of(st.floats(-1.2, 1.2), st.floats(-1e300, 1e300))  # in range, and clipped
    A = np.array(data.draw(st.lists(value, min_size=steps * n * dim, max_size=steps * n * dim)))
    A = A.reshape(steps, n, dim)
    vobs, vinfo = venv.reset(seed=seed)
    V = [(vobs, None, {k: v.copy() for k, v in vinfo["state"].items()})]
    for k in range(steps):
        obs, rew, _, _, info = venv.step(A[k])
        V.append((obs, rew, info["state"]))
    venv.close()
    for i in range(n):
        obs, info = env.reset(seed=seed + i)
        assert np.array_equal(obs, V[0][0][i])
        assert all(info["state"][k] == V[0][2][k][i] for k in info["state"])
        for k in range(steps):
            obs, rew, _, _, info = env.step(A[k, i])
            vo, vr, vs = V[k + 1]
            assert np.array_equal(obs, vo[i]), (i, k)
            assert rew == vr[i]
            assert all(info["state"][name] == vs[name][i] for name in info["state"])
