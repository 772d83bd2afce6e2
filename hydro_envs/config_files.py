"""Where the shipped configuration files live: the top-level ``configs/`` folder.

``configs/`` holds every file the package reads by default and every example a user copies:

==========================  ==========================================================
``plants/<plant>/``         ``randomization.yaml`` (the plant's default domain
                            randomisation), ``presets/*.yaml`` (parameter sets)
``datasheets/*.yaml``       plants from a data sheet (a parameter file with units)
``agents/*.yml``            SB3 hyperparameters per algorithm (rl-baselines3-zoo format);
                            ``agents/residual/`` residual-policy configs
``benchmarks/*.yaml``       ``hydro benchmark --config NAME``
``base/*.yaml``             example ``--base`` files of ``hydro diagnose``
==========================  ==========================================================

In a source checkout it is the folder beside ``hydro_envs/``; in an installed wheel the same
files are the package ``hydro_envs.configs`` (``[tool.setuptools]`` maps it onto ``configs/``),
so they are found from any working directory.
"""

from __future__ import annotations

import functools
from importlib import resources
from pathlib import Path

__all__ = ["config_file", "config_root"]


@functools.lru_cache(maxsize=1)
def config_root() -> Path:
    """The shipped ``configs/`` folder (the installed package data or the checkout's folder;
    a file system path: the package is not run from a zip archive)."""
    try:
        root = Path(str(resources.files("hydro_envs.configs")))
        if root.joinpath("plants").is_dir():
            return root
    except ModuleNotFoundError:
        pass
    here = Path(__file__).resolve().parent.parent / "configs"
    if here.is_dir():
        return here
    raise FileNotFoundError("the shipped configs/ folder is missing: reinstall hydro-envs")


def config_file(*parts: str) -> Path:
    """``configs/<parts...>`` (may not exist: check ``is_file()``)."""
    return config_root().joinpath(*parts)
