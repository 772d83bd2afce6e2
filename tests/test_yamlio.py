"""The one YAML loader (hydro_envs.yamlio): bombs, duplicate keys, size, tags, typed values."""

from __future__ import annotations

import glob
import time
from pathlib import Path

import pytest
import yaml

from hydro_envs import yamlio
from hydro_envs.yamlio import MAX_MESSAGE, YamlError, load_yaml, load_yaml_text

ROOT = Path(__file__).resolve().parents[1]


def bomb(levels: int = 9, key: str = "note") -> str:
    """``levels`` of nine aliases each: 9**levels strings from a few hundred bytes."""
    lines = [f"{key}:", '  - &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for k in range(1, levels):
        lines.append(f"  - &a{k} [" + ",".join([f"*a{k - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def test_alias_bomb_is_refused_fast_with_a_short_message(tmp_path):
    f = tmp_path / "bomb.yaml"
    f.write_text(bomb())
    assert f.stat().st_size < 700
    t0 = time.perf_counter()
    with pytest.raises(YamlError, match=r"bomb\.yaml: line \d+, column \d+: the document expands to more than") as e:
        load_yaml(f)
    assert time.perf_counter() - t0 < 1.0 and len(str(e.value)) <= MAX_MESSAGE


def test_small_aliases_and_merge_keys_load_as_safe_load():
    text = "base: &b {n: 1, m: [1, 2]}\nother:\n  <<: *b\n  n: 2\nlist: [*b, *b]\n"
    assert load_yaml_text(text) == yaml.safe_load(text)
    assert load_yaml_text(text)["other"] == {"n": 2, "m": [1, 2]}  # the mapping's own key overrides the merge
    assert load_yaml_text(bomb(3)) == yaml.safe_load(bomb(3))  # 729 strings: below the bound


def test_every_shipped_yaml_file_loads_as_safe_load():
    files = [f for pat in ("configs/**/*.y*ml",
                           "agents/pretrained/*/*/config.yml") for f in glob.glob(str(ROOT / pat), recursive=True)]
    assert len(files) > 30
    for f in files:
        assert load_yaml(f) == yaml.safe_load(Path(f).read_text()), f


def test_recursive_alias_is_refused():
    with pytest.raises(YamlError, match="recursive alias"):
        load_yaml_text("a: &a [1, *a]\n", "r.yaml")


@pytest.mark.parametrize("text,key,line,first", [
    ("a: 1\nb: 2\na: 3\n", "a", 3, 1),
    ("top:\n  mass: {x: 1}\n  other: 2\n  mass: {x: 2}\n", "mass", 4, 2),
    ("m: {b: 1, b: 2}\n", "b", 1, 1),
])
def test_duplicate_key_is_an_error_naming_key_and_lines(text, key, line, first):
    with pytest.raises(YamlError) as e:
        load_yaml_text(text, "d.yaml")
    msg = str(e.value)
    assert f"line {line}: duplicate key {key!r} (first given on line {first})" in msg and e.value.key == key


def test_python_tags_and_bad_yaml_are_one_line_errors():
    with pytest.raises(YamlError, match=r"line 1, column 4: could not determine a constructor.*no Python or custom tags"):
        load_yaml_text("x: !!python/object/apply:os.system ['true']\n", "t.yaml")
    with pytest.raises(YamlError, match=r"line 2, column 1: not valid YAML"):
        load_yaml_text("a: [1, 2\n", "t.yaml")
    with pytest.raises(YamlError) as e:
        load_yaml_text("a: [" + "1, " * 5000 + "\n", "t.yaml")
    assert "\n" not in str(e.value) and len(str(e.value)) <= MAX_MESSAGE


def test_size_missing_and_binary_files(tmp_path):
    big = tmp_path / "big.yaml"
    big.write_text("a: " + "x" * 2000 + "\n")
    with pytest.raises(YamlError, match="big.yaml: YAML file is 2004 bytes; at most 1000"):
        load_yaml(big, max_bytes=1000)
    with pytest.raises(YamlError, match="spec not found"):
        load_yaml(tmp_path / "none.yaml", what="spec")
    (tmp_path / "bin.yaml").write_bytes(b"\xff\xfe\x00a")
    with pytest.raises(YamlError, match="not UTF-8"):
        load_yaml(tmp_path / "bin.yaml")
    assert load_yaml_text("") is None


def test_typed_values_refuse_what_they_must():
    assert yamlio.integer(20, "n") == 20 and yamlio.integer(2.0e6, "n") == 2_000_000
    for bad in (2.9, True, "3", None, float("inf")):
        with pytest.raises(YamlError, match=r"cfg.yaml: n = .*; allowed an integer in \[1, inf\]"):
            yamlio.integer(bad, "n", "cfg.yaml", lo=1)
    with pytest.raises(YamlError, match="seed = -1"):
        yamlio.integer(-1, "seed", lo=0)
    assert yamlio.number(3, "x") == 3.0 and yamlio.number("3e-4", "x") == 3e-4
    for bad in (True, False, "abc", float("nan"), [1]):
        with pytest.raises(YamlError, match="allowed a finite number"):
            yamlio.number(bad, "x")
    assert yamlio.boolean(False, "f") is False
    with pytest.raises(YamlError, match="allowed true or false"):
        yamlio.boolean(1, "f")
    assert yamlio.text("a", "s", choices=("a", "b")) == "a"
    with pytest.raises(YamlError, match="allowed a, b"):
        yamlio.text("c", "s", choices=("a", "b"))


def test_short_cuts_a_huge_value():
    s = yamlio.short(list(range(10_000)))
    assert len(s) <= 60 and s.endswith("...")
