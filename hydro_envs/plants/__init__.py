"""The plants: one folder per plant (see :mod:`hydro_envs.spec` for its modules), listed in
:mod:`hydro_envs.registry`. Importing this package imports no plant."""
