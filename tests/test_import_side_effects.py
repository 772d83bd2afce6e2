"""Importing hydro_envs changes nothing in the process or on disk: no environment variable is
set (the OpenMP spin setting waits for the first vector env) and no numba cache file is deleted
(the cache is checked against the sources before the first kernel runs)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# gymnasium's own import sets PYGAME_HIDE_SUPPORT_PROMPT: import it first, measure hydro_envs
_ENV_DIFF = """
import json, os
import gymnasium, numba, numpy
before = dict(os.environ)
import hydro_envs
after = dict(os.environ)
print(json.dumps(sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))))
"""


def _clean_env(**extra: str) -> dict[str, str]:
    drop = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "NUMBA_CACHE_DIR", "NUMBA_DISABLE_JIT")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    return {**env, **extra}


def test_importing_the_package_leaves_os_environ_unchanged():
    env = _clean_env(PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    run = subprocess.run([sys.executable, "-c", _ENV_DIFF], env=env, capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-2000:]
    assert json.loads(run.stdout) == []


def test_importing_deletes_no_cache_file_and_the_first_use_checks_the_cache(tmp_path):
    # a copy of the sources without a fingerprint stamp: the check at first use must purge
    for pkg in ("hydro_envs", "identification"):
        shutil.copytree(ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    marker = tmp_path / "hydro_envs" / "__pycache__" / "stale_kernel.nbi"
    marker.parent.mkdir()
    marker.write_bytes(b"stale")
    code = ("import pathlib, hydro_envs; m = pathlib.Path(%r); print(m.exists()); "
            "from hydro_envs._numba_cache import ensure_fresh_cache; print(ensure_fresh_cache(), m.exists())"
            % str(marker))
    run = subprocess.run([sys.executable, "-c", code], env=_clean_env(PYTHONPATH=str(tmp_path)),
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["True", "True", "False"]  # kept on import, purged at first use
