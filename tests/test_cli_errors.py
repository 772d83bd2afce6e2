"""One error convention for every `hydro` subcommand: one line, never a traceback, exit 0/1/2.

A table of bad inputs covers every subcommand (the built-in ones and those found through entry
points: identify, diagnose, benchmark, demo); a hypothesis test feeds random bytes to every
reader a command opens (records, sidecars, configs, presets, run folders). Each bad input must
be refused before any long work, in one ``hydro <command>: error: ...`` line with its exit code.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hydro_envs.cli import main
from hydro_envs.cli_errors import CheckFailed, CliError, Parser, exit_code_for, guarded
from hydro_envs.data.measured import write_measured

ROOT = Path(__file__).resolve().parents[1]
ENV = "hydro_envs/ServoCylinderPosition-v0"
POLICY = ROOT / "agents" / "pretrained" / "servo_cylinder" / "ppo_s0"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    t = 1e-3 * np.arange(3000)
    f = 20 * np.sin(2 * np.pi * 3 * t)
    x = 0.05 + 0.01 * np.sin(2 * np.pi * 3 * t - 1.0)
    write_measured(d / "slider.csv", t, {"f": f, "x": x}, plant="slider")
    write_measured(d / "slider_mm.csv", t, {"f": f, "x": 1e3 * x}, plant="slider")
    write_measured(d / "slider_ms.csv", 1e3 * t, {"f": f, "x": x}, plant="slider", metadata={"sample_rate": "1000"})
    gap = np.r_[t[:1000], t[1000:] + 1.0]
    write_measured(d / "slider_gap.csv", gap, {"f": f, "x": x}, plant="slider")
    u = 0.5 * np.sin(2 * np.pi * 2 * t)
    p = {"u": u, "x": 0.03 + 0.01 * np.sin(2 * np.pi * 2 * t), "p1": 5e6 + 0 * t, "p2": 4e6 + 0 * t}
    write_measured(d / "servo_noarea.csv", t, p, plant="servo_cylinder")
    write_measured(d / "servo_bar.csv", t, dict(p, p1=p["p1"] / 1e5, p2=p["p2"] / 1e5), plant="servo_cylinder")
    part = {"plant": "servo_cylinder", "parameters": {"coulomb_friction": {"value": 40.0, "unit": "N", "source": "t"}}}
    (d / "servo_partial.yaml").write_text(yaml.safe_dump(part))
    (d / "taken.txt").write_text("keep\n")
    (d / "full").mkdir()
    (d / "full" / "old.md").write_text("old\n")
    (d / "dup.yaml").write_text(f"env: {ENV}\nn: 2\nn: 3\n")
    (d / "typed.yaml").write_text(f"env: {ENV}\nn: 2.9\n")
    (d / "tag.yaml").write_text(f"env: {ENV}\nn: !!python/object/apply:os.system ['true']\n")
    (d / "list.yaml").write_text("- 1\n- 2\n")
    bad_run = d / "badrun"
    shutil.copytree(POLICY, bad_run)
    (bad_run / "policy.pt").write_bytes(b"\x80\x04 not torch")
    return d


def _cases(d: Path):
    """(argv, exit code, fragment of the error line)."""
    slider = str(d / "slider.csv")
    bench = ["benchmark", "--env", ENV, "--controllers", "pid", "--n", "2", "--steps", "20", "--no-figures"]
    return [
        (["channels", "warp_drive"], 2, "unknown plant"),
        (["simulate", "hydro_envs/Nope-v0", "--steps", "5", "--out", str(d / "s.csv")], 2, "cannot make"),
        (["simulate", ENV, "--steps", "0", "--out", str(d / "s.csv")], 2, "--steps"),
        (["simulate", ENV, "--steps", "5", "--out", str(d / "r.xlsx")], 2, "xlsx"),
        (["simulate", ENV, "--steps", "5", "--out", str(d / "taken.txt")], 2, "suffix"),
        (["simulate", ENV, "--steps", "5", "--out", slider], 2, "--force"),
        (["simulate", ENV, "--steps", "5", "--amplitude", "abc", "--out", str(d / "s.csv")], 2, "--amplitude"),
        (["validate", "--bogus"], 2, "unrecognized arguments"),
        (["compile", "--only", "nope"], 2, "unknown warm-up"),
        (["nonsense"], 2, "invalid choice"),
        (["identify"], 2, "choose a method"),
        (["identify", "slider"], 2, "--data"),
        (["identify", "slider", "--data", str(d / "missing.csv")], 2, "not found"),
        (["identify", "slider", "--data", str(d / "slider_mm.csv")], 2, "mm"),
        (["identify", "slider", "--data", str(d / "slider_ms.csv")], 2, "sample_rate"),
        (["identify", "slider", "--data", str(d / "slider_gap.csv")], 2, "--allow-gaps"),
        (["identify", "slider", "--data", slider, "--map-file", str(d / "dup.yaml")], 2, "duplicate key"),
        (["identify", "slider", "--data", slider, "--emit-ranges", slider], 2, "input file"),
        (["identify", "slider", "--data", slider, "--emit-ranges", str(d / "taken.txt")], 2, "suffix"),
        (["identify", "arx", "--plant", "slider", "--data", slider, "--input", "f", "--output", "q"], 2, "'q'"),
        (["identify", "arx", "--plant", "warp", "--data", slider, "--input", "f", "--output", "x"], 2, "warp"),
        (["identify", "frf", "--plant", "slider", "--data", str(d / "slider_gap.csv"), "--input", "f", "--output", "x"],
         2, "gap"),
        (["identify", "friction", "--plant", "servo_cylinder", "--data", str(d / "servo_noarea.csv")], 2, "--bore"),
        (["identify", "friction", "--plant", "servo_cylinder", "--data", str(d / "servo_bar.csv"), "--area", "6e-4"],
         2, "bar"),
        (["identify", "friction", "--plant", "servo_cylinder", "--data", slider, "--bore", "0.05"], 2, "--rod"),
        (["identify", "friction", "--plant", "seal_friction", "--data", slider, "--bore", "25"], 2, "0.025 m"),
        (["identify", "greybox", "--plant", "servo_cylinder", "--data", slider, "--fit", "mass", "--set", "x"], 2,
         "NAME=VALUE"),
        (["identify", "greybox", "--plant", "slider", "--data", slider, "--fit", "mass"], 2, "not supported"),
        (["identify", "greybox", "--plant", "servo_cylinder", "--data", str(d / "servo_noarea.csv"), "--fit",
          "mass"], 2, "--nominal-geometry"),
        (["identify", "greybox", "--plant", "servo_cylinder", "--data", str(d / "servo_noarea.csv"), "--fit",
          "mass", "--set", "piston_area=6e-4"], 2, "line_volume_1 [m^3]"),
        (["diagnose", "--plant", "servo_cylinder", "--data", str(d / "servo_noarea.csv")], 2, "--nominal-geometry"),
        (["diagnose", "--plant", "servo_cylinder", "--data", str(d / "servo_noarea.csv"), "--base",
          str(d / "servo_partial.yaml")], 2, "geometry is not listed (piston_area [m^2]"),
        (["diagnose", "--plant", "nope", "--data", slider], 2, "nope"),
        (["diagnose", "--plant", "slider", "--data", str(d / "missing.csv")], 2, "not found"),
        (["diagnose", "--plant", "slider", "--data", slider, "--out", str(d / "taken.txt")], 2, "is a file"),
        (["diagnose", "--plant", "slider", "--data", slider, "--out", str(d / "full")], 2, "--force"),
        (["diagnose", "--plant", "slider", "--data", slider, "--base", str(d / "dup.yaml")], 2, "duplicate key"),
        (["diagnose", "--plant", "slider", "--data", slider, "--base", str(d / "missing.yaml")], 2, "not found"),
        (["diagnose", "--plant", "slider", "--data", str(d / "slider_mm.csv")], 2, "mm"),
        (["benchmark"], 2, "--env"),
        (["benchmark", "--env", "hydro_envs/Nope-v0"], 2, "supports"),
        (bench[:-5] + ["--n", "0"], 2, "--n"),
        (bench + ["--controllers", "nope"], 2, "unknown controller"),
        (["benchmark", "--config", str(d / "missing.yaml")], 2, "no such file"),
        (["benchmark", "--config", str(d / "dup.yaml")], 2, "duplicate key 'n'"),
        (["benchmark", "--config", str(d / "typed.yaml")], 2, "n = 2.9"),
        (["benchmark", "--config", str(d / "tag.yaml")], 2, "constructor"),
        (["benchmark", "--config", str(d / "list.yaml")], 2, "mapping"),
        (bench + ["--out", str(d / "full")], 2, "--force"),
        (bench + ["--out", str(d / "taken.txt")], 2, "is a file"),
        (bench + ["--randomization", str(d / "missing.yaml")], 2, "no such file"),
        (bench + ["--randomization", str(d / "dup.yaml")], 2, "duplicate key"),
        (bench + ["--policy", str(d / "no_run")], 2, "no such run folder"),
        (bench + ["--policy", str(d / "badrun")], 2, "policy.pt"),
        (["demo", "--n", "0"], 2, "--n"),
        (["demo", "--algo", "dqn"], 2, "invalid choice"),
        (["demo", "--out", str(d / "taken.txt")], 2, "is a file"),
        (["demo", "--out", str(d / "full")], 2, "--force"),
    ]


def _check(capsys, argv, code, fragment):
    rc = main(argv)
    err = capsys.readouterr().err
    errors = [ln for ln in err.splitlines() if ": error: " in ln]
    assert "Traceback" not in err, (argv, err)
    assert rc == code, (argv, rc, err)
    assert len(errors) == 1 and errors[0].startswith("hydro"), (argv, err)
    assert fragment.lower() in errors[0].lower(), (argv, errors[0])


def test_every_subcommand_refuses_bad_input_in_one_line(files, capsys):
    cases = _cases(files)
    commands = {argv[0] for argv, _, _ in cases}
    assert commands >= {"channels", "simulate", "validate", "compile", "identify", "diagnose", "benchmark", "demo"}
    for argv, code, fragment in cases:
        _check(capsys, argv, code, fragment)
    assert (files / "taken.txt").read_text() == "keep\n" and (files / "full" / "old.md").read_text() == "old\n"


_READERS = [
    ("record", lambda p, d: ["identify", "slider", "--data", p]),
    ("record (friction)", lambda p, d: ["identify", "friction", "--plant", "servo_cylinder", "--data", p, "--area", "6e-4"]),
    ("record (diagnose)", lambda p, d: ["diagnose", "--plant", "slider", "--data", p]),
    ("sidecar", lambda p, d: ["identify", "slider", "--data", str(d / "slider.csv"), "--map-file", p]),
    ("preset", lambda p, d: ["diagnose", "--plant", "slider", "--data", str(d / "slider.csv"), "--base", p]),
    ("benchmark config", lambda p, d: ["benchmark", "--config", p]),
    ("randomisation spec", lambda p, d: ["benchmark", "--env", ENV, "--controllers", "pid", "--params", "in",
                                          "--n", "2", "--steps", "5", "--no-figures", "--randomization", p]),
]


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(raw=st.one_of(st.binary(max_size=300),
                     st.text(alphabet="t,xfup12[]#:. -\n\r\tm&*!{}", max_size=200).map(str.encode)),
       reader=st.sampled_from(range(len(_READERS))))
def test_random_bytes_in_any_file_a_command_reads_never_escape(files, tmp_path_factory, capsys, raw, reader):
    name, argv = _READERS[reader]
    p = tmp_path_factory.mktemp("fuzz") / ("f.yaml" if name not in ("record", "record (friction)",
                                                                     "record (diagnose)") else "f.csv")
    p.write_bytes(raw)
    rc = main(argv(str(p), files))
    err = capsys.readouterr().err
    assert "Traceback" not in err and rc in (1, 2), (name, raw, rc, err)
    assert [ln for ln in err.splitlines() if ": error: " in ln], (name, raw, err)


def test_the_policy_run_folder_files_fuzzed(files, tmp_path, capsys):
    for target, content in (("config.yml", b"{]"), ("config.yml", b"- a\n"), ("args.json", b"{"),
                            ("args.json", b'{"env_id": 3}'), ("obs_normalization.npz", b"PK junk")):
        run = tmp_path / f"run_{target}_{len(content)}"
        shutil.copytree(POLICY, run)
        (run / target).write_bytes(content)
        _check(capsys, ["benchmark", "--env", ENV, "--controllers", "pid", "--n", "2", "--steps", "5",
                        "--no-figures", "--policy", str(run)], 2, target)


def test_exit_codes_and_one_line_for_unexpected_errors(capsys):
    assert exit_code_for(CliError("x")) == 2 and exit_code_for(CheckFailed("x")) == 1
    assert exit_code_for(FileNotFoundError("x")) == 2 and exit_code_for(OSError(28, "full")) == 1
    assert exit_code_for(ValueError("x")) == 2 and exit_code_for(KeyError("x")) == 2
    assert exit_code_for(RuntimeError("x")) == 1

    def boom(_):
        raise ZeroDivisionError("division by zero")

    assert guarded("hydro x", boom, None) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("hydro x: error: internal error: ZeroDivisionError") and "Traceback" not in err
    with pytest.raises(SystemExit) as e:
        Parser(prog="hydro y").parse_args(["--nope"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("hydro y: error: unrecognized arguments: --nope")
