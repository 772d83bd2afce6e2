"""The shipped configuration files (installed as the package ``hydro_envs.configs``; see
:mod:`hydro_envs.config_files`). Data only: nothing here is code."""
