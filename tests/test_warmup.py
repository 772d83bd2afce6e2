"""`hydro compile`: the warm-ups fill numba's disk cache with what a later run calls."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from hydro_envs.cli import main, warmups

REPO = Path(__file__).resolve().parents[1]

_WARM = "from identification.diagnosis.warmup import compile_kernels; compile_kernels(['force_actuator_load'])"
# a different record than the warm-up's: a hidden effect, longer, every round of the loop
_RUN = ("from identification.diagnosis import diagnose\n"
        "from identification.diagnosis.synthetic import hidden_effect_records\n"
        "c = hidden_effect_records('force_actuator_load', 'valve_hysteresis', 7, duration=6.0)\n"
        "r = diagnose('force_actuator_load', [c.fit], [c.holdout], base=c.base.params)\n"
        "print(r.verdict, [e['name'] for e in r.effects])\n")


def _cache_files(cache: Path) -> set[str]:
    return {str(p.relative_to(cache)) for p in cache.rglob("*") if p.suffix in (".nbi", ".nbc")}


def test_diagnosis_warmup_leaves_nothing_to_compile(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path),
               PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    subprocess.run([sys.executable, "-c", _WARM], env=env, check=True, capture_output=True, timeout=600)
    warmed = _cache_files(tmp_path)
    assert warmed, "the warm-up stored no compiled kernel"
    res = subprocess.run([sys.executable, "-c", _RUN], env=env, check=True, capture_output=True, text=True,
                         timeout=600)
    assert "valve_hysteresis" in res.stdout, res.stdout
    assert _cache_files(tmp_path) == warmed  # the diagnosis compiled nothing new


def test_compile_lists_envs_and_diagnosis():
    assert {"envs", "diagnosis"} <= set(warmups())


def test_compile_rejects_an_unknown_warmup(capsys):
    assert main(["compile", "--only", "envs,nonsense"]) == 2
    err = capsys.readouterr().err
    assert "nonsense" in err and "diagnosis" in err
