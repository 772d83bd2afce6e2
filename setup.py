"""Package list for setuptools (the rest of the metadata is in pyproject.toml): the three
packages and the top-level ``configs/`` folder, installed as ``hydro_envs.configs``."""

from setuptools import find_packages, setup

setup(
    packages=find_packages(include=["hydro_envs*", "identification*", "agents*"]) + ["hydro_envs.configs"],
    package_dir={"hydro_envs.configs": "configs"},
)
