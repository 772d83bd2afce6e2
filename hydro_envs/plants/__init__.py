"""Plant models: one module per plant (parameters, state layout, numba right-hand side).

Importing this package imports every plant module, which registers its measured-data
channels (:mod:`hydro_envs.data.channels`) and its validation rows
(:mod:`hydro_envs.validation`).
"""

from hydro_envs.plants import servo_cylinder  # noqa: F401
from hydro_envs.plants import ls_compensator  # noqa: F401
from hydro_envs.plants import ls_circuit  # noqa: F401
from hydro_envs.plants import shaking_table  # noqa: F401
from hydro_envs.plants import slider  # noqa: F401
from hydro_envs.plants import rodless_cylinder  # noqa: F401
from hydro_envs.plants import force_actuator  # noqa: F401,E402
