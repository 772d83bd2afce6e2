"""The source distribution is complete: tests with their data, docs, bench scripts, licence files."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# PEP 517 build of the sdist with the installed backend (what `python -m build --sdist
# --no-isolation` does), for machines without the `build` front end.
_BACKEND = "import sys, setuptools.build_meta as b; print(b.build_sdist(sys.argv[1]))"


# Build artefacts of earlier builds are left out of the copy: setuptools reads an existing
# *.egg-info/SOURCES.txt back into the manifest, which would hide a file MANIFEST.in misses.
_NOT_SOURCE = shutil.ignore_patterns(".git", ".venv", "*.egg-info", "build", "dist", "runs", "out",
                                     "__pycache__", "*.pyc", ".pytest_cache", ".hypothesis", ".mypy_cache",
                                     ".ruff_cache")


def _installed(dist: str) -> bool:
    try:
        importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return False
    return True


def _build_sdist(out: Path) -> Path:
    src = out / "src"
    shutil.copytree(ROOT, src, ignore=_NOT_SOURCE)
    if _installed("build"):  # the distribution, not a ./build folder on sys.path (a wheel build's)
        cmd = [sys.executable, "-m", "build", "--sdist", "--no-isolation", "--outdir", str(out), str(src)]
    elif importlib.util.find_spec("setuptools") is not None:
        cmd = [sys.executable, "-c", _BACKEND, str(out)]
    else:
        pytest.skip("neither the `build` front end nor setuptools is installed: cannot build an sdist")
    run = subprocess.run(cmd, cwd=src, capture_output=True, text=True)
    assert run.returncode == 0, (run.stdout + run.stderr)[-3000:]
    (sdist,) = out.glob("hydro_envs-*.tar.gz")
    return sdist


@pytest.fixture(scope="module")
def sdist(tmp_path_factory) -> Path:
    return _build_sdist(tmp_path_factory.mktemp("sdist"))


@pytest.fixture(scope="module")
def sdist_names(sdist) -> set[str]:
    with tarfile.open(sdist) as tar:
        names = tar.getnames()
    top = names[0].split("/")[0]
    return {n[len(top) + 1:] for n in names if n.startswith(top + "/")}


def test_sdist_carries_the_test_data(sdist_names):
    data = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "tests" / "data").rglob("*") if p.is_file())
    assert len(data) >= 7, data  # two records' README + 5 csv files
    missing = [d for d in data if d not in sdist_names]
    assert not missing, missing


def test_sdist_carries_tests_docs_bench_and_configs(sdist_names):
    for pattern in ("tests/*.py", "docs/*.md", "bench/*.py", "configs/agents/*.yml",
                    "configs/plants/*/randomization.yaml", "configs/base/*.yaml", "setup.py"):
        wanted = {p.relative_to(ROOT).as_posix() for p in ROOT.glob(pattern)}
        assert wanted, pattern
        assert wanted <= sdist_names, (pattern, sorted(wanted - sdist_names))


def test_sdist_carries_licence_and_notice(sdist_names):
    for name in ("LICENSE", "NOTICE.md", "README.md", "pyproject.toml", "PKG-INFO"):
        assert name in sdist_names, name
    assert not any("__pycache__" in n or n.endswith(".pyc") for n in sdist_names)


def test_sdist_metadata_states_the_spdx_licence(sdist):
    with tarfile.open(sdist) as tar:
        member = next(m for m in tar.getmembers() if m.name.count("/") == 1 and m.name.endswith("/PKG-INFO"))
        meta = tar.extractfile(member).read().decode()
    assert "License-Expression: MIT" in meta
    assert "License-File: LICENSE" in meta and "License-File: NOTICE.md" in meta
    assert "example.invalid" not in meta
    assert "Operating System :: POSIX :: Linux" in meta
