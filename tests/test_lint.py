"""ruff (pyflakes, syntax, complexity of new code) and mypy (the package's types) are clean.

Their settings are in pyproject.toml ([tool.ruff], [tool.mypy]); the lists of exempt files and
modules there must only shrink.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(tool: str, *args: str) -> subprocess.CompletedProcess:
    if importlib.util.find_spec(tool) is None:
        pytest.skip(f"{tool} is not installed (pip install -e '.[test]')")
    return subprocess.run([sys.executable, "-m", tool, *args], cwd=ROOT, capture_output=True, text=True)


def test_ruff_check_is_clean():
    run = _run("ruff", "check", "--no-cache", "--output-format", "concise", ".")
    assert run.returncode == 0, run.stdout + run.stderr


def test_mypy_is_clean_on_the_package():
    run = _run("mypy")  # files, exemptions and missing-stub modules from [tool.mypy]
    assert run.returncode == 0, run.stdout[-5000:] + run.stderr[-2000:]
    assert "Success" in run.stdout


def test_py_typed_is_shipped_only_when_every_module_is_checked():
    config = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    exempt = "ignore_errors = true" in config
    assert (ROOT / "hydro_envs" / "py.typed").exists() is not exempt
