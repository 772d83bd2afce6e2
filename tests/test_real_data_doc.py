"""docs/real-data.md runs as written: every command on the shipped record prints what the page shows.

The page's ``python`` blocks are saved under the file name of their first-line comment
(``# convert.py: ...``); its ``console`` blocks are ``$ command`` lines followed by the expected
output (standard output and error together). Each command runs in a scratch directory that
links the repository's ``tests`` data and the figure script; the output must match the page
line by line, numbers within a relative 1e-4 (the rest of the text exactly), and a command
whose expected output holds an ``error:`` line must fail.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "real-data.md"
RECORD = ROOT / "tests" / "data" / "seal_friction_oring" / "O-ring_5bar_3cycles.csv"
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)


def _blocks():
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(DOC.read_text())]


def _steps():
    """(python files {name: code}, [(command, expected output lines)]) in page order."""
    files, steps = {}, []
    for kind, body in _blocks():
        if kind == "python":
            name = body.splitlines()[0].lstrip("# ").split(":")[0]
            files[name] = body
        elif kind == "console":
            for chunk in re.split(r"^\$ ", body, flags=re.M)[1:]:
                lines = chunk.rstrip("\n").split("\n")
                steps.append((lines[0], lines[1:]))
    return files, steps


def _same(expected: str, actual: str) -> bool:
    if NUMBER.sub("#", expected).rstrip() != NUMBER.sub("#", actual).rstrip():
        return False
    for a, b in zip(NUMBER.findall(expected), NUMBER.findall(actual)):
        x, y = float(a), float(b)
        if abs(x - y) > 1e-4 * max(abs(x), abs(y)) + 1e-12:
            return False
    return True


def test_the_shipped_record_is_small_and_credited():
    assert RECORD.stat().st_size < 200_000
    readme = (RECORD.parent / "README.md").read_text()
    for word in ("CC0", "EvaZillen/3D-printed-pneumatic-actuator", "Citation", "sha256"):
        assert word in readme


def test_the_page_has_every_step():
    files, steps = _steps()
    assert set(files) == {"convert.py", "reference.py", "calibrate.py"}
    cmds = " ".join(c for c, _ in steps)
    for part in ("--bore", "--stroke", "--asymmetric", "--emit-ranges", "reference.py", "real_data_seal.py"):
        assert part in cmds
    assert "figures/real_data_seal.png" in DOC.read_text()


def test_walkthrough_commands_print_what_the_page_shows(tmp_path):
    pytest.importorskip("matplotlib")  # the figure step (the 'plot' extra)
    files, steps = _steps()
    (tmp_path / "tests").symlink_to(ROOT / "tests")
    (tmp_path / "docs" / "figures").mkdir(parents=True)
    (tmp_path / "docs" / "figures" / "real_data_seal.py").symlink_to(ROOT / "docs" / "figures" / "real_data_seal.py")
    for name, code in files.items():
        (tmp_path / name).write_text(code)
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    for cmd, expected in steps:
        argv = shlex.split(cmd)
        if argv[0] == "python":
            argv[0] = sys.executable
        proc = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
        actual = (proc.stdout + proc.stderr).rstrip("\n").split("\n")
        fails = any("error:" in ln for ln in expected)
        assert (proc.returncode != 0) == fails, (cmd, proc.returncode, proc.stdout, proc.stderr)
        assert len(actual) == len(expected), (cmd, actual)
        for e, a in zip(expected, actual):
            assert _same(e, a), (cmd, e, a)
    # the figure: at least 1200 px wide, written where the page shows it
    from PIL import Image

    with Image.open(tmp_path / "docs" / "figures" / "real_data_seal.png") as im:
        assert im.size[0] >= 1200
    assert (ROOT / "docs" / "figures" / "real_data_seal.png").is_file()


def test_same_detects_a_changed_number():
    assert _same("F_c  7.15157  0.879656  N", "F_c  7.15160  0.879656  N")
    assert not _same("F_c  7.15157  0.879656  N", "F_c  7.25157  0.879656  N")
    assert not _same("F_c  7.15157 N", "F_v  7.15157 N")


@pytest.mark.parametrize("bore, area", [(0.025, None)])
def test_doc_numbers_agree_with_the_library(bore, area):
    # the fit and the reference computed in-process agree with the page's 7.15 N and 6.76 N
    sys.path.insert(0, str(ROOT / "docs" / "figures"))
    try:
        import real_data_seal
    finally:
        sys.path.pop(0)
    from identification.friction import fit_friction
    from identification.seal_friction import load_seal_friction, seal_friction_points

    pts = seal_friction_points(load_seal_friction(RECORD, bore=bore))
    assert fit_friction(pts, model="coulomb").parameters["F_c"] == pytest.approx(7.15157, rel=1e-5)
    assert real_data_seal.half_range(RECORD, bore) == pytest.approx(6.76, abs=0.005)
